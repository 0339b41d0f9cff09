//! A fixed workload of the batched `U` for profilers and instruction
//! counts: the 4096 random points and light 0 of `cargo bench --bench ltc`
//! (`unshadowed_batch/quad`), `REPS` times over (default 20).
//!
//! `cargo build --release --example u_profile && valgrind --tool=callgrind
//! target/release/examples/u_profile 20` counts instructions (81,920
//! evaluations; deterministic, unlike time on a shared machine); without
//! valgrind it prints its own ns per evaluation (a hint: take the minimum
//! of several runs).

// The bench's synthetic G-buffer is not used here.
#[allow(dead_code)]
#[path = "../benches/support/u_inputs.rs"]
mod u_inputs;

use glam::Vec3;
use penumbra::shading::SurfacePoint;
use penumbra::shading::u_batch::{
    BatchLight, LANES, LaneCounts, LaneLobes, PixelBatch, lobes_batch,
};
use std::hint::black_box;

fn main() {
    let reps: usize = match std::env::args().nth(1).map(|s| s.parse()) {
        None => 20,
        Some(Ok(n)) => n,
        Some(Err(e)) => {
            eprintln!("u_profile: REPS must be a whole number: {e}");
            std::process::exit(2);
        }
    };
    let inputs = u_inputs::random_points();
    let light = BatchLight::new(&u_inputs::lights()[0]);
    let mut sum = Vec3::ZERO;
    let mut counts = LaneCounts::default();
    let mut out = LaneLobes::default();
    let start = std::time::Instant::now();
    for _ in 0..reps {
        for group in inputs.chunks(LANES) {
            let lanes: [Option<SurfacePoint>; LANES] =
                std::array::from_fn(|l| group.get(l).copied());
            let batch = PixelBatch::new(black_box(&lanes));
            let c = lobes_batch(&batch, &light, &mut out);
            counts.fast += c.fast;
            counts.scalar += c.scalar;
            for l in 0..group.len() {
                let (d, s) = out.lane(l);
                sum += d + s;
            }
        }
    }
    let evals = reps * inputs.len();
    println!(
        "{evals} evaluations, {:.1} ns each; lanes on the scalar path {}; sum of U {sum}",
        start.elapsed().as_nanos() as f64 / evals.max(1) as f64,
        counts.scalar
    );
}

//! A fixed workload of the batched `U` for profilers and instruction
//! counts: the 4096 random points and light 0 of `cargo bench --bench ltc`
//! (`unshadowed_batch/quad`), `REPS` times over (default 20); with a second
//! argument `passN`, the 1280x720 G-buffer and first N lights of
//! `u_pass 1280x720/batched, N lights` instead, once per rep (`pass0`: the
//! per-pixel setup alone, no light; its time is per pixel).
//!
//! Instructions (deterministic, unlike time on a shared machine) under
//! callgrind, which runs no AVX-512 (the AVX2 level of `isa` runs there):
//! `cargo build --release --example u_profile && scripts/valgrind.sh
//! --tool=callgrind target/release/examples/u_profile 20` (81,920
//! evaluations); `PENUMBRA_ISA` picks a level. Without
//! valgrind it prints its own ns per evaluation (a hint: take the minimum
//! of several runs).

#[path = "../benches/support/u_inputs.rs"]
mod u_inputs;

use glam::Vec3;
use penumbra::shading::u_batch::{BatchLight, LaneCounts};

fn main() {
    let reps: usize = match std::env::args().nth(1).map(|s| s.parse()) {
        None => 20,
        Some(Ok(n)) => n,
        Some(Err(e)) => {
            eprintln!("u_profile: REPS must be a whole number: {e}");
            std::process::exit(2);
        }
    };
    // `pass N`: the 1280x720 G-buffer of `u_pass 1280x720/batched, N lights`
    // instead, once per rep.
    let pass: Option<usize> = match std::env::args().nth(2).as_deref() {
        None => None,
        Some(s) => match s.strip_prefix("pass").map(str::parse) {
            Some(Ok(n)) if (0..=4).contains(&n) => Some(n),
            _ => {
                eprintln!("u_profile: the second argument is passN, N in 0..=4");
                std::process::exit(2);
            }
        },
    };
    let inputs = match pass {
        Some(_) => u_inputs::gbuffer(),
        None => u_inputs::random_points(),
    };
    let lights: Vec<BatchLight> = u_inputs::lights()
        .iter()
        .take(pass.unwrap_or(1))
        .map(BatchLight::new)
        .collect();
    let mut sum = Vec3::ZERO;
    let mut counts = LaneCounts::default();
    let start = std::time::Instant::now();
    for _ in 0..reps {
        sum += u_inputs::batched_pass(&inputs, &lights, &mut counts);
    }
    // With no light (`pass0`), per pixel.
    let evals = reps * inputs.len() * lights.len().max(1);
    println!(
        "{evals} evaluations, {:.1} ns each; lanes on the scalar path {}; sum of U {sum}",
        start.elapsed().as_nanos() as f64 / evals.max(1) as f64,
        counts.scalar
    );
}

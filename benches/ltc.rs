//! Speed of the analytic U: `cargo bench --bench ltc`.
//! - `unshadowed/quad`: one evaluation for a quad light, random shading
//!   points, views and roughness (inputs precomputed).
//! - `unshadowed_prepared/quad`: the same with the light prepared once
//!   (`ShadingLight`), as the renderer calls it.
//! - `u_pass/N`: a U pass over a synthetic 1280x720 G-buffer (a plane with
//!   varying normals) with N prepared quad lights, one thread.
//! - `unshadowed_batch/quad` and `u_pass 1280x720/batched, N lights`: the
//!   same through the batched path the renderer uses (`shading::u_batch`,
//!   `LANES` pixels at a time; each group's frame, LTC cell and correction
//!   constants are set up once for all its lights). The share of lanes the
//!   batch hands to the scalar path is printed once.

#[path = "support/u_inputs.rs"]
mod u_inputs;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use penumbra::shading::u_batch::{BatchLight, LaneCounts};
use penumbra::shading::{ShadingLight, SurfacePoint, unshadowed, unshadowed_prepared};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let ls = u_inputs::lights();
    let inputs = u_inputs::random_points();
    // The per-evaluation bench uses light 0, which must face every point
    // (a culled light would only time the early exit).
    assert!(
        inputs
            .iter()
            .all(|sp| ls[0].normal.dot(sp.p - ls[0].vertices[0]) > 0.0)
    );
    c.bench_function("unshadowed/quad (ns per evaluation = time / 4096)", |b| {
        b.iter(|| {
            let mut acc = Vec3::ZERO;
            for sp in &inputs {
                acc += unshadowed(black_box(sp), &ls[0]);
            }
            acc
        })
    });
    let prepared: Vec<ShadingLight> = ls.iter().map(ShadingLight::new).collect();
    c.bench_function(
        "unshadowed_prepared/quad (ns per evaluation = time / 4096)",
        |b| {
            b.iter(|| {
                let mut acc = Vec3::ZERO;
                for sp in &inputs {
                    acc += unshadowed_prepared(black_box(sp), &prepared[0]);
                }
                acc
            })
        },
    );

    let batch_lights: Vec<BatchLight> = ls.iter().map(BatchLight::new).collect();
    // The batched U over the same inputs, `LANES` at a time.
    let u_batch = |points: &[SurfacePoint], n: usize, counts: &mut LaneCounts| {
        u_inputs::batched_pass(points, &batch_lights[..n], counts)
    };
    let mut counts = LaneCounts::default();
    c.bench_function(
        "unshadowed_batch/quad (ns per evaluation = time / 4096)",
        |b| b.iter(|| u_batch(&inputs, 1, &mut counts)),
    );

    let g = u_inputs::gbuffer();
    let mut fallback = LaneCounts::default();
    u_batch(&g, 4, &mut fallback);
    eprintln!(
        "u_batch lanes on the 1280x720 G-buffer, 4 lights: fast {}, scalar {} ({:.2} %); on the 4096 inputs, light 0: {:.2} % scalar",
        fallback.fast,
        fallback.scalar,
        100.0 * fallback.scalar as f64 / (fallback.fast + fallback.scalar) as f64,
        100.0 * counts.scalar as f64 / (counts.fast + counts.scalar).max(1) as f64
    );
    let mut group = c.benchmark_group("u_pass 1280x720");
    group.sample_size(10);
    for n in [1usize, 2, 4] {
        group.bench_function(format!("{n} lights"), |b| {
            b.iter(|| {
                let mut acc = Vec3::ZERO;
                for sp in &g {
                    for l in &prepared[..n] {
                        acc += unshadowed_prepared(black_box(sp), l);
                    }
                }
                acc
            })
        });
    }
    for n in [1usize, 2, 4] {
        group.bench_function(format!("batched, {n} lights"), |b| {
            b.iter(|| u_batch(&g, n, &mut LaneCounts::default()))
        });
    }
    group.finish();
}

#[path = "support/quiet.rs"]
mod quiet;

criterion_group! {
    name = benches;
    config = quiet::criterion();
    targets = bench
}
criterion_main!(benches);

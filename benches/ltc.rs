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

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec3, vec3};
use penumbra::scene::Light;
use penumbra::shading::u_batch::{
    BatchLight, LANES, LaneCounts, LaneLobes, PixelBatch, lobes_batch,
};
use penumbra::shading::{ShadingLight, SurfacePoint, unshadowed, unshadowed_prepared};
use std::hint::black_box;

/// Small deterministic generator (xorshift) so inputs are reproducible.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn quad(c: Vec3, u: Vec3, v: Vec3) -> Light {
    let vertices = vec![c - u - v, c + u - v, c + u + v, c - u + v];
    let n = u.cross(v);
    Light {
        vertices,
        radiance: Vec3::splat(5.0),
        two_sided: false,
        normal: n.normalize(),
        area: 4.0 * n.length(),
        quad: Some((c, u, v)),
    }
}

/// Four quads, all emitting toward the plane y = 0 around the origin.
fn lights() -> Vec<Light> {
    vec![
        quad(
            vec3(0.0, 3.0, 0.0),
            vec3(1.0, 0.0, 0.0),
            vec3(0.0, 0.0, 0.5),
        ),
        quad(
            vec3(-3.0, 1.5, 1.0),
            vec3(0.0, 0.0, 0.6),
            vec3(0.0, -0.4, 0.0),
        ),
        quad(
            vec3(2.5, 2.0, -2.0),
            vec3(0.3, 0.0, 0.3),
            vec3(0.0, 0.5, 0.0),
        ),
        quad(
            vec3(0.0, 1.0, 4.0),
            vec3(-1.5, 0.0, 0.0),
            vec3(0.0, 0.7, 0.0),
        ),
    ]
}

/// A 1280x720 "G-buffer": points on the plane y = 0 seen from a camera at
/// (0, 2, -6), normals wobbling around +Y, roughness varying across it.
fn gbuffer() -> Vec<SurfacePoint> {
    let (w, h) = (1280, 720);
    let eye = vec3(0.0, 2.0, -6.0);
    let mut out = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            let p = vec3(
                (i as f32 / w as f32 - 0.5) * 10.0,
                0.0,
                (j as f32 / h as f32 - 0.5) * 8.0,
            );
            let n = vec3(
                0.2 * (i as f32 * 0.05).sin(),
                1.0,
                0.2 * (j as f32 * 0.07).cos(),
            )
            .normalize();
            out.push(SurfacePoint {
                p,
                n,
                wo: (eye - p).normalize(),
                diffuse: vec3(0.5, 0.4, 0.3),
                specular: Vec3::splat(0.04),
                roughness: 0.05 + 0.9 * i as f32 / w as f32,
            });
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let ls = lights();
    let mut rng = Rng(0x9e3779b97f4a7c15);
    let inputs: Vec<SurfacePoint> = (0..4096)
        .map(|_| {
            let p = vec3(rng.next() * 6.0 - 3.0, 0.0, rng.next() * 6.0 - 3.0);
            let n = vec3(rng.next() - 0.5, 2.0, rng.next() - 0.5).normalize();
            let eye = vec3(rng.next() * 10.0 - 5.0, 0.5 + rng.next() * 4.0, -6.0);
            SurfacePoint {
                p,
                n,
                wo: (eye - p).normalize(),
                diffuse: Vec3::splat(0.5),
                specular: Vec3::splat(0.04),
                roughness: rng.next(),
            }
        })
        .collect();
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
    // The batched U over the same inputs, 8 at a time.
    let u_batch = |points: &[SurfacePoint], n: usize, counts: &mut LaneCounts| {
        let mut acc = Vec3::ZERO;
        let mut out = LaneLobes::default();
        for group in points.chunks(LANES) {
            let lanes: [Option<SurfacePoint>; LANES] =
                std::array::from_fn(|l| group.get(l).copied());
            let batch = PixelBatch::new(black_box(&lanes));
            for bl in &batch_lights[..n] {
                let c = lobes_batch(&batch, bl, &mut out);
                counts.fast += c.fast;
                counts.scalar += c.scalar;
                for l in 0..group.len() {
                    let (d, s) = out.lane(l);
                    acc += d + s;
                }
            }
        }
        acc
    };
    let mut counts = LaneCounts::default();
    c.bench_function(
        "unshadowed_batch/quad (ns per evaluation = time / 4096)",
        |b| b.iter(|| u_batch(&inputs, 1, &mut counts)),
    );

    let g = gbuffer();
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

criterion_group!(benches, bench);
criterion_main!(benches);

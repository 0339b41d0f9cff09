//! Inputs of the `U` benchmarks (`benches/ltc.rs`) and of the profiling
//! workload `examples/u_profile.rs`: both time the same lights and points.

use glam::{Vec3, vec3};
use penumbra::scene::Light;
use penumbra::shading::SurfacePoint;
use penumbra::shading::u_batch::{
    BatchLight, LANES, LaneCounts, LaneLobes, PixelBatch, lobes_batch,
};
use std::hint::black_box;

/// Small deterministic generator (xorshift) so inputs are reproducible.
pub struct Rng(pub u64);
impl Rng {
    pub fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

pub fn quad(c: Vec3, u: Vec3, v: Vec3) -> Light {
    Light::quad(c, u, v, Vec3::splat(5.0)).expect("a bench quad spans an area")
}

/// Four quads, all emitting toward the plane y = 0 around the origin.
pub fn lights() -> Vec<Light> {
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
pub fn gbuffer() -> Vec<SurfacePoint> {
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

/// 4096 shading points on the plane y = 0 under the lights, with random
/// normals, views and roughness (all facing light 0).
pub fn random_points() -> Vec<SurfacePoint> {
    let mut rng = Rng(0x9e3779b97f4a7c15);
    (0..4096)
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
        .collect()
}

/// The batched `U` of `lights` over `points`, `LANES` pixels at a time, each
/// batch set up once for all its lights (as the renderer runs it): the sum
/// of every lane's `U`; the lanes' paths are added to `counts`.
pub fn batched_pass(
    points: &[SurfacePoint],
    lights: &[BatchLight],
    counts: &mut LaneCounts,
) -> Vec3 {
    let mut acc = Vec3::ZERO;
    let mut out = LaneLobes::default();
    for group in points.chunks(LANES) {
        let lanes: [Option<SurfacePoint>; LANES] = std::array::from_fn(|l| group.get(l).copied());
        let batch = PixelBatch::new(black_box(&lanes));
        for light in lights {
            let c = lobes_batch(&batch, light, &mut out);
            counts.fast += c.fast;
            counts.scalar += c.scalar;
            for l in 0..group.len() {
                let (d, s) = out.lane(l);
                acc += d + s;
            }
        }
    }
    acc
}

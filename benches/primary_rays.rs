//! Raw Embree throughput on one thread: camera rays as single rays vs 4x4
//! coherent 16-packets, and shadow rays as single rays vs 16-packets, on a
//! ~1M-triangle displaced grid filling a 1280x720 frame.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use penumbra::embree::{
    Device, GeometryRole, Rays16, Scene, SceneBuilder, Vec3, set_flush_denormals,
};

const W: usize = 1280;
const H: usize = 720;
/// 708^2 * 2 = 1,002,528 triangles.
const GRID: usize = 708;

/// A bumpy height field over [-1, 1]^2 (y up), so shadow rays are partly blocked.
fn displaced_grid() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let n = GRID + 1;
    let mut positions = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let x = i as f32 / GRID as f32 * 2.0 - 1.0;
            let z = j as f32 / GRID as f32 * 2.0 - 1.0;
            let y = 0.08 * (9.0 * x).sin() * (7.0 * z).cos() + 0.03 * (31.0 * x + 17.0 * z).sin();
            positions.push(Vec3::new(x, y, z));
        }
    }
    let mut indices = Vec::with_capacity(GRID * GRID * 2);
    for j in 0..GRID {
        for i in 0..GRID {
            let a = (j * n + i) as u32;
            let b = a + 1;
            let c = a + n as u32;
            let d = c + 1;
            indices.push([a, c, b]);
            indices.push([b, c, d]);
        }
    }
    (positions, indices)
}

/// Pinhole camera above the grid looking down at it; the grid fills the frame.
struct Camera {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
}

impl Camera {
    fn new() -> Self {
        // Steep enough that every pixel sees the grid: misses would be free
        // rays and inflate the throughput.
        let eye = Vec3::new(0.0, 1.0, 0.25);
        let forward = (Vec3::new(0.0, 0.0, 0.0) - eye).normalize();
        let right = forward.cross(Vec3::Y).normalize();
        let up = right.cross(forward);
        let tan_half = (25.0f32).to_radians().tan();
        let aspect = W as f32 / H as f32;
        Camera {
            eye,
            forward,
            right: right * tan_half * aspect,
            up: up * tan_half,
        }
    }
    fn dir(&self, px: usize, py: usize) -> Vec3 {
        let sx = (px as f32 + 0.5) / W as f32 * 2.0 - 1.0;
        let sy = 1.0 - (py as f32 + 0.5) / H as f32 * 2.0;
        (self.forward + self.right * sx + self.up * sy).normalize()
    }
}

/// Camera rays as 4x4-pixel 16-packets, in tile order.
fn primary_packets(cam: &Camera) -> Vec<Rays16> {
    let mut packets = Vec::with_capacity(W * H / 16);
    for by in (0..H).step_by(4) {
        for bx in (0..W).step_by(4) {
            let mut p = Rays16::new();
            for k in 0..16 {
                p.set(
                    k,
                    cam.eye,
                    cam.dir(bx + k % 4, by + k / 4),
                    0.0,
                    f32::INFINITY,
                );
            }
            packets.push(p);
        }
    }
    packets
}

/// One shadow ray per pixel from the visible surface toward a random point on
/// a square light, packed 4x4 like a renderer would: origins coherent,
/// directions not.
fn shadow_packets(scene: &Scene<'_>, primary: &[Rays16]) -> Vec<Rays16> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    primary
        .iter()
        .map(|p| {
            let hits = scene.intersect16(p, true);
            let mut s = Rays16::new();
            for k in 0..16 {
                if !hits.is_hit(k) {
                    continue;
                }
                let org = Vec3::new(p.ox[k], p.oy[k], p.oz[k])
                    + Vec3::new(p.dx[k], p.dy[k], p.dz[k]) * hits.t[k];
                let ng = Vec3::new(hits.ngx[k], hits.ngy[k], hits.ngz[k]).normalize();
                let org = org + ng * 1e-4;
                let light = Vec3::new(rnd() * 1.6 - 0.8, 0.35, rnd() * 1.6 - 0.8);
                let d = light - org;
                s.set(k, org, d, 0.0, 0.999);
            }
            s
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    set_flush_denormals();
    let device = Device::new().expect("Embree device");
    let (positions, indices) = displaced_grid();
    let mut builder = SceneBuilder::new(&device).unwrap();
    builder
        .add_triangles(&positions, &indices, GeometryRole::Occluder)
        .unwrap();
    let scene = builder.commit().unwrap();
    let cam = Camera::new();
    let primary = primary_packets(&cam);
    let shadow = shadow_packets(&scene, &primary);
    let primary_misses: usize = primary
        .iter()
        .map(|p| {
            (0..16)
                .filter(|&k| !scene.intersect16(p, true).is_hit(k) && p.is_active(k))
                .count()
        })
        .sum();
    let shadow_rays: u64 = shadow.iter().map(|s| s.active.count_ones() as u64).sum();
    let occluded: u64 = shadow
        .iter()
        .map(|s| scene.occluded16(s).count_ones() as u64)
        .sum();
    eprintln!(
        "scene: {} triangles (Embree {}); primary misses: {primary_misses} of {}; shadow rays: {shadow_rays}, occluded: {occluded}",
        indices.len(),
        device.library_version(),
        W * H
    );

    let mut g = c.benchmark_group("primary_1280x720");
    g.sample_size(10)
        .measurement_time(std::time::Duration::from_secs(4))
        .warm_up_time(std::time::Duration::from_secs(1));
    g.throughput(Throughput::Elements((W * H) as u64));
    g.bench_function("intersect1", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for py in 0..H {
                for px in 0..W {
                    hits += scene
                        .intersect1(cam.eye, cam.dir(px, py), 0.0, f32::INFINITY)
                        .is_some() as u32;
                }
            }
            black_box(hits)
        })
    });
    g.bench_function("intersect16_coherent", |b| {
        b.iter(|| {
            let mut hits = 0u32;
            for p in &primary {
                let h = scene.intersect16(p, true);
                hits += h.geom_id.iter().filter(|&&g| g != u32::MAX).count() as u32;
            }
            black_box(hits)
        })
    });
    g.finish();

    let mut g = c.benchmark_group("shadow_random");
    g.sample_size(10)
        .measurement_time(std::time::Duration::from_secs(4))
        .warm_up_time(std::time::Duration::from_secs(1));
    g.throughput(Throughput::Elements(shadow_rays));
    g.bench_function("occluded1", |b| {
        b.iter(|| {
            let mut n = 0u32;
            for s in &shadow {
                for k in 0..16 {
                    if s.is_active(k) {
                        let org = Vec3::new(s.ox[k], s.oy[k], s.oz[k]);
                        let dir = Vec3::new(s.dx[k], s.dy[k], s.dz[k]);
                        n += scene.occluded1(org, dir, s.tnear[k], s.tfar[k]) as u32;
                    }
                }
            }
            black_box(n)
        })
    });
    g.bench_function("occluded16", |b| {
        b.iter(|| {
            black_box(
                shadow
                    .iter()
                    .map(|s| scene.occluded16(s).count_ones())
                    .sum::<u32>(),
            )
        })
    });
    g.finish();
}

#[path = "support/quiet.rs"]
mod quiet;

criterion_group! {
    name = benches;
    config = quiet::criterion();
    targets = bench
}
criterion_main!(benches);

//! One denoise call at 1280x720 on a synthetic plane with soft shadows of a
//! few discs (penumbra rings, fully shadowed cores, lit elsewhere) at 1 spp:
//! `cold` has no history (the most filtering), `warm` a full history (the
//! steady state of a static view). Single thread and all threads.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use penumbra::denoise::{DenoiseSettings, Denoiser, GuideBuffers};
use std::time::{Duration, Instant};

const W: u32 = 1280;
const H: u32 = 720;

struct Data {
    pos: Vec<Vec3>,
    normal: Vec<Vec3>,
    depth: Vec<f32>,
    prev_pixel: Vec<Vec2>,
    prev_valid: Vec<bool>,
    u: Vec<Vec3>,
    /// A few noise realisations, cycled so a warm history sees real variance.
    un: Vec<Vec<Vec3>>,
    sn: Vec<Vec<Vec3>>,
}

const REALISATIONS: usize = 4;

impl Data {
    fn guide(&self) -> GuideBuffers<'_> {
        GuideBuffers {
            width: W,
            height: H,
            position: &self.pos,
            normal: &self.normal,
            depth: &self.depth,
            prev_pixel: &self.prev_pixel,
            prev_valid: &self.prev_valid,
            u: &self.u,
            lobe: &[],
        }
    }
}

fn hash(mut z: u64) -> f32 {
    z = z.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
}

/// A floor seen from above at an angle; discs cast shadows with a core of
/// radius r and a penumbra ring of width r / 2.
fn data() -> Data {
    let n = (W * H) as usize;
    let discs = [
        (300.0, 200.0, 90.0),
        (800.0, 400.0, 140.0),
        (1100.0, 150.0, 60.0),
        (500.0, 600.0, 110.0),
    ];
    let mut d = Data {
        pos: Vec::with_capacity(n),
        normal: vec![Vec3::Y; n],
        depth: Vec::with_capacity(n),
        prev_pixel: Vec::with_capacity(n),
        prev_valid: vec![true; n],
        u: Vec::with_capacity(n),
        un: (0..REALISATIONS).map(|_| Vec::with_capacity(n)).collect(),
        sn: (0..REALISATIONS).map(|_| Vec::with_capacity(n)).collect(),
    };
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let dir = Vec3::new(
                (x as f32 + 0.5 - W as f32 / 2.0) / H as f32,
                (H as f32 / 2.0 - y as f32 - 0.5) / H as f32 - 0.6,
                -1.0,
            );
            let p = dir * (2.0 / -dir.y);
            d.pos.push(p);
            d.depth.push(p.length());
            d.prev_pixel.push(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            d.u.push(Vec3::splat(1.0 / (1.0 + 0.1 * p.length_squared())));
            let mut vis = 1.0f32;
            for (cx, cy, r) in discs {
                let dist = ((x as f32 - cx).powi(2) + (y as f32 - cy).powi(2)).sqrt();
                vis = vis.min(((dist - r) / (0.5 * r)).clamp(0.0, 1.0));
            }
            for k in 0..REALISATIONS {
                let s = (i * REALISATIONS + k) as u64 * 4;
                let un = d.u[i] * Vec3::new(0.5 + hash(s), 0.5 + hash(s + 1), 0.5 + hash(s + 2));
                let v = if hash(s + 3) < vis { 1.0 } else { 0.0 };
                d.un[k].push(un);
                d.sn[k].push(un * v);
            }
        }
    }
    d
}

fn bench(c: &mut Criterion) {
    let data = data();
    let settings = DenoiseSettings::default();
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut group = c.benchmark_group("denoise_1280x720");
    group.sample_size(20);
    for threads in [1, all] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut den = Denoiser::new(W, H);
        let (mut un, mut sn) = (data.un[0].clone(), data.sn[0].clone());
        let mut frame = 0usize;
        for warm in [false, true] {
            let name = format!("{}_{threads}t", if warm { "warm" } else { "cold" });
            if warm {
                // Fill the history to its cap.
                for _ in 0..40 {
                    frame += 1;
                    un.copy_from_slice(&data.un[frame % REALISATIONS]);
                    sn.copy_from_slice(&data.sn[frame % REALISATIONS]);
                    pool.install(|| den.denoise(&data.guide(), &mut un, &mut sn, &settings));
                }
            }
            group.bench_function(&name, |b| {
                b.iter_custom(|iters| {
                    let mut total = Duration::ZERO;
                    for _ in 0..iters {
                        frame += 1;
                        un.copy_from_slice(&data.un[frame % REALISATIONS]);
                        sn.copy_from_slice(&data.sn[frame % REALISATIONS]);
                        if !warm {
                            den.reset();
                        }
                        let t = Instant::now();
                        let st = pool
                            .install(|| den.denoise(&data.guide(), &mut un, &mut sn, &settings));
                        total += t.elapsed();
                        std::hint::black_box(st);
                    }
                    total
                })
            });
            let st = pool.install(|| {
                frame += 1;
                un.copy_from_slice(&data.un[frame % REALISATIONS]);
                sn.copy_from_slice(&data.sn[frame % REALISATIONS]);
                if !warm {
                    den.reset();
                }
                den.denoise(&data.guide(), &mut un, &mut sn, &settings)
            });
            eprintln!(
                "{name}: temporal {:.2} ms, spatial {:.2} ms, tiles skipped {}/{}, levels {}",
                st.temporal_ms, st.spatial_ms, st.tiles_skipped, st.tiles_total, st.levels
            );
        }
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

//! One denoise call at 1280x720 on a synthetic plane with soft shadows of a
//! few discs (penumbra rings, fully shadowed cores, lit elsewhere) at 1 spp:
//! `cold` has no history (the most filtering), `warm` a full history (the
//! steady state of a static view). Single thread and all threads.
//!
//! And the output pass of the viewer's dynamic resolution: a 320x180 frame
//! of the same plane upscaled to 1280x720 (`Upscale::resolve_rows`) with the
//! display transform fused, for a still camera and for one whose motion
//! vectors move every pixel (the history reprojected and clamped).

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use penumbra::denoise::{
    CameraMotion, DenoiseSettings, Denoiser, GuideBuffers, ResolveSettings, Upscale,
};
use penumbra::display::DisplayMap;
use rayon::prelude::*;
use std::time::{Duration, Instant};

const W: u32 = 1280;
const H: u32 = 720;

struct Data {
    width: u32,
    height: u32,
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
            width: self.width,
            height: self.height,
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
fn data(w: u32, h: u32) -> Data {
    let n = (w * h) as usize;
    // The discs' pixel coordinates are the 1280x720 frame's.
    let k = W as f32 / w as f32;
    let discs = [
        (300.0, 200.0, 90.0),
        (800.0, 400.0, 140.0),
        (1100.0, 150.0, 60.0),
        (500.0, 600.0, 110.0),
    ];
    let mut d = Data {
        width: w,
        height: h,
        pos: Vec::with_capacity(n),
        normal: vec![Vec3::Y; n],
        depth: Vec::with_capacity(n),
        prev_pixel: Vec::with_capacity(n),
        prev_valid: vec![true; n],
        u: Vec::with_capacity(n),
        un: (0..REALISATIONS).map(|_| Vec::with_capacity(n)).collect(),
        sn: (0..REALISATIONS).map(|_| Vec::with_capacity(n)).collect(),
    };
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let dir = Vec3::new(
                (x as f32 + 0.5 - w as f32 / 2.0) / h as f32,
                (h as f32 / 2.0 - y as f32 - 0.5) / h as f32 - 0.6,
                -1.0,
            );
            let p = dir * (2.0 / -dir.y);
            d.pos.push(p);
            d.depth.push(p.length());
            d.prev_pixel.push(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            d.u.push(Vec3::splat(1.0 / (1.0 + 0.1 * p.length_squared())));
            let mut vis = 1.0f32;
            for (cx, cy, r) in discs {
                let dist = ((x as f32 * k - cx).powi(2) + (y as f32 * k - cy).powi(2)).sqrt();
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
    let data = data(W, H);
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

/// Render pixels the moving camera's motion vectors shift every pixel by:
/// (1.25, 0.75) output pixels at a quarter scale, a fraction of a pixel on
/// both axes, so that every output pixel's path back through the frames
/// crosses the samples of every jitter position (a whole number of output
/// pixels a frame, even on one axis, left half the output without a sample
/// for good).
const SHIFT: Vec2 = Vec2::new(0.3125, 0.1875);
/// Frames run before a moving camera is timed: a steady state, the history
/// as full as its cap lets it be.
const MOVING_WARM_UP: usize = 64;

fn upscale(c: &mut Criterion) {
    let (rw, rh) = (W / 4, H / 4);
    let mut still = data(rw, rh);
    let color: Vec<Vec3> = still
        .u
        .iter()
        .zip(&still.sn[0])
        .map(|(u, s)| *u * s.x.min(1.0))
        .collect();
    let mut moving = data(rw, rh);
    for p in &mut moving.prev_pixel {
        *p += SHIFT;
    }
    let map = DisplayMap::new(1.0);
    let mut pixels = vec![0u32; (W * H) as usize];
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut group = c.benchmark_group("upscale_1280x720_from_320x180");
    group.sample_size(30);
    for threads in [1, all] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        for (name, d, motion) in [
            ("still", &mut still, CameraMotion::Still),
            ("moving", &mut moving, CameraMotion::Moved),
        ] {
            let mut up = Upscale::new(W, H);
            let mut frame = 0usize;
            // A 4x4 stratified jitter, as the frames' (0,m,2)-net covers a
            // render pixel; 16 frames first so that a still camera's every
            // output pixel holds samples.
            let jitter = |k: usize| {
                Vec2::new(
                    ((k * 5 + 1) % 4) as f32 * 0.25 + 0.125,
                    ((k / 4 * 3 + k) % 4) as f32 * 0.25 + 0.125,
                )
            };
            let once = |up: &mut Upscale, frame: usize, pixels: &mut [u32]| {
                up.resolve_rows(
                    &d.guide(),
                    &color,
                    jitter(frame),
                    Some(motion),
                    &ResolveSettings::default(),
                    &DenoiseSettings::default(),
                    &[],
                    pixels.par_chunks_mut(W as usize),
                    |row: &mut &mut [u32], t: &[[f32; 4]], changed: bool| {
                        if changed {
                            map.row(t, row)
                        }
                    },
                )
            };
            let warm_up = match motion {
                CameraMotion::Moved => MOVING_WARM_UP,
                _ => 16,
            };
            for _ in 0..warm_up {
                frame += 1;
                pool.install(|| once(&mut up, frame, &mut pixels));
            }
            let empty = up.history_len().iter().filter(|&&n| n <= 0.0).count();
            eprintln!(
                "{name}, {threads} thread(s): {empty} of {} output pixels hold no sample after {warm_up} frames",
                W * H
            );
            group.bench_function(format!("{name}_{threads}t"), |b| {
                b.iter(|| {
                    frame += 1;
                    pool.install(|| once(&mut up, frame, &mut pixels));
                })
            });
        }
    }
    group.finish();
}

#[path = "support/quiet.rs"]
mod quiet;

criterion_group! {
    name = benches;
    config = quiet::criterion();
    targets = bench, upscale
}
criterion_main!(benches);

//! The denoiser's figures for docs/denoiser.md: relMSE against `reference` for
//! ratio / stochastic x TAA (jitter + colour resolve) on / off x denoise
//! on / off x 1, 4, 16 static frames at 1 spp, the frame-to-frame flicker of
//! the ratio in penumbrae on an orbiting camera, and the denoiser's and the
//! resolve's milliseconds:
//! `cargo run --release --example denoise_table -- scenes/room.toml 320 180 1024`
//! (scene, width, height, reference spp; all cores).

use glam::Vec3;
use penumbra::denoise::luminance;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, PixelKind, RenderSettings, World};
use penumbra::report::stats::{bilinear_taps, interior, median, rel_mse, rel_mse_masked};
use penumbra::scene::{Camera, Scene};
use std::path::Path;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("scenes/room.toml", String::as_str);
    let width: u32 = args.get(2).map_or(Ok(320), |s| s.parse())?;
    let height: u32 = args.get(3).map_or(Ok(180), |s| s.parse())?;
    let ref_spp: u32 = args.get(4).map_or(Ok(1024), |s| s.parse())?;
    let scene = Scene::load(Path::new(path))?;
    let camera = scene.camera;
    let device = Device::new()?;
    let world = World::build(&device, scene)?;
    let pool = embree::thread_pool(0)?;
    let settings = |mode, spp, seed, denoise, taa| RenderSettings {
        mode,
        spp,
        seed,
        denoise,
        taa,
        ..RenderSettings::default()
    };
    // Renders one frame per camera with one frame state; `each` sees every
    // frame with its wall, denoiser and resolve milliseconds.
    let run = |cams: &[Camera], s: RenderSettings, each: &mut dyn FnMut(&Frame, [f64; 3])| {
        let mut frame = Frame::new(width, height);
        for cam in cams {
            let t = pool.install(|| frame.render(&world, cam, &s));
            each(&frame, [t.wall * 1e3, t.denoise * 1e3, t.resolve * 1e3]);
        }
        frame
    };

    let t = Instant::now();
    let reference = run(
        &[camera],
        settings(Mode::Reference, ref_spp, 0x5eed, false, false),
        &mut |_, _| {},
    );
    println!(
        "{path} {width}x{height}: reference {ref_spp} spp in {:.1} s",
        t.elapsed().as_secs_f64()
    );
    let inside = interior(width, height, &reference.gbuf);
    // The floor under every pixel-centred frame: `reference` averages each
    // pixel's area (jittered camera rays), the other modes shade its centre,
    // so even the converged unbiased estimator differs from it by this much.
    let centred = run(
        &[camera],
        settings(Mode::Stochastic, ref_spp, 0x5eed, false, false),
        &mut |_, _| {},
    );
    println!(
        "floor: stochastic at {ref_spp} spp, undenoised (pixel centres) vs reference: relMSE {:.3e}, interior {:.3e}",
        rel_mse(&centred.color, &reference.color),
        rel_mse_masked(&centred.color, &reference.color, &inside)
    );

    println!(
        "\nstatic camera, 1 spp per frame; relMSE of the last frame; ms: median per frame (denoiser, resolve alone)"
    );
    println!(
        "{:<12} {:>4} {:>7} {:>7} {:>11} {:>16} {:>9} {:>11} {:>11}",
        "mode",
        "taa",
        "denoise",
        "frames",
        "relMSE",
        "relMSE interior",
        "ms",
        "denoise ms",
        "resolve ms"
    );
    for mode in [Mode::Ratio, Mode::Stochastic] {
        for taa in [false, true] {
            for denoise in [false, true] {
                for frames in [1usize, 4, 16] {
                    let mut ms: [Vec<f64>; 3] = Default::default();
                    let f = run(
                        &vec![camera; frames],
                        settings(mode, 1, 1, denoise, taa),
                        &mut |_, t| {
                            for (m, v) in ms.iter_mut().zip(t) {
                                m.push(v);
                            }
                        },
                    );
                    let on = |b: bool| if b { "on" } else { "off" };
                    println!(
                        "{:<12} {:>4} {:>7} {:>7} {:>11.3e} {:>16.3e} {:>9.1} {:>11.2} {:>11.2}",
                        mode.name(),
                        on(taa),
                        on(denoise),
                        frames,
                        rel_mse(&f.color, &reference.color),
                        rel_mse_masked(&f.color, &reference.color, &inside),
                        median(&ms[0]),
                        median(&ms[1]),
                        median(&ms[2])
                    );
                }
            }
        }
    }

    println!(
        "\norbit 1 deg per frame, 16 frames at 1 spp: rms frame-to-frame change of colour / unshadowed colour (U without TAA) in penumbrae, followed by reprojection"
    );
    println!(
        "(penumbra: 0.05 < colour / U < 0.95 in the denoised frame; the undenoised run is measured on the same pixels)"
    );
    let cams: Vec<Camera> = (0..16).map(|k| camera.orbit(k as f32)).collect();
    for mode in [Mode::Ratio, Mode::Stochastic] {
        for taa in [false, true] {
            // The ratio is colour over the `unshadowed` colour of the same
            // frame (same jitter and resolve): colour / U without TAA, and
            // with it not confounded by the jitter's sub-pixel shading.
            let mut unshadowed: Vec<Vec<Vec3>> = Vec::new();
            run(
                &cams,
                settings(Mode::Unshadowed, 1, 1, false, taa),
                &mut |f, _| unshadowed.push(f.color.clone()),
            );
            let mut masks: Vec<Vec<bool>> = Vec::new();
            for denoise in [true, false] {
                let mut prev: Option<(Vec<Option<f32>>, Vec<Vec3>)> = None;
                let (mut sum, mut n, mut t) = (0.0f64, 0usize, 0usize);
                run(&cams, settings(mode, 1, 1, denoise, taa), &mut |f, _| {
                    let (r, pos) = ratios(f, &unshadowed[t]);
                    if denoise {
                        masks.push(
                            r.iter()
                                .map(|v| v.is_some_and(|v| v > 0.05 && v < 0.95))
                                .collect(),
                        );
                    }
                    if let Some((pr, pp)) = &prev {
                        for k in 0..f.pixel_count() {
                            if !masks[t][k] {
                                continue;
                            }
                            if let (Some(rk), Some(before)) = (r[k], reproject(f, k, pr, pp)) {
                                sum += ((rk - before) as f64).powi(2);
                                n += 1;
                            }
                        }
                    }
                    prev = Some((r, pos));
                    t += 1;
                });
                println!(
                    "{:<12} taa {:<3} denoise {:<3}  flicker {:.4} over {n} pixel-frames",
                    mode.name(),
                    if taa { "on" } else { "off" },
                    if denoise { "on" } else { "off" },
                    (sum / n.max(1) as f64).sqrt()
                );
            }
        }
    }
    Ok(())
}

/// colour / `unshadowed` colour luminance per surface pixel (None where it
/// is dark), and positions.
fn ratios(f: &Frame, unshadowed: &[Vec3]) -> (Vec<Option<f32>>, Vec<Vec3>) {
    let r = (0..f.pixel_count())
        .map(|k| {
            let lu = luminance(unshadowed[k]);
            (f.gbuf[k].kind == PixelKind::Surface && lu > 1e-3).then(|| luminance(f.color[k]) / lu)
        })
        .collect();
    (r, f.gbuf.iter().map(|g| g.position).collect())
}

/// Previous frame's ratio where pixel k's point was, bilinear over four taps
/// on the same surface; None across edges or off screen.
fn reproject(f: &Frame, k: usize, pr: &[Option<f32>], pp: &[Vec3]) -> Option<f32> {
    let g = &f.gbuf[k];
    if !g.prev_valid {
        return None;
    }
    let (w, h) = (f.width as usize, f.height as usize);
    let taps = bilinear_taps(g.prev_pixel, w, h)?;
    let mut sum = 0.0;
    for (t, wt) in taps {
        if pp[t].distance(g.position) >= 0.05 * g.depth {
            return None;
        }
        sum += pr[t]? * wt;
    }
    Some(sum)
}

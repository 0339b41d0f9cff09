//! Where the denoised error lives on a scene of several receivers (the 4x
//! goal on `shadow-plane`, docs/denoiser.md): after `frames` static frames at 1 spp with TAA
//! (what `render --frames 16` writes), the interior relMSE against
//! `reference` of denoised `ratio` and denoised `stochastic`, split per
//! material and per how much of the light the pixel's BRDF lobe sees
//! (converged ratio = converged `ratio` colour / `U` at the pixel centre):
//! `shadowed` (< 0.02), `penumbra`, `lit` (> 0.98). Each cell is the class's
//! share of its material's relMSE (the cells of a material add up to it).
//! The last two columns are an oracle: the same jittered frames, each with
//! `ref_spp` samples (converged visibility) and no denoiser, i.e. what a
//! perfect denoiser would leave (the jitter's own error).
//!
//! `cargo run --release --example denoise_strips -- scenes/shadow-plane.toml 160 90 256 16 1 2 3`
//! (scene, width, height, reference spp, frames, sample seeds; all cores).

use penumbra::denoise::luminance;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, PixelKind, RenderSettings, World};
use penumbra::report::stats::{interior, rel_mse_masked};
use penumbra::scene::Scene;
use std::path::Path;

/// Visibility classes by the converged ratio at the pixel centre.
const CLASSES: [(&str, f32, f32); 3] = [
    ("shadowed", f32::NEG_INFINITY, 0.02),
    ("penumbra", 0.02, 0.98),
    ("lit", 0.98, f32::INFINITY),
];

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let path = args
        .get(1)
        .map_or("scenes/shadow-plane.toml", String::as_str);
    let width: u32 = args.get(2).map_or(Ok(160), |s| s.parse())?;
    let height: u32 = args.get(3).map_or(Ok(90), |s| s.parse())?;
    let ref_spp: u32 = args.get(4).map_or(Ok(256), |s| s.parse())?;
    let frames: usize = args.get(5).map_or(Ok(16), |s| s.parse())?;
    let seeds: Vec<u32> = if args.len() > 6 {
        args[6..]
            .iter()
            .map(|s| s.parse())
            .collect::<Result<_, _>>()?
    } else {
        vec![1, 2, 3]
    };
    let scene = Scene::load(Path::new(path))?;
    let camera = scene.camera;
    let materials: Vec<String> = scene.materials.iter().map(|m| m.name.clone()).collect();
    let device = Device::new()?;
    let world = World::build(&device, scene)?;
    let pool = embree::thread_pool(0)?;
    let run = |mode, spp, seed, denoise, taa, n: usize| {
        let s = RenderSettings {
            mode,
            spp,
            seed,
            denoise,
            taa,
            ..RenderSettings::default()
        };
        let mut frame = Frame::new(width, height);
        for _ in 0..n {
            pool.install(|| frame.render(&world, &camera, &s));
        }
        frame
    };

    let reference = run(Mode::Reference, ref_spp, 0x5eed, false, false, 1);
    let unshadowed = run(Mode::Unshadowed, 1, 0x5eed, false, false, 1);
    let converged = run(Mode::Ratio, ref_spp, 0x5eed, false, false, 1);
    let inside = interior(width, height, &converged.gbuf);
    let visibility: Vec<f32> = (0..inside.len())
        .map(|k| {
            let u = luminance(unshadowed.color[k]);
            if u > 1e-6 {
                luminance(converged.color[k]) / u
            } else {
                1.0
            }
        })
        .collect();

    // Denoised frames per seed, and the oracle once (it has no noise to speak of).
    let denoised: Vec<(Frame, Frame)> = seeds
        .iter()
        .map(|&seed| {
            (
                run(Mode::Ratio, 1, seed, true, true, frames),
                run(Mode::Stochastic, 1, seed, true, true, frames),
            )
        })
        .collect();
    let oracle_ratio = run(Mode::Ratio, ref_spp, 1, false, true, frames);
    let oracle_stochastic = run(Mode::Stochastic, ref_spp, 1, false, true, frames);

    // relMSE over `mask`, each seed's figure averaged.
    let mean_over_seeds = |mask: &[bool], pick: fn(&(Frame, Frame)) -> &Frame| {
        denoised
            .iter()
            .map(|p| rel_mse_masked(&pick(p).color, &reference.color, mask))
            .sum::<f64>()
            / denoised.len() as f64
    };
    println!(
        "{path} {width}x{height}, {frames} static frames at 1 spp, TAA on, denoised; relMSE vs {ref_spp}-spp reference, interior, mean over seeds {seeds:?}; oracle: {ref_spp} spp per frame, no denoiser"
    );
    println!(
        "{:<10} {:<9} {:>6} {:>11} {:>11} {:>7} {:>13} {:>13}",
        "material", "class", "px", "ratio", "stochastic", "s / r", "oracle ratio", "oracle stoch"
    );
    let row = |material: &str, class: &str, mask: &[bool], share: f64| {
        let px = mask.iter().filter(|&&b| b).count();
        let r = share * mean_over_seeds(mask, |p| &p.0);
        let s = share * mean_over_seeds(mask, |p| &p.1);
        println!(
            "{:<10} {:<9} {:>6} {:>11.3e} {:>11.3e} {:>7.2} {:>13.3e} {:>13.3e}",
            material,
            class,
            px,
            r,
            s,
            s / r.max(1e-30),
            share * rel_mse_masked(&oracle_ratio.color, &reference.color, mask),
            share * rel_mse_masked(&oracle_stochastic.color, &reference.color, mask),
        );
    };
    for (id, name) in materials.iter().enumerate() {
        let on: Vec<bool> = (0..inside.len())
            .map(|k| {
                inside[k]
                    && converged.gbuf[k].kind == PixelKind::Surface
                    && converged.gbuf[k].material == id as u32
            })
            .collect();
        let px = on.iter().filter(|&&b| b).count();
        if px == 0 {
            continue;
        }
        for (class, lo, hi) in CLASSES {
            let sub: Vec<bool> = (0..on.len())
                .map(|k| on[k] && visibility[k] > lo && visibility[k] <= hi)
                .collect();
            let n = sub.iter().filter(|&&b| b).count();
            if n > 0 {
                row(name, class, &sub, n as f64 / px as f64);
            }
        }
        row(name, "all", &on, 1.0);
    }
    row("interior", "all", &inside, 1.0);
    Ok(())
}

//! The seed's figure on a scene: the modes beside the reference, with
//! per-pixel error maps, in one labelled PNG:
//!
//! ```text
//! cargo run --release --example room_figure -- scenes/room.toml 480 270 2048 docs
//! ```
//!
//! (scene, width, height, reference spp, output folder, [spp of the bottom
//! row]). Writes `room-fig-{soft-shadow,stochastic,ratio,reference}.png`
//! (undenoised, 1 spp except the reference) and `room-figure.png`: the top
//! row is those four frames; the bottom row holds `soft-shadow` at
//! `CONVERGED_SPP` (its noise gone, its bias left), its per-pixel error and
//! the ratio's at the same spp (log scale, 1e-4 black to 1 white) against the
//! MIS estimator converged at pixel centres, and the shadowed glossy floor on
//! which tests/seed_claims.rs compares the two; the third row magnifies the
//! floor below the pedestal 2x in `reference`, `soft-shadow` and `ratio` at
//! `CONVERGED_SPP`, and `ratio` at 1 spp. It prints the relMSE of each frame against `reference`
//! and against that pixel-centred truth, over the whole image and over the
//! shadowed glossy floor.

use glam::Vec3;
use penumbra::display::display_rgb8;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, RenderSettings, World};
use penumbra::report::stats::{rel_mse, rel_mse_masked, shadowed_glossy};
use penumbra::scene::Scene;
use penumbra::view::font::{ADVANCE_Y, Canvas};
use std::path::Path;

/// Light samples per pixel of the bottom row's `soft-shadow` and `ratio`
/// (the optional 6th argument).
const CONVERGED_SPP: u32 = 64;
/// Floor pixels counted as glossy: material `tiles` with a resolved
/// roughness below this (the polished tiles, not the grout).
pub const GLOSSY_ROUGHNESS: f32 = 0.3;
/// Error maps: log10 of the per-pixel relative squared error, from LO (black)
/// to HI (white).
const LOG_LO: f32 = -4.0;
const LOG_HI: f32 = 0.0;
const LABEL_SCALE: usize = 2;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("scenes/room.toml", String::as_str);
    let width: u32 = args.get(2).map_or(Ok(480), |s| s.parse())?;
    let height: u32 = args.get(3).map_or(Ok(270), |s| s.parse())?;
    let ref_spp: u32 = args.get(4).map_or(Ok(1024), |s| s.parse())?;
    let out = Path::new(args.get(5).map_or("docs", String::as_str));
    let converged_spp: u32 = args.get(6).map_or(Ok(CONVERGED_SPP), |s| s.parse())?;
    let scene = Scene::load(Path::new(path))?;
    let camera = scene.camera;
    let tiles = scene.materials.iter().position(|m| m.name == "tiles");
    let device = Device::new()?;
    let world = World::build(&device, scene)?;
    let pool = embree::thread_pool(0)?;
    let render = |mode, spp, seed| {
        let settings = RenderSettings {
            mode,
            spp,
            seed,
            denoise: false,
            ..RenderSettings::default()
        };
        let mut frame = Frame::new(width, height);
        pool.install(|| frame.render(&world, &camera, &settings));
        frame
    };

    let reference = render(Mode::Reference, ref_spp, 0x5eed);
    // The same MIS estimator converged at pixel centres, where every other
    // mode samples: against it the box filter of `reference` (which blurs
    // the sharp reflections on the polished floor) is not counted as error.
    let centred = render(Mode::Stochastic, ref_spp, 0x5eed);
    // An independent soft-shadow frame says where some of the light is blocked.
    let probe = render(Mode::SoftShadow, 32, 99);
    // No `tiles` material (another scene): no pixel qualifies.
    let shadowed = match tiles {
        Some(t) => shadowed_glossy(&probe, t as u32, GLOSSY_ROUGHNESS),
        None => vec![false; probe.gbuf.len()],
    };
    let n = shadowed.iter().filter(|&&m| m).count();
    println!(
        "{path} {width}x{height}; relMSE, undenoised, whole image and on the shadowed glossy floor ({n} px)"
    );
    println!(
        "{:<20} {:>12} {:>12} {:>14} {:>14}",
        "frame", "vs reference", "floor", "vs centred", "floor"
    );
    let report = |name: &str, f: &Frame| {
        println!(
            "{name:<20} {:>12.3e} {:>12.3e} {:>14.3e} {:>14.3e}",
            rel_mse(&f.color, &reference.color),
            rel_mse_masked(&f.color, &reference.color, &shadowed),
            rel_mse(&f.color, &centred.color),
            rel_mse_masked(&f.color, &centred.color, &shadowed),
        );
    };

    let (w, h) = (width as usize, height as usize);
    let mut top = Vec::new();
    for mode in [Mode::SoftShadow, Mode::Stochastic, Mode::Ratio] {
        let f = render(mode, 1, 1);
        report(&format!("{} 1 spp", mode.name()), &f);
        let file = out.join(format!("room-fig-{}.png", mode.name()));
        penumbra::output::write_png(&file, width, height, &f.color, 0.0)?;
        top.push((format!("{} 1 spp", mode.name()), to_rgb(&f.color)));
    }
    report(&format!("reference {ref_spp} spp"), &reference);
    let file = out.join("room-fig-reference.png");
    penumbra::output::write_png(&file, width, height, &reference.color, 0.0)?;
    top.push((format!("reference {ref_spp} spp"), to_rgb(&reference.color)));

    // Third row: the floor below the pedestal, magnified 2x.
    let mut zoomed = vec![("reference, zoom".to_string(), zoom(&top[3].1, w, h))];
    let mut bottom = Vec::new();
    for mode in [Mode::SoftShadow, Mode::Ratio] {
        let f = render(mode, converged_spp, 1);
        report(&format!("{} {converged_spp} spp", mode.name()), &f);
        let rgb = to_rgb(&f.color);
        zoomed.push((
            format!("{} {converged_spp} spp, zoom", mode.name()),
            zoom(&rgb, w, h),
        ));
        if mode == Mode::SoftShadow {
            bottom.push((format!("{} {converged_spp} spp", mode.name()), rgb));
        }
        bottom.push((
            format!("{} {converged_spp} spp error", mode.name()),
            error_map(&f.color, &centred.color),
        ));
    }
    // Where the floor figures (and tests/seed_claims.rs) are measured.
    let mask = reference
        .color
        .iter()
        .zip(&shadowed)
        .map(|(c, &m)| {
            let [r, g, b] = display_rgb8(*c, 1.0);
            if m {
                [r / 3, g / 3 + 140, b / 3]
            } else {
                [r / 3, g / 3, b / 3]
            }
        })
        .collect();
    bottom.push(("glossy floor in shadow".to_string(), mask));
    zoomed.push(("ratio 1 spp, zoom".to_string(), zoom(&top[2].1, w, h)));
    let panels: Vec<_> = top.into_iter().chain(bottom).chain(zoomed).collect();
    let composite = compose(w, h, &panels);
    let file = out.join("room-figure.png");
    composite.save(&file)?;
    println!("wrote {}", file.display());
    Ok(())
}

fn to_rgb(color: &[Vec3]) -> Vec<[u8; 3]> {
    color.iter().map(|c| display_rgb8(*c, 1.0)).collect()
}

/// Per-pixel relative squared error (the relMSE's summand, mean over the
/// channels) on a log scale, as a black-red-yellow-white ramp.
fn error_map(x: &[Vec3], reference: &[Vec3]) -> Vec<[u8; 3]> {
    x.iter()
        .zip(reference)
        .map(|(a, r)| {
            let d = *a - *r;
            let e = ((d * d) / (*r * *r + Vec3::splat(1e-2))).element_sum() / 3.0;
            let t = ((e.max(1e-12).log10() - LOG_LO) / (LOG_HI - LOG_LO)).clamp(0.0, 1.0);
            let ramp = |lo: f32| ((t * 3.0 - lo).clamp(0.0, 1.0) * 255.0) as u8;
            [ramp(0.0), ramp(1.0), ramp(2.0)]
        })
        .collect()
}

/// Two rows of four panels with a label strip above each row.
/// The lower middle of a w x h image (columns w/4 .. 3w/4, rows h/2 .. h),
/// each pixel repeated 2 x 2: a w x h panel.
fn zoom(rgb: &[[u8; 3]], w: usize, h: usize) -> Vec<[u8; 3]> {
    (0..w * h)
        .map(|k| {
            let (x, y) = (w / 4 + (k % w) / 2, h / 2 + (k / w) / 2);
            rgb[y.min(h - 1) * w + x.min(w - 1)]
        })
        .collect()
}

/// Rows of four w x h panels, each with a label strip above it.
fn compose(w: usize, h: usize, panels: &[(String, Vec<[u8; 3]>)]) -> image::RgbImage {
    let gap = 4;
    let strip = ADVANCE_Y * LABEL_SCALE + 4;
    let cols = 4;
    let rows = panels.len().div_ceil(cols);
    let (cw, ch) = (
        cols * w + (cols - 1) * gap,
        rows * (strip + h) + (rows - 1) * gap,
    );
    let mut pixels = vec![0x0020_2020u32; cw * ch];
    for (i, (label, rgb)) in panels.iter().enumerate() {
        let (col, row) = (i % cols, i / cols);
        let x0 = col * (w + gap);
        let y0 = row * (strip + h + gap) + strip;
        for (k, p) in rgb.iter().enumerate() {
            let (x, y) = (x0 + k % w, y0 + k / w);
            pixels[y * cw + x] = (p[0] as u32) << 16 | (p[1] as u32) << 8 | p[2] as u32;
        }
        let mut canvas = Canvas {
            pixels: &mut pixels,
            width: cw,
            height: ch,
        };
        canvas.text(x0 + 4, y0 - strip + 2, LABEL_SCALE, 0x00ff_ffff, label);
    }
    image::RgbImage::from_fn(cw as u32, ch as u32, |x, y| {
        let p = pixels[y as usize * cw + x as usize];
        image::Rgb([(p >> 16) as u8, (p >> 8) as u8, p as u8])
    })
}

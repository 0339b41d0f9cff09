//! Error of the analytic U in a scene against brute force, pixel by pixel:
//! `cargo run --release --example u_scene_error -- scenes/room.toml 320 180 4`
//! (scene, width, height, pixel stride). For every `stride`-th surface pixel
//! of the G-buffer, U of every light (`unshadowed`) against adaptive area
//! quadrature of the same BRDF x light (tests/integration/support/ltc.rs). Prints the
//! relMSE of the summed U (the image metric of `error_table`) and the
//! distribution of its relative error.

// The example uses the quadrature (`reference`) alone.
#[allow(dead_code)]
#[path = "../tests/integration/support/ltc.rs"]
mod common;

use glam::Vec3;
use penumbra::embree::{self, Device};
use penumbra::render::estimate::surface_point;
use penumbra::render::{Frame, Mode, PixelKind, RenderSettings, World};
use penumbra::shading::unshadowed;
use rayon::prelude::*;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("scenes/room.toml", String::as_str);
    let width: u32 = args.get(2).map_or(Ok(320), |s| s.parse())?;
    let height: u32 = args.get(3).map_or(Ok(180), |s| s.parse())?;
    let stride: usize = args.get(4).map_or(Ok(4), |s| s.parse())?;
    let scene = penumbra::scene::Scene::load(Path::new(path))?;
    let camera = scene.camera;
    let device = Device::new()?;
    let world = World::build(&device, scene)?;
    let pool = embree::thread_pool(0)?;
    let settings = RenderSettings {
        mode: Mode::Unshadowed,
        spp: 1,
        denoise: false,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(width, height);
    pool.install(|| frame.render(&world, &camera, &settings));
    let pixels: Vec<usize> = (0..frame.gbuf.len())
        .step_by(stride.max(1))
        .filter(|&i| frame.gbuf[i].kind == PixelKind::Surface)
        .collect();
    let lights = world.lights.declared();
    // (U, reference) per pixel, all lights summed.
    let pairs: Vec<(Vec3, Vec3)> = pool.install(|| {
        pixels
            .par_iter()
            .map(|&i| {
                let sp = surface_point(&frame.gbuf[i]);
                let mut u = Vec3::ZERO;
                let mut r = Vec3::ZERO;
                for light in lights {
                    u += unshadowed(&sp, light);
                    let (d, s) = common::reference(&sp, light, 1e-4).lobes(&sp, light);
                    r += d + s;
                }
                (u, r)
            })
            .collect()
    });
    let (u, r): (Vec<Vec3>, Vec<Vec3>) = pairs.iter().copied().unzip();
    let mse = penumbra::report::stats::rel_mse(&u, &r);
    let mut rel: Vec<f32> = pairs
        .iter()
        .filter(|(_, r)| r.max_element() > 1e-4)
        .map(|(u, r)| ((*u - *r).abs() / *r).max_element())
        .collect();
    rel.sort_by(f32::total_cmp);
    let q = |p: f64| rel[((rel.len() - 1) as f64 * p).round() as usize];
    println!(
        "{path} {width}x{height}, every {stride}th pixel: {} surface pixels; U vs brute force: relMSE {mse:.3e}; relative error (worst channel) median {:.4}, p90 {:.4}, p99 {:.4}, max {:.4}",
        pixels.len(),
        q(0.5),
        q(0.9),
        q(0.99),
        q(1.0)
    );
    Ok(())
}

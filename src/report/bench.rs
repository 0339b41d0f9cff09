//! `penumbra bench`: median frame time per available mode, its split, the
//! ratio to the Embree ceiling, and the thread speed-up.

use super::ceiling::primary_ray_time;
use super::stats::median;
use crate::embree::{self, Device};
use crate::render::{Frame, Mode, RenderSettings, World};
use crate::scene::Scene;
use anyhow::{Context, Result};
use std::fmt::Write;

pub fn bench_scene(scene: Scene, width: u32, height: u32, frames: u32) -> Result<String> {
    let name = scene.source.display().to_string();
    let tris = scene.triangle_count();
    let camera = scene.camera;
    let device = Device::new().context("starting Embree")?;
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut out = String::new();
    writeln!(out, "scene {name}: {tris} triangles, {width}x{height}, {frames} frames per figure (median)")?;
    writeln!(out, "{:<12} {:>7} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9}", "mode", "threads", "ms/frame", "primary", "U", "shadow", "composite", "/ceiling")?;
    for t in [1usize, threads] {
        let pool = embree::thread_pool(t)?;
        let ceiling = pool.install(|| {
            let runs: Vec<f64> = (0..frames).map(|_| primary_ray_time(&world, &camera, width, height)).collect();
            median(&runs)
        });
        for mode in Mode::ALL.into_iter().filter(|m| m.available() && *m != Mode::Reference) {
            let settings = RenderSettings { mode, ..RenderSettings::default() };
            let mut frame = Frame::new(width, height);
            pool.install(|| frame.render(&world, &camera, &settings)); // warm-up
            let runs: Vec<_> = (0..frames).map(|_| pool.install(|| frame.render(&world, &camera, &settings))).collect();
            let wall = median(&runs.iter().map(|r| r.wall).collect::<Vec<_>>());
            let per = |f: fn(&crate::render::PhaseTimes) -> f64| median(&runs.iter().map(f).collect::<Vec<_>>()) / t as f64 * 1e3;
            writeln!(
                out,
                "{:<12} {:>7} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>10.2} {:>9.2}",
                mode.name(),
                t,
                wall * 1e3,
                per(|r| r.primary),
                per(|r| r.u),
                per(|r| r.shadow),
                per(|r| r.composite),
                wall / ceiling
            )?;
        }
        writeln!(out, "{:<12} {:>7} {:>10.2}   (Embree alone: the same camera rays, 16-packets, no shading)", "ceiling", t, ceiling * 1e3)?;
    }
    Ok(out)
}

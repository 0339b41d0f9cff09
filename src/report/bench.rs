//! `penumbra bench`: median frame time per mode, its split by stage, and the
//! ratio to the Embree ceiling (the same number of rays, no shading), at one
//! thread and at all threads.

use super::ceiling::ray_ceiling;
use super::stats::median;
use crate::embree::{self, Device};
use crate::render::shadow::PacketWidth;
use crate::render::{Frame, Mode, PhaseTimes, RenderSettings, World};
use crate::scene::Scene;
use anyhow::{Context, Result};
use std::fmt::Write;

/// The configurations measured: mode, whether the denoiser runs, and how
/// shadow rays reach Embree.
const CONFIGS: [(Mode, bool, PacketWidth); 8] = [
    (Mode::Ratio, true, PacketWidth::Sixteen),
    (Mode::Ratio, false, PacketWidth::Sixteen),
    (Mode::Ratio, false, PacketWidth::Eight),
    (Mode::Ratio, false, PacketWidth::One),
    (Mode::Stochastic, true, PacketWidth::Sixteen),
    (Mode::Stochastic, false, PacketWidth::Sixteen),
    (Mode::SoftShadow, false, PacketWidth::Sixteen),
    (Mode::Unshadowed, false, PacketWidth::Sixteen),
];

pub fn bench_scene(scene: Scene, width: u32, height: u32, frames: u32) -> Result<String> {
    let name = scene.source.display().to_string();
    let tris = scene.triangle_count();
    let camera = scene.camera;
    let device = Device::new().context("starting Embree")?;
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut out = String::new();
    writeln!(
        out,
        "scene {name}: {tris} triangles, {width}x{height}, 1 spp, median of {frames} frames after one warm-up (ms; stage times are thread time / threads)"
    )?;
    writeln!(
        out,
        "{:<16} {:>7} {:>9} {:>8} {:>8} {:>8} {:>8} {:>9} {:>9}",
        "mode", "threads", "frame", "primary", "U", "shadow", "denoise", "composite", "/ceiling"
    )?;
    let mut frame_ms = Vec::new();
    for t in [1usize, threads] {
        let pool = embree::thread_pool(t)?;
        let ceilings: Vec<_> = (0..frames)
            .map(|_| pool.install(|| ray_ceiling(&world, &camera, width, height, 1)))
            .collect();
        let ceiling = median(&ceilings.iter().map(|c| c.total()).collect::<Vec<_>>());
        for (mode, denoise, packet) in CONFIGS {
            let settings = RenderSettings {
                mode,
                denoise,
                packet,
                ..RenderSettings::default()
            };
            let mut frame = Frame::new(width, height);
            pool.install(|| frame.render(&world, &camera, &settings));
            let runs: Vec<PhaseTimes> = (0..frames)
                .map(|_| pool.install(|| frame.render(&world, &camera, &settings)))
                .collect();
            let wall = median(&runs.iter().map(|r| r.wall).collect::<Vec<_>>());
            let stage = |f: fn(&PhaseTimes) -> f64| {
                median(&runs.iter().map(f).collect::<Vec<_>>()) / t as f64 * 1e3
            };
            let label = format!(
                "{}{}{}",
                mode.name(),
                if denoise { "+dn" } else { "" },
                match packet {
                    PacketWidth::Sixteen => "",
                    PacketWidth::Eight => " (x8)",
                    PacketWidth::One => " (x1)",
                }
            );
            writeln!(
                out,
                "{:<16} {:>7} {:>9.1} {:>8.1} {:>8.1} {:>8.1} {:>8.1} {:>9.1} {:>9.2}",
                label,
                t,
                wall * 1e3,
                stage(|r| r.primary),
                stage(|r| r.u),
                stage(|r| r.shadow),
                median(&runs.iter().map(|r| r.denoise).collect::<Vec<_>>()) * 1e3,
                stage(|r| r.composite),
                wall / ceiling
            )?;
            if mode == Mode::Ratio && denoise && packet == PacketWidth::Sixteen {
                frame_ms.push(wall);
            }
        }
        let c = &ceilings[0];
        writeln!(
            out,
            "{:<16} {:>7} {:>9.1}   Embree alone: {} camera rays + {} shadow rays, 16-wide packets, no shading",
            "ceiling",
            t,
            ceiling * 1e3,
            width * height,
            c.shadow_rays
        )?;
    }
    if let [one, all] = frame_ms[..] {
        writeln!(
            out,
            "ratio+dn speed-up, {threads} threads over 1: {:.2}x",
            one / all
        )?;
    }
    Ok(out)
}

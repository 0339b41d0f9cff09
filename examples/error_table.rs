//! relMSE of every mode against `reference`, by spp, with the time per frame:
//! `cargo run --release --example error_table -- scenes/room.toml 320 180 4096`
//! (scene, width, height, reference spp). Undenoised, one frame per figure;
//! `interior` leaves out pixels on geometric edges, where the reference's box
//! filter and the other modes' pixel centres differ.

use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, RenderSettings, World};
use penumbra::report::stats::{interior, rel_mse, rel_mse_masked};
use penumbra::scene::Scene;
use std::path::Path;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map_or("scenes/room.toml", String::as_str);
    let width: u32 = args.get(2).map_or(Ok(320), |s| s.parse())?;
    let height: u32 = args.get(3).map_or(Ok(180), |s| s.parse())?;
    let ref_spp: u32 = args.get(4).map_or(Ok(4096), |s| s.parse())?;
    let scene = Scene::load(Path::new(path))?;
    let camera = scene.camera;
    let device = Device::new()?;
    let world = World::build(&device, scene)?;
    let pool = embree::thread_pool(0)?;
    let render = |mode, spp, seed, denoise| {
        let settings = RenderSettings {
            mode,
            spp,
            seed,
            denoise,
            ..RenderSettings::default()
        };
        let mut frame = Frame::new(width, height);
        let t = Instant::now();
        pool.install(|| frame.render(&world, &camera, &settings));
        (frame, t.elapsed().as_secs_f64())
    };
    let (reference, secs) = render(Mode::Reference, ref_spp, 0x5eed, false);
    println!("{path} {width}x{height}: reference {ref_spp} spp in {secs:.1} s");
    let (centred, _) = render(Mode::Unshadowed, 1, 0, false);
    let inside = interior(width, height, &centred.gbuf);
    println!(
        "{:<12} {:>5} {:>11} {:>16} {:>9}",
        "mode", "spp", "relMSE", "relMSE interior", "ms"
    );
    for mode in [
        Mode::Ratio,
        Mode::Stochastic,
        Mode::SoftShadow,
        Mode::Unshadowed,
    ] {
        for spp in [1u32, 4, 16, 64] {
            if mode == Mode::Unshadowed && spp > 1 {
                continue;
            }
            let (frame, secs) = render(mode, spp, 1, false);
            let e = rel_mse(&frame.color, &reference.color);
            let ei = rel_mse_masked(&frame.color, &reference.color, &inside);
            println!(
                "{:<12} {:>5} {:>11.3e} {:>16.3e} {:>9.1}",
                mode.name(),
                spp,
                e,
                ei,
                secs * 1e3
            );
        }
    }
    Ok(())
}

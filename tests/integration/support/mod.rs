//! Fixtures shared by the integration tests: scenes, renders and error
//! measures here; each area's own fixtures in the module named after it.

pub mod denoise;
pub mod ltc;
pub mod rng;
pub mod sampling;

use penumbra::embree::Device;
use penumbra::render::{Frame, Mode, RenderSettings, World};
use penumbra::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A grey material "m" and an 8x8 floor quad at y = 0 centred on the origin;
/// inline test scenes add a camera, lights and occluders around it.
pub const FLOOR: &str = r#"
[[material]]
name = "m"
diffuse = [0.5, 0.5, 0.5]
specular = [0.04, 0.04, 0.04]
roughness = 0.4

[[object]]
material = "m"
type = "quad"
center = [0.0, 0.0, 0.0]
u = [0.0, 0.0, 4.0]
v = [4.0, 0.0, 0.0]
"#;

/// Parses inline scene text, panicking with the loader's message.
pub fn parse(text: &str) -> Scene {
    Scene::parse(text, Path::new("inline.toml")).unwrap_or_else(|e| panic!("{e}"))
}

pub fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

pub fn load(name: &str) -> Scene {
    Scene::load(&scene_path(name)).unwrap_or_else(|e| panic!("{e}"))
}

pub struct Job {
    pub width: u32,
    pub height: u32,
    pub mode: Mode,
    pub spp: u32,
    pub frames: u32,
    pub threads: usize,
    pub seed: u32,
    pub denoise: bool,
}

impl Default for Job {
    fn default() -> Self {
        Job {
            width: 160,
            height: 90,
            mode: Mode::Ratio,
            spp: 1,
            frames: 1,
            threads: 1,
            seed: 0,
            denoise: false,
        }
    }
}

/// Renders `job.frames` frames of the scene's own camera and returns the frame state.
pub fn render(scene: &Scene, job: &Job) -> Frame {
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = penumbra::embree::thread_pool(job.threads).expect("thread pool");
    let settings = RenderSettings {
        mode: job.mode,
        spp: job.spp,
        seed: job.seed,
        denoise: job.denoise,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(job.width, job.height);
    let camera = scene.camera;
    pool.install(|| {
        for _ in 0..job.frames {
            frame.render(&world, &camera, &settings);
        }
    });
    frame
}

/// The frame's colour as raw bytes, for bit-exact comparisons.
pub fn color_bytes(frame: &Frame) -> Vec<u8> {
    frame
        .color
        .iter()
        .flat_map(|c| c.to_array())
        .flat_map(f32::to_le_bytes)
        .collect()
}

/// relMSE of `x` against `reference` over the pixels where `mask` holds.
pub fn rel_mse_where(x: &Frame, reference: &Frame, mask: impl Fn(usize) -> bool) -> f64 {
    let m: Vec<bool> = (0..x.pixel_count()).map(mask).collect();
    penumbra::report::stats::rel_mse_masked(&x.color, &reference.color, &m)
}

pub fn rel_mse(x: &Frame, reference: &Frame) -> f64 {
    penumbra::report::stats::rel_mse(&x.color, &reference.color)
}

/// Pixels away from geometric edges (see `report::stats::interior`).
pub fn interior(frame: &Frame) -> Vec<bool> {
    penumbra::report::stats::interior(frame.width, frame.height, &frame.gbuf)
}

/// The `penumbra` binary cargo built for the tests.
pub fn penumbra() -> Command {
    Command::new(env!("CARGO_BIN_EXE_penumbra"))
}

/// `name` in a directory of the system temp dir named after `area` and this
/// process, so that areas running in parallel never share a file.
pub fn temp(area: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-{area}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The box-filtered unshadowed `U` of every pixel of a `width` x `height`
/// frame of `camera`: `U` at `s` x `s` sub-pixel centres (an unjittered
/// render at `s` times the size), averaged over each pixel's block.
pub fn box_filtered_u(
    world: &World,
    pool: &rayon::ThreadPool,
    camera: &penumbra::scene::Camera,
    (width, height): (u32, u32),
    s: u32,
) -> Vec<glam::Vec3> {
    let settings = RenderSettings {
        mode: Mode::Unshadowed,
        taa: false,
        ..RenderSettings::default()
    };
    let mut fine = Frame::new(width * s, height * s);
    pool.install(|| fine.render(world, camera, &settings));
    let mut boxed = vec![glam::Vec3::ZERO; (width * height) as usize];
    for y in 0..height * s {
        for x in 0..width * s {
            boxed[((y / s) * width + x / s) as usize] +=
                fine.color[(y * width * s + x) as usize] / (s * s) as f32;
        }
    }
    boxed
}

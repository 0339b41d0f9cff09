use super::controls::Flyer;
use crate::embree::{self, Device};
use crate::output;
use crate::render::{Frame, Mode, RenderSettings, World};
use crate::scene::Scene;
use anyhow::{Context, Result, bail};
use minifb::{Key, KeyRepeat, MouseButton, MouseMode, Window, WindowOptions};
use std::path::PathBuf;
use std::time::Instant;

pub struct ViewOptions {
    pub scene: Option<PathBuf>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub mode: Mode,
    pub spp: u32,
    pub threads: usize,
    pub seed: u32,
    pub denoise: bool,
    pub exposure: f32,
    /// Close after this many frames.
    pub frames: Option<u32>,
    /// PNG of the last frame shown.
    pub screenshot: Option<PathBuf>,
}

const MODE_KEYS: [(Key, Mode); 5] = [
    (Key::Key1, Mode::Ratio),
    (Key::Key2, Mode::Stochastic),
    (Key::Key3, Mode::SoftShadow),
    (Key::Key4, Mode::Unshadowed),
    (Key::Key5, Mode::Reference),
];

pub fn run(opts: ViewOptions) -> Result<()> {
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        bail!(
            "no display to open a window on (DISPLAY is not set); use `penumbra render SCENE --out frame.png` instead"
        );
    }
    let scene = match &opts.scene {
        Some(p) => Scene::load(p)?,
        None => Scene::builtin(),
    };
    let w = opts.width.unwrap_or(scene.width);
    let h = opts.height.unwrap_or(scene.height);
    crate::scene::check_resolution(w, h).map_err(anyhow::Error::msg)?;
    let mut window = Window::new("penumbra", w as usize, h as usize, WindowOptions::default())
        .map_err(|e| {
            anyhow::anyhow!(
                "cannot open a window ({e}); use `penumbra render SCENE --out frame.png` instead"
            )
        })?;
    let device = Device::new().context("starting Embree")?;
    let mut flyer = Flyer::from_camera(&scene.camera);
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let pool = embree::thread_pool(opts.threads)?;
    let mut settings = RenderSettings {
        mode: if opts.mode.available() {
            opts.mode
        } else {
            Mode::Unshadowed
        },
        spp: opts.spp,
        seed: opts.seed,
        denoise: opts.denoise,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(w, h);
    let mut pixels = vec![0u32; frame.pixel_count()];
    let exposure = opts.exposure.exp2();
    let mut last_mouse: Option<(f32, f32)> = None;
    let mut shown = 0u32;
    let mut last = Instant::now();
    while window.is_open() && !window.is_key_down(Key::Escape) {
        let now = Instant::now();
        let dt = (now - last).as_secs_f32().min(0.25);
        last = now;
        for (key, mode) in MODE_KEYS {
            if window.is_key_pressed(key, KeyRepeat::No) && mode.available() {
                settings.mode = mode;
                frame.reset_history();
            }
        }
        let axis = |a: Key, b: Key| {
            window.is_key_down(a) as i32 as f32 - window.is_key_down(b) as i32 as f32
        };
        flyer.travel(
            axis(Key::D, Key::A),
            axis(Key::E, Key::Q),
            axis(Key::W, Key::S),
            dt,
        );
        flyer.look(
            axis(Key::Right, Key::Left) * dt * 1.5,
            axis(Key::Up, Key::Down) * dt * 1.5,
        );
        let mouse = window.get_mouse_pos(MouseMode::Pass);
        if window.get_mouse_down(MouseButton::Left) {
            if let (Some((x0, y0)), Some((x, y))) = (last_mouse, mouse) {
                flyer.look((x - x0) * 0.005, (y0 - y) * 0.005);
            }
            last_mouse = mouse;
        } else {
            last_mouse = None;
        }
        let camera = flyer.camera();
        let times = pool.install(|| frame.render(&world, &camera, &settings));
        for (p, c) in pixels.iter_mut().zip(&frame.color) {
            let [r, g, b] = output::display_rgb8(*c, exposure);
            *p = (r as u32) << 16 | (g as u32) << 8 | b as u32;
        }
        window
            .update_with_buffer(&pixels, w as usize, h as usize)
            .context("presenting the frame")?;
        window.set_title(&format!(
            "penumbra — {} — {} spp — {:.1} ms",
            settings.mode,
            settings.spp,
            times.wall * 1e3
        ));
        shown += 1;
        if opts.frames.is_some_and(|n| shown >= n) {
            break;
        }
    }
    if let Some(path) = &opts.screenshot {
        output::write_png(path, w, h, &frame.color, opts.exposure)?;
        println!("{}", path.display());
    }
    Ok(())
}

//! The window loop (minifb): gather input from the window and the script,
//! render, present, write screenshots. Nothing here waits: minifb's rate
//! limit is off, so the loop runs as fast as frames render.

use super::input::{Action, FrameInput};
use super::present;
use super::scale::DynamicScale;
use super::script::{Player, SCRIPT_DT, Script};
use super::session::Session;
use crate::embree::{self, Device};
use crate::render::{RenderSettings, World};
use crate::scene::Scene;
use anyhow::{Context, Result, bail};
use minifb::{Key, KeyRepeat, MouseButton, MouseMode, ScaleMode, Window, WindowOptions};
use rayon::ThreadPool;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub struct ViewOptions {
    pub scene: Option<PathBuf>,
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// The settings of the first frame (the keys change them).
    pub settings: RenderSettings,
    pub threads: usize,
    pub exposure: f32,
    /// Scale the render resolution to hold this frame rate (the frame is
    /// upscaled to the window's size, `render::upscaled`); `None`: render
    /// at the window's size.
    pub target_fps: Option<f32>,
    /// Draw the overlay (key `O` toggles it).
    pub overlay: bool,
    /// Close after this many frames.
    pub frames: Option<u32>,
    /// PNG of the last frame shown (and the linear EXR beside it).
    pub screenshot: Option<PathBuf>,
    /// Timed key and mouse events to replay.
    pub script: Option<PathBuf>,
}

fn no_window(why: &str) -> anyhow::Error {
    anyhow::anyhow!("{why}; use `penumbra render SCENE --out frame.png` instead")
}

pub fn run(opts: ViewOptions) -> Result<()> {
    // Everything that can be checked without a window is checked first.
    if let Some(p) = &opts.screenshot {
        check_png(p)?;
    }
    let script = opts.script.as_deref().map(Script::load).transpose()?;
    let scene = match &opts.scene {
        Some(p) => Scene::load(p)?,
        None => Scene::builtin(),
    };
    let w = opts.width.unwrap_or(scene.width);
    let h = opts.height.unwrap_or(scene.height);
    crate::scene::check_resolution(w, h).map_err(anyhow::Error::msg)?;
    if opts.frames == Some(0) {
        bail!("--frames must be at least 1");
    }
    if opts
        .target_fps
        .is_some_and(|f| DynamicScale::new(f).is_none())
    {
        bail!("--target-fps must be a positive number of frames per second");
    }
    if std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none() {
        return Err(no_window(
            "no display to open a window on (DISPLAY is not set)",
        ));
    }
    let mut window = open_window(w, h)?;

    let device = Device::new().context("starting Embree")?;
    let camera = scene.camera;
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let pool = embree::thread_pool(opts.threads)?;
    let mut session = Session::new(opts.settings, &camera, w, h, opts.exposure, opts.overlay);
    if let Some(d) = opts.target_fps.and_then(DynamicScale::new) {
        session.hold(d);
    }
    let player = script.map(Player::new);
    fly(
        &mut window,
        &mut session,
        &world,
        &pool,
        player,
        opts.frames,
    )?;
    if let Some(path) = &opts.screenshot {
        let (w, h) = session.shown_size();
        let linear = session.shown().to_vec();
        for p in present::save_screenshot(path, w, h, &session.pixels, &linear)? {
            println!("{}", p.display());
        }
    }
    eprintln!("{}", session.summary());
    Ok(())
}

/// Opens the window; frames are presented at their own size, so a resized
/// window shows the old frame stretched until the next one is rendered.
fn open_window(w: u32, h: u32) -> Result<Window> {
    let options = WindowOptions {
        resize: true,
        scale_mode: ScaleMode::Stretch,
        ..WindowOptions::default()
    };
    let mut window = Window::new("penumbra", w as usize, h as usize, options)
        .map_err(|e| no_window(&format!("cannot open a window ({e})")))?;
    // No rate limit: rendering paces the loop, and presenting never sleeps.
    window.set_target_fps(0);
    Ok(window)
}

/// The frame loop: input (window and script), screenshots of what is on
/// screen, steering, resizing, render, present. Ends on Esc, a closed
/// window, a scripted `quit` or after `frames` frames.
fn fly(
    window: &mut Window,
    session: &mut Session,
    world: &World,
    pool: &ThreadPool,
    mut player: Option<Player>,
    frames: Option<u32>,
) -> Result<()> {
    let scripted = player.is_some();
    let mut mouse = MouseDrag::default();
    let mut window_size = window.get_size();
    let mut shown = 0u32;
    let mut last = Instant::now();

    while window.is_open() {
        let start = Instant::now();
        let dt = if scripted {
            SCRIPT_DT
        } else {
            (start - last).as_secs_f32().min(0.25)
        };
        last = start;

        let mut input = mouse.gather(window);
        if let Some(p) = player.as_mut() {
            p.feed(shown, &mut input);
        }
        let mut shoot: Vec<Option<PathBuf>> = Vec::new();
        let mut quit = input.quit;
        for action in input.actions() {
            match action {
                Action::Screenshot => shoot.push(None),
                a => quit |= !session.apply(a),
            }
        }
        // Screenshots show what is on screen now, before the next frame.
        shoot.extend(input.screenshots.drain(..).map(Some));
        if shown > 0 {
            take_screenshots(session, shoot)?;
        }
        if quit || frames.is_some_and(|n| shown >= n) {
            break;
        }
        session.steer(&input, dt);
        let now_size = window.get_size();
        if let Some((rw, rh)) = input.resize {
            // A scripted resize stands for the window's: under a target
            // frame rate the render takes its scale of the new size.
            session.resize_window(rw, rh);
        } else if now_size != window_size {
            // The user resized the window: render at its new size.
            session.resize_window(now_size.0 as u32, now_size.1 as u32);
        }
        window_size = now_size;

        let times = pool.install(|| session.render(world));
        let t = Instant::now();
        pool.install(|| session.compose());
        let (fw, fh) = session.shown_size();
        window
            .update_with_buffer(&session.pixels, fw as usize, fh as usize)
            .context("presenting the frame")?;
        window.set_title(&session.readout().title());
        let present = t.elapsed().as_secs_f64();
        let total = start.elapsed().as_secs_f64();
        session.record(&times, present, total);
        if input.resize.is_none() {
            session.hold_frame_rate();
        }
        shown += 1;
    }
    Ok(())
}

fn check_png(p: &Path) -> Result<()> {
    if !p.extension().is_some_and(|e| e.eq_ignore_ascii_case("png")) {
        bail!(
            "{}: --screenshot must end in .png (the linear EXR goes beside it)",
            p.display()
        );
    }
    Ok(())
}

/// Writes each requested screenshot (`None`: a `P` press, named by
/// number in the current folder). A failed `P` is reported and the session
/// goes on; a scripted screenshot that fails fails the run.
fn take_screenshots(session: &mut Session, requests: Vec<Option<PathBuf>>) -> Result<()> {
    for request in requests {
        let interactive = request.is_none();
        let path = request.unwrap_or_else(|| present::next_screenshot_path(Path::new(".")));
        match screenshot(session, &path) {
            Ok(msg) => {
                eprintln!("penumbra: {msg}");
                let name = path.file_name().unwrap_or_default().to_string_lossy();
                session.set_status(format!("SAVED {} +EXR", name.to_uppercase()));
            }
            Err(e) if interactive => {
                eprintln!("penumbra: {e:#}");
                session.set_status("SCREENSHOT FAILED (SEE STDERR)".into());
            }
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

/// Writes what the window shows now; returns a message saying where.
fn screenshot(session: &mut Session, path: &Path) -> Result<String> {
    let (w, h) = session.shown_size();
    let linear = session.shown().to_vec();
    let [png, exr] = present::save_screenshot(path, w, h, &session.pixels, &linear)?;
    Ok(format!("saved {} and {}", png.display(), exr.display()))
}

/// The window's side of a frame's input; remembers where a drag was.
#[derive(Default)]
struct MouseDrag {
    last: Option<(f32, f32)>,
}

impl MouseDrag {
    fn gather(&mut self, window: &Window) -> FrameInput {
        let mut input = FrameInput {
            pressed: window.get_keys_pressed(KeyRepeat::No),
            held: window.get_keys(),
            ..FrameInput::default()
        };
        // `+` shares a key with `=` on most layouts; repeating it while held
        // is what people expect of a speed key.
        for key in window.get_keys_pressed(KeyRepeat::Yes) {
            if matches!(
                key,
                Key::Equal | Key::Minus | Key::NumPadPlus | Key::NumPadMinus
            ) && !input.pressed.contains(&key)
            {
                input.pressed.push(key);
            }
        }
        let pos = window.get_mouse_pos(MouseMode::Pass);
        if window.get_mouse_down(MouseButton::Left) {
            if let (Some((x0, y0)), Some((x, y))) = (self.last, pos) {
                input.drag = (x - x0, y - y0);
            }
            self.last = pos;
        } else {
            self.last = None;
        }
        if let Some((_, y)) = window.get_scroll_wheel() {
            input.scroll = y;
        }
        input
    }
}

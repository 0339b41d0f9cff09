//! `penumbra bench --equal-time`: the viewer's dynamic resolution judged at
//! equal wall-clock time against the full-size frame, and the cost of the
//! passes at the window's size (docs/interactive.md).
//!
//! Each path runs as the viewer does, without the window: render, then the
//! output pass (the upscale with the display transform fused into it, or
//! the display transform alone at full size) into 0RGB pixels; the copy to
//! a window is the same for every path and left out. The clock counts only
//! those; measuring the error is not counted.
//!
//! - Still camera: relMSE of the frame shown when 0.5 s, 2 s and 8 s of
//!   frames have run, against the scene's cached reference.
//! - Orbit: the camera turns 1 degree per frame for `orbit_seconds`, each
//!   path at its own frame rate (a faster path turns further); the frames
//!   shown at evenly spaced instants are measured against a reference of
//!   their own camera.

use super::reference::{self, Reference};
use super::stats::{interior, interior_of_view, median, rel_mse, rel_mse_masked};
use crate::denoise::CameraMotion;
use crate::display::DisplayMap;
use crate::embree::{self, Device};
use crate::render::{Frame, Mode, RenderSettings, Upscaled, World, scaled_size};
use crate::scene::{Camera, Scene};
use crate::view::present;
use crate::view::scale::{DynamicScale, FrameCost};
use anyhow::{Context, Result};
use glam::Vec3;
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What to measure.
#[derive(Debug, Clone)]
pub struct EqualTimeOptions {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of the still camera's reference (cached).
    pub reference_spp: u32,
    /// Of each orbit frame's reference (rendered, not cached).
    pub orbit_reference_spp: u32,
    /// Instants of the still camera, seconds.
    pub still_seconds: Vec<f64>,
    pub orbit_seconds: f64,
    /// Orbit frames measured per path.
    pub orbit_samples: usize,
    pub target_fps: f32,
    pub cache_dir: PathBuf,
}

impl EqualTimeOptions {
    pub fn new(cache_dir: PathBuf) -> EqualTimeOptions {
        EqualTimeOptions {
            width: 1280,
            height: 720,
            reference_spp: 256,
            orbit_reference_spp: 16,
            still_seconds: vec![0.5, 2.0, 8.0],
            orbit_seconds: 3.0,
            orbit_samples: 4,
            target_fps: crate::view::DEFAULT_TARGET_FPS,
            cache_dir,
        }
    }
}

/// The ways of showing frames compared.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Path_ {
    /// Every frame at the output's size.
    Full,
    /// At this scale of each side, upscaled.
    Fixed(f32),
    /// The viewer's default: the scale its controller picks.
    Dynamic,
}

impl Path_ {
    fn name(&self, target: f32) -> String {
        match self {
            Path_::Full => "full size".into(),
            Path_::Fixed(s) => format!("{:.0} % fixed", s * 100.0),
            Path_::Dynamic => format!("dynamic ({target:.0} fps)"),
        }
    }
}

/// A viewer without its window.
struct Shower {
    frame: Frame,
    up: Option<Upscaled>,
    dynamic: Option<DynamicScale>,
    pixels: Vec<u32>,
    map: DisplayMap,
    size: (u32, u32),
    last: Option<Camera>,
    /// Scales of the shown frames.
    scales: Vec<f32>,
}

impl Shower {
    fn new(path: Path_, (w, h): (u32, u32), target: f32) -> Shower {
        let dynamic = (path == Path_::Dynamic)
            .then(|| DynamicScale::new(target))
            .flatten();
        let scale = match path {
            Path_::Full => 1.0,
            Path_::Fixed(s) => s,
            Path_::Dynamic => dynamic.as_ref().map_or(1.0, |d| d.scale()),
        };
        let (rw, rh) = scaled_size(w, h, scale);
        Shower {
            frame: Frame::new(rw, rh),
            up: (path != Path_::Full).then(|| Upscaled::new(w, h)),
            dynamic,
            pixels: vec![0; w as usize * h as usize],
            map: DisplayMap::new(1.0),
            size: (w, h),
            last: None,
            scales: Vec::new(),
        }
    }

    /// Shows one frame of `camera`; returns its seconds.
    fn show(&mut self, world: &World, camera: &Camera, settings: &RenderSettings) -> f64 {
        let start = Instant::now();
        let ow = self.size.0 as usize;
        let output = match self.up.as_mut() {
            Some(up) => {
                let map = &self.map;
                up.render_rows(
                    &mut self.frame,
                    world,
                    camera,
                    settings,
                    self.pixels.par_chunks_mut(ow),
                    |row: &mut &mut [u32], t: &[[f32; 4]], changed: bool| {
                        if changed {
                            map.row(t, row)
                        }
                    },
                );
                up.upscale_seconds
            }
            None => {
                self.frame.render(world, camera, settings);
                let t = Instant::now();
                present::to_display(&self.frame.color, &self.map, &mut self.pixels);
                t.elapsed().as_secs_f64()
            }
        };
        let total = start.elapsed().as_secs_f64();
        self.scales
            .push(self.frame.width as f32 / self.size.0 as f32);
        let moving = self.last.is_some_and(|c| c != *camera);
        self.last = Some(*camera);
        if let Some(d) = self.dynamic.as_mut()
            && d.observe(FrameCost {
                total,
                output,
                moving,
            })
        {
            let (rw, rh) = d.size(self.size.0, self.size.1);
            self.frame = Frame::new(rw, rh);
        }
        total
    }

    fn linear(&mut self) -> &[Vec3] {
        match self.up.as_mut() {
            Some(u) => u.linear(),
            None => &self.frame.color,
        }
    }
}

/// One path's figures on one scene.
struct PathResult {
    name: String,
    /// relMSE at each still instant (all pixels, interior), and frames
    /// shown by then.
    still: Vec<(f64, f64, u32)>,
    still_fps: f64,
    still_scale: f32,
    /// Orbit: median relMSE of the measured frames (all pixels,
    /// interior), frames shown, fps.
    orbit: (f64, f64),
    orbit_frames: u32,
    orbit_fps: f64,
    orbit_scale: f32,
}

/// The reference of `camera` (not cached: one per orbit frame), and its
/// interior pixels (`stats::interior`).
fn camera_reference(
    world: &World,
    camera: &Camera,
    (w, h): (u32, u32),
    spp: u32,
) -> (Vec<Vec3>, Vec<bool>) {
    let mut frame = Frame::new(w, h);
    let mut done = 0;
    while done < spp {
        let pass = 4.min(spp - done);
        let settings = RenderSettings {
            mode: Mode::Reference,
            spp: pass,
            seed: reference::SEED,
            denoise: false,
            ..RenderSettings::default()
        };
        frame.render(world, camera, &settings);
        done += pass;
    }
    let inside = interior(w, h, &frame.gbuf);
    (frame.color, inside)
}

fn scene_run(
    path: Option<&Path>,
    opts: &EqualTimeOptions,
    out: &mut String,
) -> Result<Vec<PathResult>> {
    let scene = match path {
        Some(p) => Scene::load(p)?,
        None => Scene::builtin(),
    };
    let camera = scene.camera;
    let device = Device::new().context("starting Embree")?;
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let pool = embree::thread_pool(threads)?;
    let size = (opts.width, opts.height);
    let Reference { color: truth, .. } = pool.install(|| {
        reference::reference(
            &world,
            path,
            opts.width,
            opts.height,
            opts.reference_spp,
            &opts.cache_dir,
            None,
        )
    })?;
    let pass = output_pass_row(&world, &camera, size, &pool);
    eprintln!("{pass}");
    let mask = interior_of_view(&world, &camera, (opts.width, opts.height), &pool);
    let settings = RenderSettings::default();
    let paths = [Path_::Full, Path_::Fixed(0.5), Path_::Dynamic];
    let end = opts.still_seconds.iter().copied().fold(0.0, f64::max);
    let mut results = Vec::new();
    for p in paths {
        let name = p.name(opts.target_fps);
        eprintln!("equal time: {name}, still camera, {end} s");
        // Still camera.
        let mut s = Shower::new(p, size, opts.target_fps);
        let (mut clock, mut frames) = (0.0, 0u32);
        let mut still = Vec::new();
        let mut times = Vec::new();
        for &at in &opts.still_seconds {
            while clock < at {
                let t = pool.install(|| s.show(&world, &camera, &settings));
                clock += t;
                times.push(t);
                frames += 1;
            }
            let c = s.linear();
            still.push((rel_mse(c, &truth), rel_mse_masked(c, &truth, &mask), frames));
        }
        let still_fps = 1.0 / median(&times[1.min(times.len() - 1)..]);
        let still_scale = *s.scales.last().unwrap_or(&1.0);
        // Orbit: 1 degree per frame. The frames shown at evenly spaced
        // instants are measured (their references off the clock).
        eprintln!("equal time: {name}, orbit, {} s", opts.orbit_seconds);
        let mut s = Shower::new(p, size, opts.target_fps);
        let (mut clock, mut k) = (0.0, 0u32);
        let mut times = Vec::new();
        let mut errors = Vec::new();
        let n = opts.orbit_samples.max(1);
        let instant = |i: usize| opts.orbit_seconds * (i + 1) as f64 / n as f64;
        while errors.len() < n {
            let cam = camera.orbit(k as f32);
            let t = pool.install(|| s.show(&world, &cam, &settings));
            clock += t;
            times.push(t);
            k += 1;
            if clock >= instant(errors.len()) {
                let (r, m) =
                    pool.install(|| camera_reference(&world, &cam, size, opts.orbit_reference_spp));
                let c = s.linear();
                errors.push((rel_mse(c, &r), rel_mse_masked(c, &r, &m)));
            }
        }
        let orbit_fps = 1.0 / median(&times[1.min(times.len() - 1)..]);
        results.push(PathResult {
            name,
            still,
            still_fps,
            still_scale,
            orbit: (
                median(&errors.iter().map(|e| e.0).collect::<Vec<_>>()),
                median(&errors.iter().map(|e| e.1).collect::<Vec<_>>()),
            ),
            orbit_frames: k,
            orbit_fps,
            orbit_scale: median(&s.scales.iter().map(|&x| x as f64).collect::<Vec<_>>()) as f32,
        });
    }
    let name = path.map_or("<builtin>".into(), |p| p.display().to_string());
    let _ = writeln!(out, "\n{name} at {}x{}:", opts.width, opts.height);
    let mut head = String::from("| path | fps still (scale) |");
    for at in &opts.still_seconds {
        let _ = write!(head, " relMSE {at} s: all / interior (frames) |");
    }
    let _ = writeln!(
        head,
        " orbit fps (median scale) | orbit relMSE, median of {} frames: all / interior \
         (frames shown) |",
        opts.orbit_samples
    );
    out.push_str(&head);
    let cols = 4 + opts.still_seconds.len();
    let _ = writeln!(out, "|{}", "---|".repeat(cols));
    for r in &results {
        let mut line = format!(
            "| {} | {:.1} ({:.0} %) |",
            r.name,
            r.still_fps,
            r.still_scale * 100.0
        );
        for (e, ei, f) in &r.still {
            let _ = write!(line, " {e:.3e} / {ei:.3e} ({f}) |");
        }
        let _ = writeln!(
            line,
            " {:.1} ({:.0} %) | {:.3e} / {:.3e} ({}) |",
            r.orbit_fps,
            r.orbit_scale * 100.0,
            r.orbit.0,
            r.orbit.1,
            r.orbit_frames
        );
        out.push_str(&line);
    }
    let full = &results[0];
    let dynamic = &results[results.len() - 1];
    let ratios: Vec<String> = full
        .still
        .iter()
        .zip(&dynamic.still)
        .map(|(f, d)| format!("{:.2} / {:.2}", d.0 / f.0, d.1 / f.1))
        .collect();
    let _ = writeln!(
        out,
        "dynamic over full size (all / interior): still {} (at {}), orbit {:.2} / {:.2}",
        ratios.join(", "),
        opts.still_seconds
            .iter()
            .map(|s| format!("{s} s"))
            .collect::<Vec<_>>()
            .join(", "),
        dynamic.orbit.0 / full.orbit.0,
        dynamic.orbit.1 / full.orbit.1
    );
    let _ = writeln!(out, "{pass}");
    Ok(results)
}

/// The output pass alone, ns per output pixel (median of 15 runs): the
/// upscale of a quarter-scale frame with the display transform fused, for
/// a still and a moving camera, and the display transform of a full-size
/// frame.
fn output_pass_row(
    world: &World,
    camera: &Camera,
    (w, h): (u32, u32),
    pool: &rayon::ThreadPool,
) -> String {
    let (rw, rh) = scaled_size(w, h, 0.25);
    let mut frame = Frame::new(rw, rh);
    let settings = RenderSettings {
        upscaled: true,
        ..RenderSettings::default()
    };
    // Two frames one degree apart: the motion vectors of an orbit.
    pool.install(|| {
        frame.render(world, &camera.orbit(-1.0), &settings);
        frame.render(world, camera, &settings);
    });
    let map = DisplayMap::new(1.0);
    let mut pixels = vec![0u32; w as usize * h as usize];
    let mut up = Upscaled::new(w, h);
    let pixels_n = w as f64 * h as f64;
    // A 4x4 stratified jitter sequence, as the frames' (0,m,2)-net covers
    // a render pixel: after the first 16 frames every output pixel holds a
    // sample, the steady state measured.
    let jitter = |k: usize| {
        glam::Vec2::new(
            ((k * 5 + 1) % 4) as f32 * 0.25 + 0.125,
            ((k / 4 * 3 + k) % 4) as f32 * 0.25 + 0.125,
        )
    };
    let mut time = |motion: CameraMotion| {
        let runs: Vec<f64> = (0..31)
            .map(|k| {
                let t = Instant::now();
                pool.install(|| {
                    up.upscale_rows(
                        &frame,
                        world,
                        camera,
                        jitter(k),
                        Some(motion),
                        pixels.par_chunks_mut(w as usize),
                        |row: &mut &mut [u32], t: &[[f32; 4]], changed: bool| {
                            if changed {
                                map.row(t, row)
                            }
                        },
                    )
                });
                t.elapsed().as_secs_f64()
            })
            .collect();
        median(&runs[16..]) * 1e9 / pixels_n
    };
    let still = time(CameraMotion::Still);
    let moving = time(CameraMotion::Moved);
    let edges = up.edge_count();
    let full = vec![Vec3::splat(0.5); w as usize * h as usize];
    let runs: Vec<f64> = (0..15)
        .map(|_| {
            let t = Instant::now();
            pool.install(|| present::to_display(&full, &map, &mut pixels));
            t.elapsed().as_secs_f64()
        })
        .collect();
    format!(
        "output pass at {w}x{h} (ns per output pixel, median of 15): upscale from {rw}x{rh} \
         + display transform, still {still:.2}, moving {moving:.2} (camera rays at {edges} \
         output pixels on the rims of lights and the background); display transform of a \
         full-size frame {:.2}",
        median(&runs) * 1e9 / pixels_n
    )
}

/// Runs every scene; returns the report's text (markdown tables).
pub fn run(scenes: &[Option<PathBuf>], opts: &EqualTimeOptions) -> Result<String> {
    let mut out = String::new();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let _ = writeln!(
        out,
        "equal time: still camera at {:?} s, orbit 1 degree per frame for {} s; still \
         reference {} spp (cached), orbit references {} spp; load average at the start: {}",
        opts.still_seconds,
        opts.orbit_seconds,
        opts.reference_spp,
        opts.orbit_reference_spp,
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    for p in scenes {
        scene_run(p.as_deref(), opts, &mut out)?;
    }
    Ok(out)
}

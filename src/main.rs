//! The `penumbra` command line: render, view, bench, fit-ltc.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use penumbra::embree::{self, Device};
use penumbra::output::{self, Aov};
use penumbra::render::{Frame, Mode, RenderSettings, World};
use penumbra::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "penumbra",
    version,
    about = "Correct soft shadows from area lights, ray traced on the CPU"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to a PNG (tonemapped) or EXR (linear) file.
    Render(RenderArgs),
    /// Open an interactive window on a scene.
    View(ViewArgs),
    /// Measure frame time against the Embree ray ceiling.
    Bench(BenchArgs),
    /// Fit the LTC table for the project's GGX BRDF.
    FitLtc(FitArgs),
}

#[derive(Args)]
struct SceneArgs {
    /// Scene file (TOML); the built-in scene when omitted.
    scene: Option<PathBuf>,
    /// Output width in pixels (overrides the scene's [output]).
    #[arg(long)]
    width: Option<u32>,
    /// Output height in pixels (overrides the scene's [output]).
    #[arg(long)]
    height: Option<u32>,
    /// ratio | stochastic | soft-shadow | unshadowed | reference
    #[arg(long, default_value = "ratio")]
    mode: Mode,
    /// Light samples per pixel per frame (`reference`: in total).
    #[arg(long, default_value_t = 1)]
    spp: u32,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Seed of every random choice; the same seed gives the same bytes.
    #[arg(long, default_value_t = 0)]
    seed: u32,
    /// Denoise U_N and S_N (ratio, stochastic, soft-shadow): on | off.
    #[arg(long, default_value = "on")]
    denoise: Switch,
    /// Exposure in stops for PNG and the window.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Switch {
    On,
    Off,
}

#[derive(Args)]
struct RenderArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// Output file, .png or .exr. A `{frame}` in it writes every frame, the
    /// frame number (from 0) zero-padded to 4 digits, or more when the last
    /// number needs more: `--out out/f{frame}.png` gives out/f0000.png, ...
    #[arg(long)]
    out: PathBuf,
    /// Frames to render (without `{frame}` in --out, the last is written).
    #[arg(long, default_value_t = 1)]
    frames: u32,
    /// Turn the eye about the camera target by this many degrees per frame
    /// (about the camera's up axis; frame k is turned by k * DEG).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    orbit: f32,
    /// Extra EXR images beside --out: albedo, normal, depth, u, un, sn, ratio.
    #[arg(long, default_value = "")]
    aov: String,
}

#[derive(Args)]
struct ViewArgs {
    #[command(flatten)]
    common: SceneArgs,
    /// Close after this many frames (for scripted runs).
    #[arg(long)]
    frames: Option<u32>,
    /// Write the last frame shown to this PNG (as shown, overlay included)
    /// and the linear frame beside it as EXR.
    #[arg(long)]
    screenshot: Option<PathBuf>,
    /// Replay timed key and mouse events from this file (see README, "Viewer").
    #[arg(long)]
    script: Option<PathBuf>,
    /// Draw the overlay (mode, timings, fps): on | off. Key O toggles it.
    #[arg(long, default_value = "on")]
    overlay: Switch,
}

#[derive(Args)]
struct BenchArgs {
    /// Scenes to measure (default: the built-in scene).
    scenes: Vec<PathBuf>,
    /// Frames measured per configuration (median reported).
    #[arg(long, default_value_t = 9)]
    frames: u32,
    /// Width, height of the measured frames.
    #[arg(long, default_value_t = 1280)]
    width: u32,
    #[arg(long, default_value_t = 720)]
    height: u32,
}

#[derive(Args)]
struct FitArgs {
    /// Table resolution per axis.
    #[arg(long, default_value_t = 64)]
    size: usize,
    /// Where to write the table.
    #[arg(long, default_value = "data/ltc_64.bin")]
    out: PathBuf,
    /// Optional PNG heat map of the per-cell fit error.
    #[arg(long)]
    heatmap: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => cmd_render(a),
        Command::View(a) => penumbra::view::run(view_options(a)),
        Command::Bench(a) => cmd_bench(a),
        Command::FitLtc(a) => {
            penumbra::shading::ltc_fit::run_fit(a.size, &a.out, a.heatmap.as_deref())
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("penumbra: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn load_scene(path: Option<&Path>) -> Result<Scene> {
    match path {
        Some(p) => Ok(Scene::load(p)?),
        None => Ok(Scene::builtin()),
    }
}

/// The output size: command line over the scene's `[output]`, checked.
fn frame_size(scene: &Scene, width: Option<u32>, height: Option<u32>) -> Result<(u32, u32)> {
    let w = width.unwrap_or(scene.width);
    let h = height.unwrap_or(scene.height);
    penumbra::scene::check_resolution(w, h).map_err(anyhow::Error::msg)?;
    Ok((w, h))
}

fn check_mode(mode: Mode) -> Result<()> {
    if !mode.available() {
        let ready: Vec<_> = Mode::ALL
            .iter()
            .filter(|m| m.available())
            .map(|m| m.name())
            .collect();
        bail!(
            "mode \"{mode}\" is not available yet in this build (available: {})",
            ready.join(", ")
        );
    }
    Ok(())
}

fn cmd_render(a: RenderArgs) -> Result<()> {
    let c = &a.common;
    check_mode(c.mode)?;
    let aovs = Aov::parse_list(&a.aov)?;
    let ext = a
        .out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    if !matches!(ext.as_deref(), Some("png" | "exr")) {
        bail!("{}: --out must end in .png or .exr", a.out.display());
    }
    if a.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if !a.orbit.is_finite() {
        bail!("--orbit must be a finite number of degrees");
    }
    // Checked before rendering, not after the first (or last) frame.
    if let Some(dir) = a
        .out
        .parent()
        .filter(|d| !d.as_os_str().is_empty() && !d.is_dir())
    {
        bail!("{}: the directory of --out does not exist", dir.display());
    }
    let per_frame = FramePattern::new(&a.out, a.frames);
    let scene = load_scene(c.scene.as_deref())?;
    let (w, h) = frame_size(&scene, c.width, c.height)?;
    let device = Device::new().context("starting Embree")?;
    let camera = scene.camera;
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let pool = embree::thread_pool(c.threads)?;
    let settings = RenderSettings {
        mode: c.mode,
        spp: c.spp.max(1),
        seed: c.seed,
        denoise: c.denoise == Switch::On,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(w, h);
    let mut last = None;
    let mut written = Vec::new();
    pool.install(|| -> Result<()> {
        for k in 0..a.frames {
            let cam = camera.orbit(a.orbit * k as f32);
            last = Some(frame.render(&world, &cam, &settings));
            if let Some(p) = &per_frame {
                written.extend(output::write_frame(&p.path(k), &frame, c.exposure, &aovs)?);
            }
        }
        Ok(())
    })?;
    if per_frame.is_none() {
        written = output::write_frame(&a.out, &frame, c.exposure, &aovs)?;
    }
    if let Some(t) = last {
        eprintln!(
            "{}x{} {} spp={} frames={}: last frame {:.1} ms",
            w,
            h,
            c.mode,
            settings.spp,
            a.frames,
            t.wall * 1e3
        );
    }
    for p in written {
        println!("{}", p.display());
    }
    Ok(())
}

/// An `--out` path holding `{frame}`: every frame gets its own file.
struct FramePattern {
    text: String,
    digits: usize,
}

impl FramePattern {
    const TOKEN: &'static str = "{frame}";

    /// `None` when `out` has no `{frame}` (only the last frame is written).
    fn new(out: &Path, frames: u32) -> Option<FramePattern> {
        let text = out.to_str()?;
        if !text.contains(Self::TOKEN) {
            return None;
        }
        // Padded so that the files sort in frame order: 4 digits, more when
        // the last frame number is longer.
        let digits = (frames.saturating_sub(1)).to_string().len().max(4);
        Some(FramePattern {
            text: text.to_string(),
            digits,
        })
    }

    fn path(&self, frame: u32) -> PathBuf {
        let number = format!("{frame:0width$}", width = self.digits);
        PathBuf::from(self.text.replace(Self::TOKEN, &number))
    }
}

fn view_options(a: ViewArgs) -> penumbra::view::ViewOptions {
    penumbra::view::ViewOptions {
        scene: a.common.scene,
        width: a.common.width,
        height: a.common.height,
        mode: a.common.mode,
        spp: a.common.spp.max(1),
        threads: a.common.threads,
        seed: a.common.seed,
        denoise: a.common.denoise == Switch::On,
        exposure: a.common.exposure,
        overlay: a.overlay == Switch::On,
        frames: a.frames,
        screenshot: a.screenshot,
        script: a.script,
    }
}

fn cmd_bench(a: BenchArgs) -> Result<()> {
    let scenes: Vec<Option<PathBuf>> = if a.scenes.is_empty() {
        vec![None]
    } else {
        a.scenes.into_iter().map(Some).collect()
    };
    for path in scenes {
        let scene = load_scene(path.as_deref())?;
        let report = penumbra::report::bench_scene(scene, a.width, a.height, a.frames.max(1))?;
        print!("{report}");
    }
    Ok(())
}

//! The `penumbra` command line: render, view, bench, fit-ltc, compare.

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use penumbra::embree::{self, Device};
use penumbra::output::{self, Aov};
use penumbra::render::{
    Frame, LIGHT_TOLERANCE, Mode, RenderSettings, Upscaled, VisibilityRate, World,
};
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
    /// Measure speed against error, the Embree ceiling and scaling.
    Bench(BenchArgs),
    /// Fit the LTC table for the project's GGX BRDF.
    FitLtc(FitArgs),
    /// Measure an image against a reference (relMSE, FLIP, largest error).
    /// Exit status: 0 within the limits, 1 above one, 2 on bad input.
    Compare(CompareArgs),
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
    /// Per-frame sub-pixel jitter of camera rays and a temporal resolve of
    /// the frames (every mode but reference): on | off. Frame 0 is never
    /// jittered, so a one-frame render is the same either way.
    #[arg(long, default_value = "on")]
    taa: Switch,
    /// Which pixels draw visibility samples each frame in denoised ratio
    /// and soft-shadow: full (every pixel) | quarter (one of each 2x2,
    /// rotating; denoised at quad resolution and upsampled along the
    /// G-buffer's edges). `U` is evaluated at every pixel either way.
    #[arg(long, default_value = "full")]
    visibility_rate: VisibilityRate,
    /// Under a still camera, 8x8 tiles whose visibility has settled
    /// (exactly lit or in umbra over 8 frames of history) draw no shadow
    /// rays, each refreshed one frame in 8 (denoised ratio, full rate):
    /// on | off.
    #[arg(long, default_value = "on")]
    settle: Switch,
    /// Light culling of the analytic U: per 8x4-pixel tile, lights whose
    /// bounded share is negligible are left out, so that every pixel's U is
    /// at least 1 - T of every light's sum; 0 evaluates every light at every
    /// pixel.
    #[arg(long, default_value_t = LIGHT_TOLERANCE, value_parser = parse_tolerance, allow_negative_numbers = true)]
    light_tolerance: f32,
    /// Exposure in stops for PNG and the window.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    exposure: f32,
}

impl SceneArgs {
    /// What every frame of `render` and `view` runs with: the one place the
    /// command line's flags become the renderer's settings.
    fn settings(&self) -> RenderSettings {
        RenderSettings {
            mode: self.mode,
            spp: self.spp.max(1),
            seed: self.seed,
            denoise: self.denoise == Switch::On,
            taa: self.taa == Switch::On,
            visibility: self.visibility_rate,
            settle: self.settle == Switch::On,
            light_tolerance: self.light_tolerance,
            ..RenderSettings::default()
        }
    }
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
    /// Render each frame at this fraction of each side of the output and
    /// upscale it to the output's size, accumulating the jittered frames
    /// there (a number in (0, 1]; 1 renders at the output's size).
    #[arg(long, default_value_t = 1.0, value_parser = parse_render_scale, allow_negative_numbers = true)]
    render_scale: f32,
    /// After the last frame, print every sample pixel X,Y drew in it (light,
    /// strategy, pdfs, weight, visibility) and the frame's values there.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel)]
    debug_pixel: Option<(u32, u32)>,
}

/// A light culling tolerance: a number in [0, 0.5].
fn parse_tolerance(s: &str) -> std::result::Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(t) if (0.0..=0.5).contains(&t) => Ok(t),
        _ => Err(format!(
            "\"{s}\" is not a light tolerance (a number from 0 to 0.5, e.g. 0.01)"
        )),
    }
}

/// A render scale: a number in (0, 1].
fn parse_render_scale(s: &str) -> std::result::Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(t) if t > 0.0 && t <= 1.0 => Ok(t),
        _ => Err(format!(
            "\"{s}\" is not a render scale (a number above 0 and at most 1, e.g. 0.5)"
        )),
    }
}

/// `X,Y` as two pixel coordinates.
fn parse_pixel(s: &str) -> std::result::Result<(u32, u32), String> {
    let bad = || format!("\"{s}\" is not a pixel X,Y (two whole numbers from 0, e.g. 320,180)");
    let (x, y) = s.split_once(',').ok_or_else(bad)?;
    Ok((
        x.trim().parse().map_err(|_| bad())?,
        y.trim().parse().map_err(|_| bad())?,
    ))
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
    /// Replay timed key and mouse events from this file (format: docs/viewer.md).
    #[arg(long)]
    script: Option<PathBuf>,
    /// Scale the render resolution (down to a quarter of each side) to
    /// hold this many frames per second; the frames are upscaled to the
    /// window's size by a temporal upscale, so a still camera converges to
    /// the full-size image. 0 renders at the window's size.
    #[arg(long, default_value_t = penumbra::view::DEFAULT_TARGET_FPS, allow_negative_numbers = true)]
    target_fps: f32,
    /// Draw the overlay (mode, timings, fps): on | off. Key O toggles it.
    #[arg(long, default_value = "on")]
    overlay: Switch,
}

#[derive(Args)]
struct BenchArgs {
    /// Scenes to measure (default: scenes/shadow-plane.toml and
    /// scenes/room.toml when present, else the built-in scene; --quick: the
    /// built-in scene).
    scenes: Vec<PathBuf>,
    /// Small frames, few configurations, a cheap reference: a smoke run.
    #[arg(long)]
    quick: bool,
    /// Write every figure, the machine and the git revision as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw relMSE against ms per frame (log-log) to this PNG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Frames measured per configuration after one warm-up (default 7; --quick 3).
    #[arg(long)]
    frames: Option<u32>,
    /// Frame width (default 1280; --quick 256).
    #[arg(long)]
    width: Option<u32>,
    /// Frame height (default 720; --quick 144).
    #[arg(long)]
    height: Option<u32>,
    /// Samples per pixel of the reference (default 256; --quick 64).
    #[arg(long)]
    ref_spp: Option<u32>,
    /// Print (and with --plot, draw) a report saved by --json instead of measuring.
    #[arg(long, value_name = "FILE.json")]
    from_json: Option<PathBuf>,
    /// Samples per pixel of the measured rows (default 1,2,4,8; --quick 1,4).
    #[arg(long, value_delimiter = ',')]
    spp: Vec<u32>,
    /// Measure only these configurations, by the labels of the table
    /// (comma-separated, e.g. "ratio+dn,ratio+dn 1/4").
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
    /// Measure each scene also with only these of its lights (by position
    /// in the file, from 0, e.g. 0,1), in the same run.
    #[arg(long, value_delimiter = ',')]
    light_subset: Vec<usize>,
    /// The light culling tolerance of every measured row (see render --help).
    #[arg(long, default_value_t = LIGHT_TOLERANCE, value_parser = parse_tolerance, allow_negative_numbers = true)]
    light_tolerance: f32,
    /// Where references are cached.
    #[arg(long, default_value = "target/penumbra-cache")]
    cache: PathBuf,
    /// Instead of the table: the viewer's dynamic resolution against the
    /// full-size frame at equal wall-clock time, still and orbiting, and
    /// the output pass in ns per pixel (docs/interactive.md).
    #[arg(long)]
    equal_time: bool,
    /// --equal-time: the instants of the still camera, seconds.
    #[arg(long, value_delimiter = ',', default_values_t = [0.5, 2.0, 8.0])]
    still_seconds: Vec<f64>,
    /// --equal-time: how long the camera orbits (1 degree per frame).
    #[arg(long, default_value_t = 3.0)]
    orbit_seconds: f64,
    /// --equal-time: samples per pixel of each orbit frame's reference.
    #[arg(long, default_value_t = 16)]
    orbit_ref_spp: u32,
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

#[derive(Args)]
struct CompareArgs {
    /// The image measured (.exr or .png).
    test: PathBuf,
    /// The reference (same size and format).
    reference: PathBuf,
    /// Write FLIP's error map to this PNG.
    #[arg(long, value_name = "FILE.png")]
    heatmap: Option<PathBuf>,
    /// Exit 1 when relMSE is above this.
    #[arg(long, value_name = "X")]
    max_relmse: Option<f64>,
    /// Exit 1 when mean FLIP is above this.
    #[arg(long, value_name = "Y")]
    max_flip: Option<f64>,
    /// The frame's depth AOV (`render --aov depth`): speckles are counted
    /// away from its geometric edges (without it, where the reference is smooth).
    #[arg(long, value_name = "FILE.exr")]
    depth: Option<PathBuf>,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // A level that is not one, or one this CPU lacks, is an error here, not
    // a silent fall-back inside the hot loops.
    if let Err(e) = penumbra::isa::Isa::requested() {
        eprintln!("penumbra: {e}");
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Compare(a) => return cmd_compare(a),
        Command::Render(a) => cmd_render(a),
        Command::View(a) => penumbra::view::run(view_options(a)),
        Command::Bench(a) => cmd_bench(a),
        Command::FitLtc(a) => penumbra::fit_ltc::run_fit(a.size, &a.out, a.heatmap.as_deref()),
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

fn cmd_render(a: RenderArgs) -> Result<()> {
    let c = &a.common;
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
    let upscaled = a.render_scale < 1.0;
    if upscaled && (!aovs.is_empty() || a.debug_pixel.is_some()) {
        bail!(
            "--aov and --debug-pixel describe the rendered frame, which --render-scale below 1 \
             makes smaller than the output; render at scale 1 for them"
        );
    }
    let per_frame = FramePattern::new(&a.out, a.frames);
    let scene = load_scene(c.scene.as_deref())?;
    let (w, h) = frame_size(&scene, c.width, c.height)?;
    if let Some((x, y)) = a.debug_pixel.filter(|&(x, y)| x >= w || y >= h) {
        bail!("--debug-pixel {x},{y} lies outside the {w}x{h} frame");
    }
    let device = Device::new().context("starting Embree")?;
    let camera = scene.camera;
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let pool = embree::thread_pool(c.threads)?;
    let settings = c.settings();
    let (rw, rh) = penumbra::render::scaled_size(w, h, a.render_scale);
    let mut frame = Frame::new(rw, rh);
    let mut target = upscaled.then(|| Upscaled::new(w, h));
    let write = |path: &Path, frame: &Frame, target: &Option<Upscaled>| match target {
        Some(o) => {
            output::write_color(path, w, h, &o.color, c.exposure).map(|()| vec![path.into()])
        }
        None => output::write_frame(path, frame, c.exposure, &aovs),
    };
    let mut last = None;
    let mut written = Vec::new();
    pool.install(|| -> Result<()> {
        for k in 0..a.frames {
            let cam = camera.orbit(a.orbit * k as f32);
            last = Some(penumbra::render::render_frame(
                &mut frame,
                target.as_mut(),
                &world,
                &cam,
                &settings,
            ));
            if let Some(p) = &per_frame {
                written.extend(write(&p.path(k), &frame, &target)?);
            }
        }
        Ok(())
    })?;
    if per_frame.is_none() {
        written = write(&a.out, &frame, &target)?;
    }
    if let Some((x, y)) = a.debug_pixel {
        let replay = penumbra::render::replay::replay_pixel(&world, &frame, &settings, x, y)
            .map_err(anyhow::Error::msg)?;
        print!("{}", replay.report(&world));
    }
    if let Some(t) = last {
        let scaled = if upscaled {
            format!(" (rendered at {rw}x{rh})")
        } else {
            String::new()
        };
        eprintln!(
            "{}x{}{scaled} {} spp={} frames={}: last frame {:.1} ms (denoiser {:.2} ms)",
            w,
            h,
            c.mode,
            settings.spp,
            a.frames,
            t.wall * 1e3,
            t.denoise * 1e3
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
    let settings = a.common.settings();
    penumbra::view::ViewOptions {
        scene: a.common.scene,
        width: a.common.width,
        height: a.common.height,
        settings,
        threads: a.common.threads,
        exposure: a.common.exposure,
        overlay: a.overlay == Switch::On,
        target_fps: (a.target_fps != 0.0).then_some(a.target_fps),
        frames: a.frames,
        screenshot: a.screenshot,
        script: a.script,
    }
}

fn cmd_bench(a: BenchArgs) -> Result<()> {
    use penumbra::report::{self, BenchOptions};
    let mut opts = if a.quick {
        BenchOptions::quick(a.cache)
    } else {
        BenchOptions::full(a.cache)
    };
    opts.width = a.width.unwrap_or(opts.width);
    opts.height = a.height.unwrap_or(opts.height);
    opts.frames = a.frames.unwrap_or(opts.frames);
    opts.reference_spp = a.ref_spp.unwrap_or(opts.reference_spp);
    opts.only = a.only;
    opts.light_subset = a.light_subset;
    opts.light_tolerance = a.light_tolerance;
    if !a.spp.is_empty() {
        if a.spp.contains(&0) {
            bail!("--spp must be at least 1");
        }
        opts.spps = a.spp;
    }
    penumbra::scene::check_resolution(opts.width, opts.height).map_err(anyhow::Error::msg)?;
    if opts.frames == 0 || opts.reference_spp == 0 {
        bail!("--frames and --ref-spp must be at least 1");
    }
    if a.plot.is_some() {
        // A missing font is reported now, not after the run.
        report::plot::load_font()?;
    }
    let shipped = [
        PathBuf::from("scenes/shadow-plane.toml"),
        PathBuf::from("scenes/room.toml"),
    ];
    let scenes: Vec<Option<PathBuf>> = if !a.scenes.is_empty() {
        a.scenes.into_iter().map(Some).collect()
    } else if !a.quick && shipped.iter().all(|p| p.is_file()) {
        shipped.into_iter().map(Some).collect()
    } else {
        vec![None]
    };
    if a.equal_time {
        if a.still_seconds.iter().any(|s| !(s.is_finite() && *s > 0.0))
            || !(a.orbit_seconds.is_finite() && a.orbit_seconds > 0.0)
            || a.orbit_ref_spp == 0
        {
            bail!(
                "--still-seconds and --orbit-seconds must be positive, --orbit-ref-spp at least 1"
            );
        }
        let mut e = report::interactive::EqualTimeOptions::new(opts.cache_dir.clone());
        (e.width, e.height, e.reference_spp) = (opts.width, opts.height, opts.reference_spp);
        (e.still_seconds, e.orbit_seconds, e.orbit_reference_spp) =
            (a.still_seconds, a.orbit_seconds, a.orbit_ref_spp);
        print!("{}", report::interactive::run(&scenes, &e)?);
        return Ok(());
    }
    let result = match &a.from_json {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("reading {}", path.display()))?;
            let r: report::results::BenchReport = serde_json::from_str(&text)
                .with_context(|| format!("{}: not a penumbra bench report", path.display()))?;
            if r.format != report::results::JSON_FORMAT {
                bail!(
                    "{}: report format {} (this build reads {})",
                    path.display(),
                    r.format,
                    report::results::JSON_FORMAT
                );
            }
            r
        }
        None => report::run(&scenes, &opts)?,
    };
    print!("{}", report::format_report(&result));
    if let Some(path) = &a.json {
        let text = serde_json::to_string_pretty(&result)?;
        std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))?;
        println!("{}", path.display());
    }
    if let Some(path) = &a.plot {
        report::plot::plot(&result, path)?;
        println!("{}", path.display());
    }
    Ok(())
}

/// `compare`'s exit status when an image is above a limit; bad input
/// exits 2, as clap does for bad arguments.
const EXIT_ABOVE_LIMIT: u8 = 1;
const EXIT_BAD_INPUT: u8 = 2;

fn cmd_compare(a: CompareArgs) -> ExitCode {
    use penumbra::compare::{self, Image, Limits};
    let run = || -> Result<Vec<String>> {
        for (name, v) in [("--max-relmse", a.max_relmse), ("--max-flip", a.max_flip)] {
            if v.is_some_and(|v| !v.is_finite() || v < 0.0) {
                bail!("{name} must be a finite number, at least 0");
            }
        }
        let test = Image::load(&a.test)?;
        let reference = Image::load(&a.reference)?;
        let mut c = compare::compare(&test, &reference)?;
        if let Some(path) = &a.depth {
            let depth = Image::load(path)?;
            let mask = compare::away_from_depth_edges(&depth, &reference)?;
            c.speckles =
                compare::speckles(test.width, &test.pixels, &reference.pixels, Some(&mask));
        }
        print!("{}", compare::format(&c));
        if let Some(path) = &a.heatmap {
            compare::write_heatmap(&test, &reference, path)?;
            println!("{}", path.display());
        }
        let limits = Limits {
            max_rel_mse: a.max_relmse,
            max_flip: a.max_flip,
        };
        Ok(limits.exceeded(&c))
    };
    match run() {
        Ok(above) if above.is_empty() => ExitCode::SUCCESS,
        Ok(above) => {
            for line in above {
                eprintln!("penumbra: above the limit: {line}");
            }
            ExitCode::from(EXIT_ABOVE_LIMIT)
        }
        Err(e) => {
            eprintln!("penumbra: {e:#}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
    }
}

//! `penumbra bench`: for each configuration (mode, denoiser, spp) the
//! median and spread of the frame time and its stages, rays per second,
//! relMSE against a cached reference, and the ratio to the Embree ceiling;
//! then thread and resolution scaling and the equal-time comparison.

use super::ceiling::{Ceiling, ray_ceiling};
use super::machine::{Machine, git_revision};
use super::reference::{self, Reference};
use super::results::*;
use super::stats::{
    Spread, interior_of_view, interpolate_log_log, median, rel_mse, rel_mse_masked,
};
use crate::embree::{self, Device};
use crate::render::shadow::PacketWidth;
use crate::render::{
    Frame, FramePlan, LIGHT_TOLERANCE, Mode, PhaseTimes, RenderSettings, Upscaled, VisibilityRate,
    World, render_frame, scaled_size, shown,
};
use crate::scene::{Camera, Scene};
use anyhow::{Context, Result};
use glam::Vec3;
use std::path::{Path, PathBuf};

/// What to measure.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    pub width: u32,
    pub height: u32,
    /// Frames measured per configuration, after one warm-up frame.
    pub frames: u32,
    pub reference_spp: u32,
    /// Samples per pixel of `ratio` and `stochastic`, with and without the denoiser.
    pub spps: Vec<u32>,
    /// Also `soft-shadow` (denoised, 1 spp), and undenoised `ratio` at
    /// 1 spp with shadow rays as 8-wide packets and as single rays.
    pub extras: bool,
    pub cache_dir: PathBuf,
    pub quick: bool,
    /// Measure only the configurations of these labels (empty: all).
    pub only: Vec<String>,
    /// Measure each scene also with only these of its lights (empty: no).
    pub light_subset: Vec<usize>,
    /// The light culling tolerance of every measured configuration.
    pub light_tolerance: f32,
}

impl BenchOptions {
    /// The full run: 1280x720, 1-8 spp, every mode.
    pub fn full(cache_dir: PathBuf) -> BenchOptions {
        BenchOptions {
            width: 1280,
            height: 720,
            frames: 7,
            reference_spp: 256,
            spps: vec![1, 2, 4, 8],
            extras: true,
            cache_dir,
            quick: false,
            only: Vec::new(),
            light_subset: Vec::new(),
            light_tolerance: LIGHT_TOLERANCE,
        }
    }

    /// A smoke run for CI: small frames, few configurations, a cheap reference.
    pub fn quick(cache_dir: PathBuf) -> BenchOptions {
        BenchOptions {
            width: 256,
            height: 144,
            frames: 3,
            reference_spp: 64,
            spps: vec![1, 4],
            extras: false,
            cache_dir,
            quick: true,
            only: Vec::new(),
            light_subset: Vec::new(),
            light_tolerance: LIGHT_TOLERANCE,
        }
    }

    fn configs(&self) -> Vec<Config> {
        let plain = |mode, denoise, spp| Config {
            mode,
            denoise,
            spp,
            packet: PacketWidth::Sixteen,
            rate: VisibilityRate::Full,
            still: Still::Short,
            scale: 1.0,
        };
        let mut c = Vec::new();
        for mode in [Mode::Ratio, Mode::Stochastic] {
            for denoise in [false, true] {
                for &spp in &self.spps {
                    c.push(plain(mode, denoise, spp));
                }
            }
        }
        for &spp in &self.spps {
            c.push(Config {
                rate: VisibilityRate::Quarter,
                ..plain(Mode::Ratio, true, spp)
            });
        }
        // Half the size a side, upscaled to the output: the viewer's
        // dynamic resolution at its half step.
        c.push(Config {
            scale: UPSCALED_SCALE,
            ..plain(Mode::Ratio, true, 1)
        });
        if self.extras {
            for packet in [PacketWidth::Eight, PacketWidth::One] {
                c.push(Config {
                    packet,
                    ..plain(Mode::Ratio, false, 1)
                });
            }
            for rate in VisibilityRate::ALL {
                c.push(Config {
                    rate,
                    ..plain(Mode::SoftShadow, true, 1)
                });
            }
        }
        // A camera held still for long: every tile sampled, and settled
        // tiles left alone (`RenderSettings::settle`).
        for still in [Still::Long, Still::Settled] {
            c.push(Config {
                still,
                ..plain(Mode::Ratio, true, 1)
            });
        }
        c.push(plain(Mode::Unshadowed, false, 1));
        c.retain(|c| self.only.is_empty() || self.only.iter().any(|l| *l == c.label()));
        c
    }
}

/// One measured configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Config {
    mode: Mode,
    denoise: bool,
    spp: u32,
    packet: PacketWidth,
    rate: VisibilityRate,
    still: Still,
    /// Render size over output size per side (below 1: upscaled).
    scale: f32,
}

/// The upscaled row's render scale.
const UPSCALED_SCALE: f32 = 0.5;

/// How long the camera has been still when a configuration is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Still {
    /// One warm-up frame.
    Short,
    /// `LONG_WARMUP` warm-up frames, every tile sampled.
    Long,
    /// `LONG_WARMUP` warm-up frames, settled tiles drawing no samples (as
    /// shipped).
    Settled,
}

/// Warm-up frames of the long still-camera rows: past the history a tile
/// needs to settle (8 frames), so the measured frames show the steady state.
const LONG_WARMUP: u32 = 16;

impl Config {
    fn label(&self) -> String {
        let mut base = label(self.mode, self.denoise, self.packet, self.rate);
        if self.scale < 1.0 {
            base = format!("{base} {}% res", (self.scale * 100.0).round());
        }
        match self.still {
            Still::Short => base,
            Still::Long => format!("{base} still"),
            Still::Settled => format!("{base} settled"),
        }
    }

    fn warmup(&self) -> u32 {
        match self.still {
            Still::Short => 1,
            Still::Long | Still::Settled => LONG_WARMUP,
        }
    }

    fn settings(&self) -> RenderSettings {
        RenderSettings {
            mode: self.mode,
            denoise: self.denoise,
            spp: self.spp,
            packet: self.packet,
            visibility: self.rate,
            // Undenoised rows are single-frame estimates (their error is
            // the median over frames), so their frames stand alone; the
            // denoised rows run as shipped, jitter and resolve included.
            taa: self.denoise && self.mode != Mode::Unshadowed,
            // As shipped (a tile settles only after 8 frames, past the short
            // rows' frames), but for the row that samples every tile.
            settle: self.still != Still::Long,
            ..RenderSettings::default()
        }
    }
}

/// The label of a configuration: mode, `+dn` when denoised, ` 1/4` when a
/// quarter of the pixels draw visibility samples, ` (x8)` or ` (x1)` when
/// shadow rays are not 16-wide packets.
pub fn label(mode: Mode, denoise: bool, packet: PacketWidth, rate: VisibilityRate) -> String {
    let settings = RenderSettings {
        mode,
        denoise,
        visibility: rate,
        ..RenderSettings::default()
    };
    let plan = FramePlan::of(&settings);
    let dn = plan.denoise;
    let width = match packet {
        PacketWidth::Sixteen => "",
        PacketWidth::Eight => " (x8)",
        PacketWidth::One => " (x1)",
    };
    let rate = match plan.rate {
        VisibilityRate::Full => "",
        VisibilityRate::Quarter => " 1/4",
    };
    format!(
        "{}{}{rate}{width}",
        mode.name(),
        if dn { "+dn" } else { "" }
    )
}

/// The shipped default's label (`RenderSettings::default()`).
pub fn default_label() -> String {
    let s = RenderSettings::default();
    label(s.mode, s.denoise, s.packet, s.visibility)
}

/// A scene to measure: its file (`None`: the built-in scene).
pub fn run(scenes: &[Option<PathBuf>], opts: &BenchOptions) -> Result<BenchReport> {
    let started_unix = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    // Read before the run: the tree may change while it measures.
    let git_revision = git_revision();
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut reports = Vec::new();
    for path in scenes {
        let scene = match path {
            Some(p) => Scene::load(p)?,
            None => Scene::builtin(),
        };
        let subset = if opts.light_subset.is_empty() {
            None
        } else {
            let mut fewer = scene.clone();
            fewer.lights = light_subset(&scene, &opts.light_subset)?;
            Some(fewer)
        };
        reports.push(bench_scene(scene, path.as_deref(), None, opts, threads)?);
        if let Some(fewer) = subset {
            let kept = Some(&opts.light_subset[..]);
            reports.push(bench_scene(fewer, path.as_deref(), kept, opts, threads)?);
        }
    }
    Ok(BenchReport {
        format: JSON_FORMAT,
        penumbra_version: env!("CARGO_PKG_VERSION").to_string(),
        git_revision,
        machine: Machine::this(),
        started_unix,
        settings: Settings {
            width: opts.width,
            height: opts.height,
            threads,
            warmup_frames: 1,
            measured_frames: opts.frames,
            reference_spp: opts.reference_spp,
            quick: opts.quick,
            error_method: format!(
                "relMSE = mean((x-ref)^2/(ref^2+1e-2)) over pixels and channels, static camera; \
                 undenoised: median over the {} measured frames (each a single-frame estimate); \
                 denoised: the last frame, i.e. frame {} of a static camera with temporal history \
                 (rel_mse_first_frame: frame 1, no history); rows marked still or settled: \
                 after {LONG_WARMUP} warm-up frames instead of one",
                opts.frames,
                opts.frames + 1
            ),
        },
        scenes: reports,
    })
}

/// The lights of `scene` at the positions `kept` (from 0, in file order).
fn light_subset(scene: &Scene, kept: &[usize]) -> Result<Vec<crate::scene::Light>> {
    kept.iter()
        .map(|&i| {
            scene.lights.get(i).cloned().with_context(|| {
                format!(
                    "--light-subset: light {i} does not exist ({} has {} lights, from 0)",
                    scene.source.display(),
                    scene.lights.len()
                )
            })
        })
        .collect()
}

/// One configuration's repeated frames.
struct Measured {
    runs: Vec<PhaseTimes>,
    /// relMSE per measured frame, all pixels and interior.
    errors: Vec<(f64, f64)>,
    first_frame_error: Option<f64>,
    /// Speckle share (`compare::speckles`, interior) after the first and the last frame.
    speckles: [Option<f64>; 2],
}

struct Bench<'a, 'd> {
    world: &'a World<'d>,
    camera: Camera,
    frames: u32,
}

impl Bench<'_, '_> {
    /// `warmup` frames, then `frames` measured ones, of a static camera.
    /// `scale` below 1 renders smaller and upscales to `width` x `height`.
    #[allow(clippy::too_many_arguments)]
    fn measure(
        &self,
        pool: &rayon::ThreadPool,
        (width, height): (u32, u32),
        scale: f32,
        settings: &RenderSettings,
        warmup: u32,
        truth: Option<(&[Vec3], &[bool])>,
    ) -> Measured {
        let (rw, rh) = scaled_size(width, height, scale);
        let mut frame = Frame::new(rw, rh);
        let mut output = (scale < 1.0).then(|| Upscaled::new(width, height));
        let render = |frame: &mut Frame, output: &mut Option<Upscaled>| {
            pool.install(|| {
                render_frame(frame, output.as_mut(), self.world, &self.camera, settings)
            })
        };
        for _ in 0..warmup.max(1) {
            render(&mut frame, &mut output);
        }
        let error = |f: &Frame, o: &Option<Upscaled>| {
            let c = shown(f, o.as_ref());
            truth.map(|(r, m)| (rel_mse(c, r), rel_mse_masked(c, r, m)))
        };
        let first_frame_error = error(&frame, &output).map(|e| e.0);
        let speckle = |f: &Frame, o: &Option<Upscaled>| {
            let c = shown(f, o.as_ref());
            truth.map(|(r, m)| crate::compare::speckles(width, c, r, Some(m)).fraction())
        };
        let first_speckles = speckle(&frame, &output);
        let mut runs = Vec::new();
        let mut errors = Vec::new();
        for _ in 0..self.frames {
            runs.push(render(&mut frame, &mut output));
            errors.extend(error(&frame, &output));
        }
        Measured {
            runs,
            errors,
            first_frame_error,
            speckles: [first_speckles, speckle(&frame, &output)],
        }
    }

    /// Embree alone on the same rays, median over `frames` runs.
    fn ceiling(
        &self,
        pool: &rayon::ThreadPool,
        (width, height): (u32, u32),
        spp: u32,
    ) -> (Spread, Ceiling) {
        let runs: Vec<Ceiling> = (0..self.frames.max(3))
            .map(|_| pool.install(|| ray_ceiling(self.world, &self.camera, width, height, spp)))
            .collect();
        let totals: Vec<f64> = runs.iter().map(|c| c.total()).collect();
        let mid = Ceiling {
            primary: median(&runs.iter().map(|c| c.primary).collect::<Vec<_>>()),
            shadow: median(&runs.iter().map(|c| c.shadow).collect::<Vec<_>>()),
            shadow_rays: runs[0].shadow_rays,
        };
        (Spread::of(&totals).scaled(1e3), mid)
    }
}

fn frame_spread(runs: &[PhaseTimes]) -> Spread {
    Spread::of(&runs.iter().map(|r| r.wall).collect::<Vec<_>>()).scaled(1e3)
}

fn bench_scene(
    scene: Scene,
    path: Option<&Path>,
    subset: Option<&[usize]>,
    opts: &BenchOptions,
    threads: usize,
) -> Result<SceneReport> {
    let mut name = path.map_or("<builtin>".into(), |p| p.display().to_string());
    if let Some(kept) = subset {
        let list: Vec<String> = kept.iter().map(|i| i.to_string()).collect();
        name = format!("{name} (lights {})", list.join(","));
    }
    let (triangles, lights) = (scene.triangle_count(), scene.lights.len());
    let camera = scene.camera;
    let device = Device::new().context("starting Embree")?;
    let world = World::build(&device, scene).context("building the ray-tracing scene")?;
    let all = embree::thread_pool(threads)?;
    let size = (opts.width, opts.height);
    let pixels = opts.width as u64 * opts.height as u64;
    let bench = Bench {
        world: &world,
        camera,
        frames: opts.frames.max(1),
    };

    let Reference {
        color: truth,
        spp: ref_spp,
        file,
        reused,
        render_seconds,
    } = all.install(|| {
        reference::reference(
            &world,
            path,
            opts.width,
            opts.height,
            opts.reference_spp,
            &opts.cache_dir,
            subset,
        )
    })?;
    let mask = interior_of_view(&world, &camera, (opts.width, opts.height), &all);

    let mut ceilings: Vec<CeilingReport> = Vec::new();
    let mut ceiling_for = |spp: u32, pool: &rayon::ThreadPool, t: usize| -> f64 {
        if let Some(c) = ceilings.iter().find(|c| c.spp == spp && c.threads == t) {
            return c.total_ms.median;
        }
        let (total_ms, mid) = bench.ceiling(pool, size, spp);
        ceilings.push(CeilingReport {
            spp,
            threads: t,
            total_ms,
            primary_ms: mid.primary * 1e3,
            shadow_ms: mid.shadow * 1e3,
            camera_rays: pixels,
            shadow_rays: mid.shadow_rays as u64,
        });
        total_ms.median
    };

    let mut configs = Vec::new();
    let todo = opts.configs();
    let bar = super::progress::bar(
        todo.len() as u64,
        format!("measuring {name}"),
        "configurations",
    );
    for (i, cfg) in todo.iter().enumerate() {
        let (mode, spp) = (cfg.mode, cfg.spp);
        bar.set_position(i as u64);
        bar.set_message(format!("{} at {spp} spp", cfg.label()));
        let settings = RenderSettings {
            light_tolerance: opts.light_tolerance,
            ..cfg.settings()
        };
        let m = bench.measure(
            &all,
            size,
            cfg.scale,
            &settings,
            cfg.warmup(),
            Some((&truth, &mask)),
        );
        let frame_ms = frame_spread(&m.runs);
        let stage = |f: fn(&PhaseTimes) -> f64| {
            median(&m.runs.iter().map(f).collect::<Vec<_>>()) / threads as f64 * 1e3
        };
        let shadow_rays = median(
            &m.runs
                .iter()
                .map(|r| r.shadow_rays as f64)
                .collect::<Vec<_>>(),
        ) as u64;
        let shadowed = mode != Mode::Unshadowed;
        let ceiling_ms = ceiling_for(if shadowed { spp } else { 0 }, &all, threads);
        let dn = FramePlan::of(&settings).denoise;
        let (rel, rel_in) = if dn {
            *m.errors.last().expect("at least one measured frame")
        } else {
            (
                median(&m.errors.iter().map(|e| e.0).collect::<Vec<_>>()),
                median(&m.errors.iter().map(|e| e.1).collect::<Vec<_>>()),
            )
        };
        configs.push(ConfigReport {
            label: cfg.label(),
            visibility: FramePlan::of(&settings).rate.name().to_string(),
            render_scale: cfg.scale,
            mode: mode.name().to_string(),
            denoise: dn,
            spp: if shadowed { spp } else { 0 },
            threads,
            warmup_frames: cfg.warmup(),
            frame_ms,
            fps: 1e3 / frame_ms.median,
            stages_ms: Stages {
                primary: stage(|r| r.primary),
                u: stage(|r| r.u),
                shadow: stage(|r| r.shadow),
                denoise: median(&m.runs.iter().map(|r| r.denoise).collect::<Vec<_>>()) * 1e3,
                composite: stage(|r| r.composite),
                resolve: median(&m.runs.iter().map(|r| r.resolve).collect::<Vec<_>>()) * 1e3,
                upsample: median(&m.runs.iter().map(|r| r.upsample).collect::<Vec<_>>()) * 1e3,
            },
            camera_rays: pixels,
            shadow_rays,
            mrays_per_s: (pixels + shadow_rays) as f64 / (frame_ms.median * 1e-3) * 1e-6,
            u_lights: [0, 1].map(|i| {
                median(
                    &m.runs
                        .iter()
                        .map(|r| {
                            let pairs: u64 = r.u_pairs.iter().sum();
                            let surface = pairs as f64 / world.lights.len().max(1) as f64;
                            r.u_pairs[i] as f64 / surface.max(1.0)
                        })
                        .collect::<Vec<_>>(),
                )
            }),
            rel_mse: rel,
            rel_mse_interior: rel_in,
            rel_mse_first_frame: if dn { m.first_frame_error } else { None },
            speckles: m.speckles[1],
            speckles_first_frame: if dn { m.speckles[0] } else { None },
            ceiling_ms,
            over_ceiling: frame_ms.median / ceiling_ms,
        });
    }

    bar.finish_and_clear();
    eprintln!("\rmeasuring {name}: scaling with threads and resolution          ");
    // Scaling of the shipped default: 1, 2, 4, ... threads up to all of
    // them, and a quarter of the pixels against the full frame.
    let scaled = RenderSettings::default();
    let shipped = default_label();
    let full = configs
        .iter()
        .find(|c| c.label == shipped && c.spp == scaled.spp)
        .map(|c| c.frame_ms)
        .unwrap_or_else(|| frame_spread(&bench.measure(&all, size, 1.0, &scaled, 1, None).runs));
    let mut thread_points = Vec::new();
    for t in thread_counts(threads) {
        if t == threads {
            thread_points.push(ThreadPoint {
                threads,
                frame_ms: full,
                ceiling_ms: ceiling_for(scaled.spp, &all, threads),
            });
        } else {
            let pool = embree::thread_pool(t)?;
            thread_points.push(ThreadPoint {
                threads: t,
                frame_ms: frame_spread(&bench.measure(&pool, size, 1.0, &scaled, 1, None).runs),
                ceiling_ms: ceiling_for(scaled.spp, &pool, t),
            });
        }
    }
    let (first, last) = (&thread_points[0], &thread_points[thread_points.len() - 1]);
    let thread_speedup = first.frame_ms.median / last.frame_ms.median;
    let ceiling_speedup = first.ceiling_ms / last.ceiling_ms;
    let half = ((opts.width / 2).max(8), (opts.height / 2).max(8));
    let half_ms = frame_spread(&bench.measure(&all, half, 1.0, &scaled, 1, None).runs);
    let resolution: Vec<ResolutionPoint> = [(size, full), (half, half_ms)]
        .into_iter()
        .map(|((w, h), ms)| ResolutionPoint {
            width: w,
            height: h,
            frame_ms: ms,
            ns_per_pixel: ms.median * 1e6 / (w as f64 * h as f64),
        })
        .collect();
    let per_pixel_ratio = resolution[1].ns_per_pixel / resolution[0].ns_per_pixel;

    Ok(SceneReport {
        scene: name,
        triangles,
        lights,
        reference: ReferenceInfo {
            spp: ref_spp,
            seed: reference::SEED,
            cache_file: file.display().to_string(),
            reused,
            render_seconds,
        },
        equal_time: equal_time(&configs),
        configs,
        ceilings,
        scaling: Scaling {
            config: format!("{shipped} {} spp", scaled.spp),
            threads: thread_points,
            thread_speedup,
            ceiling_speedup,
            resolution,
            per_pixel_ratio,
        },
    })
}

/// 1, 2, 4, ... threads, and `all` itself where it is no power of two.
fn thread_counts(all: usize) -> Vec<usize> {
    let mut counts: Vec<usize> = std::iter::successors(Some(1usize), |t| Some(t * 2))
        .take_while(|&t| t < all)
        .collect();
    counts.push(all.max(1));
    counts
}

/// Denoised `ratio` against denoised `stochastic` at equal frame time: each
/// measured point of either mode, with the other mode's relMSE interpolated
/// (log-log) at its ms per frame where that lies within the other's range.
/// The rows of a camera held still for long are other curves (their
/// history is longer), and stay out.
pub fn equal_time(configs: &[ConfigReport]) -> Vec<EqualTime> {
    let rate = RenderSettings::default().visibility.name();
    let curve = |mode: &str| -> Vec<(f64, f64, u32)> {
        configs
            .iter()
            .filter(|c| c.mode == mode && c.denoise)
            .filter(|c| c.render_scale == 1.0 && c.warmup_frames == 1)
            .filter(|c| c.mode != "ratio" || c.visibility == rate)
            .map(|c| (c.frame_ms.median, c.rel_mse, c.spp))
            .collect()
    };
    let (ratio, stoch) = (curve("ratio"), curve("stochastic"));
    let xy = |c: &[(f64, f64, u32)]| c.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>();
    let mut out = Vec::new();
    for &(ms, r, spp) in &ratio {
        if let Some(s) = interpolate_log_log(&xy(&stoch), ms) {
            out.push((format!("ratio+dn {spp} spp"), ms, r, s));
        }
    }
    for &(ms, s, spp) in &stoch {
        if let Some(r) = interpolate_log_log(&xy(&ratio), ms) {
            out.push((format!("stochastic+dn {spp} spp"), ms, r, s));
        }
    }
    out.sort_by(|a, b| a.1.total_cmp(&b.1));
    out.into_iter()
        .map(|(anchor, ms, r, s)| EqualTime {
            anchor,
            ms,
            ratio_rel_mse: r,
            stochastic_rel_mse: s,
            stochastic_over_ratio: s / r,
        })
        .collect()
}

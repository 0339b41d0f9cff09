//! One frame: trace the G-buffer, evaluate U and the stochastic estimates
//! per band of rows over rayon, then composite. Frame state that outlives a
//! frame (previous camera, reference accumulation) lives here too.

use super::estimate::{Estimator, analytic_u_band, draw_samples, ratio};
use super::gbuffer::{GSample, PixelKind};
use super::mode::Mode;
use super::primary::{PACKET_H, PixelOffset, trace_rows};
use super::shadow::{PacketWidth, ShadowBatch};
use super::world::World;
use crate::denoise::{
    CameraMotion, DenoiseSettings, Denoiser, GuideBuffers, Lobe, Resolve, ResolveSettings,
};
use crate::sampling::sequence::frame_jitter;
use crate::scene::{Camera, CameraFrame, Light};
use crate::shading::brdf::alpha_from_roughness;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Rows per parallel work item: two packet rows, so a band's G-buffer stays
/// in cache between the passes that read it.
pub const BAND_ROWS: u32 = 2 * PACKET_H;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    pub mode: Mode,
    /// Light samples per pixel per frame (`reference`: per call).
    pub spp: u32,
    pub seed: u32,
    /// How shadow rays are handed to Embree.
    pub packet: PacketWidth,
    /// Temporal + spatial denoising of `U_N`, `S_N` (ratio, stochastic, soft-shadow).
    pub denoise: bool,
    /// Per-frame sub-pixel jitter of the camera rays plus a temporal resolve
    /// of the colour (every mode but `reference`, which jitters per sample).
    /// Frame 0 is unjittered, so a one-frame render is the same either way.
    pub taa: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Mode::Ratio,
            spp: 1,
            seed: 0,
            packet: PacketWidth::Sixteen,
            denoise: true,
            taa: true,
        }
    }
}

/// What a band pass computes: where its camera rays go and which samples
/// it draws. The same steps serve every mode, the reference included.
#[derive(Clone, Copy)]
struct BandJob<'a, 'd> {
    world: &'a World<'d>,
    cam: &'a CameraFrame,
    prev: &'a CameraFrame,
    offset: PixelOffset,
    /// `None`: no samples (`U` only).
    estimator: Option<Estimator>,
    first_sample: u32,
    spp: u32,
    seed: u32,
    packet: PacketWidth,
    clock: &'a PhaseClock,
}

impl BandJob<'_, '_> {
    /// Primary rays, `U` per light, then samples and their shadow rays for
    /// the band starting at row `y0`. Returns the time it finished, for the
    /// next stage's clock.
    fn run(
        &self,
        y0: u32,
        scratch: &mut BandScratch,
        gbuf: &mut [GSample],
        u: &mut [Vec3],
        un: &mut [Vec3],
        sn: &mut [Vec3],
    ) -> Instant {
        let (world, clock) = (self.world, self.clock);
        let t = Instant::now();
        trace_rows(world, self.cam, self.prev, y0, self.offset, gbuf);
        let t = PhaseClock::add(&clock.primary, t);
        let lights = world.scene.lights.len();
        scratch.per_light.resize(gbuf.len() * lights, Vec3::ZERO);
        scratch.spec_share.resize(gbuf.len(), 0.0);
        analytic_u_band(
            world,
            gbuf,
            &mut scratch.per_light,
            u,
            &mut scratch.spec_share,
        );
        let t = PhaseClock::add(&clock.u, t);
        un.fill(Vec3::ZERO);
        sn.fill(Vec3::ZERO);
        let Some(est) = self.estimator else {
            return t;
        };
        scratch.batch.clear();
        let width = self.cam.width;
        for (k, g) in gbuf.iter().enumerate() {
            draw_samples(
                world,
                g,
                &scratch.per_light[k * lights..(k + 1) * lights],
                u[k],
                est,
                (y0 * width + k as u32, self.first_sample, self.seed),
                self.spp,
                k as u32,
                &mut un[k],
                &mut scratch.batch,
            );
        }
        scratch
            .batch
            .trace(&world.rt, self.packet, |r| sn[r.slot as usize] += r.weight);
        clock
            .shadow_rays
            .fetch_add(scratch.batch.rays.len() as u64, Ordering::Relaxed);
        PhaseClock::add(&clock.shadow, t)
    }
}

/// Per-thread working memory, reused across bands.
#[derive(Default)]
struct BandScratch {
    /// Analytic `U` of each light at each pixel of the band.
    per_light: Vec<Vec3>,
    /// Share of the specular lobe in each pixel's `U` (luminance).
    spec_share: Vec<f32>,
    batch: ShadowBatch,
}

/// Seconds spent in each stage of a frame. Stages run fused per band, so
/// each is thread time summed over all threads; `wall` is the frame's
/// elapsed time.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PhaseTimes {
    pub primary: f64,
    pub u: f64,
    pub shadow: f64,
    pub composite: f64,
    /// Wall time of the denoiser (it runs after the band pass, over the frame).
    pub denoise: f64,
    /// Wall time of the temporal resolve of the colour (after the composite).
    pub resolve: f64,
    pub wall: f64,
    /// Shadow rays traced this frame.
    pub shadow_rays: u64,
}

#[derive(Default)]
struct PhaseClock {
    primary: AtomicU64,
    u: AtomicU64,
    shadow: AtomicU64,
    composite: AtomicU64,
    shadow_rays: AtomicU64,
}

impl PhaseClock {
    fn add(slot: &AtomicU64, since: Instant) -> Instant {
        let now = Instant::now();
        slot.fetch_add((now - since).as_nanos() as u64, Ordering::Relaxed);
        now
    }
}

/// The buffers of a frame, one entry per pixel, row-major, row 0 at the top.
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub gbuf: Vec<GSample>,
    /// Analytic unshadowed light.
    pub u: Vec<Vec3>,
    /// Stochastic estimates of `U` and `S` from the same samples.
    pub un: Vec<Vec3>,
    pub sn: Vec<Vec3>,
    /// The frame's linear radiance.
    pub color: Vec<Vec3>,
    /// The denoiser's guides, in the layout it reads (filled by the band pass).
    guide: Guides,
    denoiser: Denoiser,
    resolve: Resolve,
    /// What the resolve averages this frame (see `resolve_colour`).
    resolve_in: Vec<Vec3>,
    /// `reference`: running sum of samples, and how many per pixel.
    accum: Vec<Vec3>,
    accum_spp: u32,
    prev_camera: Option<Camera>,
    /// The previous frame's lights: a frame whose lights differ (a light
    /// moved or was edited) drops every history at once.
    prev_lights: Vec<Light>,
    /// Frames rendered so far; decorrelates samples across frames.
    pub frame_index: u32,
    /// Sub-pixel offset of the last frame's camera rays ((0.5, 0.5): none).
    pub jitter: Vec2,
    /// Frames since the history was last dropped: the jitter's index, so
    /// every history starts at the pixel centre and its first 2^m frames
    /// are a (0,m,2)-net over the pixel.
    jitter_index: u32,
}

impl Frame {
    pub fn new(width: u32, height: u32) -> Frame {
        let n = width as usize * height as usize;
        Frame {
            width,
            height,
            gbuf: vec![GSample::default(); n],
            u: vec![Vec3::ZERO; n],
            un: vec![Vec3::ZERO; n],
            sn: vec![Vec3::ZERO; n],
            color: vec![Vec3::ZERO; n],
            guide: Guides::new(n),
            denoiser: Denoiser::new(width, height),
            resolve: Resolve::new(width, height),
            resolve_in: vec![Vec3::ZERO; n],
            accum: Vec::new(),
            accum_spp: 0,
            prev_camera: None,
            prev_lights: Vec::new(),
            frame_index: 0,
            jitter: Vec2::splat(0.5),
            jitter_index: 0,
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Forgets history: the next frame starts accumulation afresh.
    pub fn reset_history(&mut self) {
        self.denoiser.reset();
        self.resolve.reset();
        self.jitter_index = 0;
        self.accum.clear();
        self.accum_spp = 0;
        self.prev_camera = None;
    }

    /// Renders one frame of `camera` into the buffers. Must run inside the
    /// rayon pool that should do the work.
    pub fn render(
        &mut self,
        world: &World,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> PhaseTimes {
        let start = Instant::now();
        let cam = camera.frame(self.width, self.height);
        let prev = self
            .prev_camera
            .unwrap_or(*camera)
            .frame(self.width, self.height);
        if settings.mode == Mode::Reference && self.prev_camera.is_some_and(|c| c != *camera) {
            self.accum.clear();
            self.accum_spp = 0;
        }
        if world.scene.lights != self.prev_lights {
            if self.prev_camera.is_some() {
                self.reset_history();
            }
            self.prev_lights.clone_from(&world.scene.lights);
        }
        let clock = PhaseClock::default();
        let taa = settings.taa && settings.mode != Mode::Reference;
        let motion = if self.prev_camera == Some(*camera) {
            CameraMotion::Still
        } else {
            CameraMotion::Moved
        };
        let offset = if taa {
            PixelOffset::Frame(frame_jitter(self.jitter_index))
        } else {
            PixelOffset::Centre
        };
        let mut denoise = 0.0;
        match settings.mode {
            Mode::Reference => self.render_reference(world, &cam, settings, &clock),
            Mode::Unshadowed => {
                self.render_direct(world, (&cam, &prev), offset, settings, &clock, true)
            }
            _ if !settings.denoise => {
                self.render_direct(world, (&cam, &prev), offset, settings, &clock, true)
            }
            _ => {
                self.render_direct(world, (&cam, &prev), offset, settings, &clock, false);
                let t = Instant::now();
                // Under a still, jittered camera `U` changes between frames
                // only through the jitter: the per-pixel light test would
                // drop history all over glossy, normal-mapped surfaces (a
                // light change resets the whole history above instead).
                self.denoise(!taa || motion == CameraMotion::Moved);
                denoise = t.elapsed().as_secs_f64();
                let t = Instant::now();
                self.composite(settings.mode);
                PhaseClock::add(&clock.composite, t);
            }
        }
        let mut resolve = 0.0;
        if taa {
            let t = Instant::now();
            self.resolve_colour(Split::of(settings), motion);
            resolve = t.elapsed().as_secs_f64();
        }
        self.jitter = match offset {
            PixelOffset::Frame(o) => o,
            _ => Vec2::splat(0.5),
        };
        self.prev_camera = Some(*camera);
        self.frame_index = self.frame_index.wrapping_add(1);
        self.jitter_index = self.jitter_index.wrapping_add(1);
        let secs = |a: &AtomicU64| a.load(Ordering::Relaxed) as f64 * 1e-9;
        PhaseTimes {
            primary: secs(&clock.primary),
            u: secs(&clock.u),
            shadow: secs(&clock.shadow),
            composite: secs(&clock.composite),
            denoise,
            resolve,
            wall: start.elapsed().as_secs_f64(),
            shadow_rays: clock.shadow_rays.load(Ordering::Relaxed),
        }
    }

    /// The band pass: primary rays, `U`, samples and shadow rays, and (when
    /// `composite`, i.e. nothing is denoised) the final colour.
    fn render_direct(
        &mut self,
        world: &World,
        (cam, prev): (&CameraFrame, &CameraFrame),
        offset: PixelOffset,
        settings: &RenderSettings,
        clock: &PhaseClock,
        composite: bool,
    ) {
        let estimator = match settings.mode {
            Mode::Ratio | Mode::Stochastic => Some(Estimator::Mis),
            Mode::SoftShadow => Some(Estimator::AreaVisibility),
            Mode::Unshadowed | Mode::Reference => None,
        };
        let split = Split::of(settings);
        let first_sample = self.frame_index.wrapping_mul(settings.spp);
        let job = BandJob {
            world,
            cam,
            prev,
            offset,
            estimator,
            first_sample,
            spp: settings.spp,
            seed: settings.seed,
            packet: settings.packet,
            clock,
        };
        self.bands()
            .into_par_iter()
            .for_each_init(BandScratch::default, |scratch, mut band| {
                let n = band.gbuf.len();
                let t = job.run(band.y0, scratch, band.gbuf, band.u, band.un, band.sn);
                // The guides serve the denoiser and the resolve alike; a frame
                // with neither (composited here, TAA off) needs none.
                if !composite || split != Split::None {
                    for (k, g) in band.gbuf.iter().enumerate() {
                        band.guide.set(k, g, scratch.spec_share[k]);
                    }
                }
                // The resolve's factor, while the band is in cache (an
                // undenoised frame's is its colour, filled below).
                match split {
                    Split::Modulated => {
                        for (k, g) in band.gbuf.iter().enumerate() {
                            band.resolve_in[k] = g.emission + band.u[k];
                        }
                    }
                    Split::Additive => {
                        for (k, g) in band.gbuf.iter().enumerate() {
                            band.resolve_in[k] = g.emission;
                        }
                    }
                    Split::Whole | Split::None => {}
                }
                if composite {
                    for k in 0..n {
                        band.color[k] = shade(
                            settings.mode,
                            &band.gbuf[k],
                            band.u[k],
                            band.un[k],
                            band.sn[k],
                        );
                    }
                    if split == Split::Whole {
                        band.resolve_in.copy_from_slice(band.color);
                    }
                } else {
                    if settings.mode == Mode::Stochastic {
                        // The full Monte Carlo signal is filtered as `S_N` over the
                        // noise-free `U`: its whole noise, not only visibility's,
                        // then drives the filter (a fair "option 2").
                        band.un.copy_from_slice(band.u);
                    }
                }
                PhaseClock::add(&clock.composite, t);
            });
    }

    /// Splits every per-pixel buffer into the same bands of rows.
    fn bands(&mut self) -> Vec<BandMut<'_>> {
        let n = (BAND_ROWS * self.width) as usize;
        let g = &mut self.guide;
        let mut guides = g
            .position
            .chunks_mut(n)
            .zip(g.normal.chunks_mut(n))
            .zip(g.depth.chunks_mut(n))
            .zip(g.prev_pixel.chunks_mut(n))
            .zip(g.prev_valid.chunks_mut(n))
            .zip(g.lobe.chunks_mut(n))
            .map(
                |(((((position, normal), depth), prev_pixel), prev_valid), lobe)| GuideMut {
                    position,
                    normal,
                    depth,
                    prev_pixel,
                    prev_valid,
                    lobe,
                },
            );
        self.gbuf
            .chunks_mut(n)
            .zip(self.u.chunks_mut(n))
            .zip(self.un.chunks_mut(n))
            .zip(self.sn.chunks_mut(n))
            .zip(self.color.chunks_mut(n))
            .zip(self.resolve_in.chunks_mut(n))
            .enumerate()
            .map(
                |(b, (((((gbuf, u), un), sn), color), resolve_in))| BandMut {
                    y0: b as u32 * BAND_ROWS,
                    gbuf,
                    u,
                    un,
                    sn,
                    color,
                    resolve_in,
                    guide: guides.next().expect("guides have the same bands"),
                },
            )
            .collect()
    }

    fn denoise(&mut self, light_test: bool) {
        let guide = self.guide.buffers(self.width, self.height, &self.u);
        self.denoiser.denoise(
            &guide,
            &mut self.un,
            &mut self.sn,
            &DenoiseSettings {
                light_test,
                ..DenoiseSettings::default()
            },
        );
    }

    /// The temporal resolve (see `denoise::resolve`): averages over the
    /// jittered frames what no earlier stage has averaged. The denoiser's
    /// temporal history already averages `U_N` and `S_N` over the same
    /// jittered frames, so a denoised colour `U · dn(S_N) / dn(U_N)` is
    /// resolved as `resolve(U) · dn(S_N) / dn(U_N)`, and denoised
    /// `stochastic` as `resolve(emission) + dn(S_N)`: averaging the denoised
    /// colour again would weight the early frames' samples up to 20x more
    /// than the late ones' (a running mean of running means). Where the
    /// jitter (or the motion) crossed a geometric edge, the resolved `U`
    /// mixes surfaces that this frame's ratio does not describe, and the
    /// resolved colour is taken instead; an undenoised frame is resolved
    /// whole. The frame's composite is computed as before: this stage only
    /// averages it, or its per-frame noise-free factor, over frames.
    fn resolve_colour(&mut self, split: Split, motion: CameraMotion) {
        let guide = self.guide.buffers(self.width, self.height, &self.u);
        self.resolve.resolve(
            &guide,
            (&mut self.resolve_in, &mut self.color),
            motion,
            &ResolveSettings::default(),
            &DenoiseSettings::default(),
        );
        if matches!(split, Split::Whole | Split::None) {
            return;
        }
        self.color
            .par_iter_mut()
            .zip(&self.guide.depth)
            .zip(&self.resolve_in)
            .zip(self.resolve.mixed())
            .zip(self.un.par_iter().zip(&self.sn))
            .for_each(|((((c, &depth), b), &mixed), (un, sn))| {
                if mixed {
                    return;
                }
                // Surfaces (depth > 0 in the guides) carry a ratio; lights
                // and misses are their emission alone.
                *c = match split {
                    Split::Modulated if depth > 0.0 => finite_or_zero(*b * ratio(*sn, *un)),
                    Split::Additive => finite_or_zero(*b + *sn),
                    _ => *b,
                }
            });
    }

    fn composite(&mut self, mode: Mode) {
        self.color
            .par_iter_mut()
            .zip(&self.gbuf)
            .zip(&self.u)
            .zip(&self.un)
            .zip(&self.sn)
            .for_each(|((((c, g), u), un), sn)| *c = shade(mode, g, *u, *un, *sn));
    }

    /// Adds `settings.spp` jittered samples of the full MIS estimator per
    /// pixel to the running average.
    fn render_reference(
        &mut self,
        world: &World,
        cam: &CameraFrame,
        settings: &RenderSettings,
        clock: &PhaseClock,
    ) {
        let n = self.pixel_count();
        if self.accum.len() != n {
            self.accum = vec![Vec3::ZERO; n];
            self.accum_spp = 0;
        }
        let band = (BAND_ROWS * self.width) as usize;
        let first = self.accum_spp;
        self.gbuf
            .par_chunks_mut(band)
            .zip(self.u.par_chunks_mut(band))
            .zip(self.un.par_chunks_mut(band))
            .zip(self.sn.par_chunks_mut(band))
            .zip(self.accum.par_chunks_mut(band))
            .enumerate()
            .for_each_init(
                BandScratch::default,
                |scratch, (b, ((((gbuf, u), un), sn), accum))| {
                    let y0 = b as u32 * BAND_ROWS;
                    for s in 0..settings.spp {
                        let index = first.wrapping_add(s);
                        let job = BandJob {
                            world,
                            cam,
                            // The reference never reprojects: the camera is its own previous camera.
                            prev: cam,
                            offset: PixelOffset::Jitter {
                                seed: settings.seed,
                                sample: index,
                            },
                            estimator: Some(Estimator::Mis),
                            first_sample: index,
                            spp: 1,
                            seed: settings.seed,
                            packet: settings.packet,
                            clock,
                        };
                        let t = job.run(y0, scratch, gbuf, u, un, sn);
                        for k in 0..gbuf.len() {
                            accum[k] += finite_or_zero(gbuf[k].emission + sn[k]);
                        }
                        PhaseClock::add(&clock.composite, t);
                    }
                },
            );
        self.accum_spp += settings.spp;
        let inv = 1.0 / self.accum_spp as f32;
        self.color
            .par_iter_mut()
            .zip(&self.accum)
            .for_each(|(c, a)| *c = *a * inv);
    }
}

/// How the temporal resolve sees a finished frame (see `resolve_colour`).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Split {
    /// Denoised ratio / soft-shadow: colour = (emission + U) · dn(S_N) / dn(U_N);
    /// the resolve averages emission + U.
    Modulated,
    /// Denoised stochastic: colour = emission + dn(S_N); the resolve
    /// averages the emission.
    Additive,
    /// Undenoised or unshadowed: the resolve averages the colour.
    Whole,
    /// No resolve (TAA off, or `reference`).
    None,
}

impl Split {
    fn of(settings: &RenderSettings) -> Split {
        if !settings.taa {
            return Split::None;
        }
        match (settings.mode, settings.denoise) {
            (Mode::Reference, _) => Split::None,
            (Mode::Ratio | Mode::SoftShadow, true) => Split::Modulated,
            (Mode::Stochastic, true) => Split::Additive,
            _ => Split::Whole,
        }
    }
}

/// A pixel's colour from its estimates.
#[inline]
fn shade(mode: Mode, g: &GSample, u: Vec3, un: Vec3, sn: Vec3) -> Vec3 {
    let lit = match mode {
        Mode::Unshadowed | Mode::Reference => u,
        Mode::Ratio | Mode::SoftShadow => u * ratio(sn, un),
        Mode::Stochastic => sn,
    };
    finite_or_zero(g.emission + lit)
}

/// The denoiser's per-pixel guides as separate arrays.
struct Guides {
    position: Vec<Vec3>,
    normal: Vec<Vec3>,
    depth: Vec<f32>,
    prev_pixel: Vec<Vec2>,
    prev_valid: Vec<bool>,
    lobe: Vec<Lobe>,
}

impl Guides {
    fn new(n: usize) -> Guides {
        Guides {
            position: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
            depth: vec![0.0; n],
            prev_pixel: vec![Vec2::ZERO; n],
            prev_valid: vec![false; n],
            lobe: vec![Lobe::default(); n],
        }
    }

    /// What the denoiser and the resolve read: these guides and the frame's `U`.
    fn buffers<'a>(&'a self, width: u32, height: u32, u: &'a [Vec3]) -> GuideBuffers<'a> {
        GuideBuffers {
            width,
            height,
            position: &self.position,
            normal: &self.normal,
            depth: &self.depth,
            prev_pixel: &self.prev_pixel,
            prev_valid: &self.prev_valid,
            u,
            lobe: &self.lobe,
        }
    }
}

struct GuideMut<'a> {
    position: &'a mut [Vec3],
    normal: &'a mut [Vec3],
    depth: &'a mut [f32],
    prev_pixel: &'a mut [Vec2],
    prev_valid: &'a mut [bool],
    lobe: &'a mut [Lobe],
}

impl GuideMut<'_> {
    /// Only receiver surfaces are denoised; lights and misses pass through.
    #[inline]
    fn set(&mut self, k: usize, g: &GSample, spec_share: f32) {
        let surface = g.kind == PixelKind::Surface;
        self.position[k] = g.position;
        self.normal[k] = if surface { g.ng } else { Vec3::ZERO };
        self.depth[k] = if surface { g.depth } else { 0.0 };
        self.prev_pixel[k] = g.prev_pixel;
        self.prev_valid[k] = g.prev_valid;
        self.lobe[k] = if surface {
            Lobe::new(g.ng, g.wo, alpha_from_roughness(g.roughness), spec_share)
        } else {
            Lobe::default()
        };
    }
}

/// One band of rows of every per-pixel buffer.
struct BandMut<'a> {
    y0: u32,
    gbuf: &'a mut [GSample],
    u: &'a mut [Vec3],
    un: &'a mut [Vec3],
    sn: &'a mut [Vec3],
    color: &'a mut [Vec3],
    /// The resolve's noise-free factor (see `Split`).
    resolve_in: &'a mut [Vec3],
    guide: GuideMut<'a>,
}

/// The last line of defence of the no-NaN rule: a non-finite value becomes 0.
#[inline]
pub fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() { v } else { Vec3::ZERO }
}

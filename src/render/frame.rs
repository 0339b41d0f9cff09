//! One frame: trace the G-buffer, evaluate U and the stochastic estimates
//! per band of rows over rayon, then composite. Frame state that outlives a
//! frame (previous camera, reference accumulation) lives here too.

use super::estimate::{Estimator, analytic_u, draw_samples, ratio};
use super::shadow::{PacketWidth, ShadowBatch};
use super::gbuffer::{GSample, PixelKind};
use super::mode::Mode;
use super::primary::{PACKET_H, PixelOffset, trace_rows};
use super::world::World;
use crate::scene::{Camera, CameraFrame};
use glam::Vec3;
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
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: Mode::Ratio,
            spp: 1,
            seed: 0,
            packet: PacketWidth::Sixteen,
        }
    }
}

/// Per-thread working memory, reused across bands.
#[derive(Default)]
struct BandScratch {
    /// Analytic `U` of each light at each pixel of the band.
    per_light: Vec<Vec3>,
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
    pub wall: f64,
}

#[derive(Default)]
struct PhaseClock {
    primary: AtomicU64,
    u: AtomicU64,
    shadow: AtomicU64,
    composite: AtomicU64,
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
    /// `reference`: running sum of samples, and how many per pixel.
    accum: Vec<Vec3>,
    accum_spp: u32,
    prev_camera: Option<Camera>,
    /// Frames rendered so far; decorrelates samples across frames.
    pub frame_index: u32,
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
            accum: Vec::new(),
            accum_spp: 0,
            prev_camera: None,
            frame_index: 0,
        }
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Forgets history: the next frame starts accumulation afresh.
    pub fn reset_history(&mut self) {
        self.accum.clear();
        self.accum_spp = 0;
        self.prev_camera = None;
    }

    /// Samples per pixel accumulated by `reference` so far.
    pub fn accumulated_spp(&self) -> u32 {
        self.accum_spp
    }

    /// Renders one frame of `camera` into the buffers. Must run inside the
    /// rayon pool that should do the work.
    pub fn render(&mut self, world: &World, camera: &Camera, settings: &RenderSettings) -> PhaseTimes {
        let start = Instant::now();
        let cam = camera.frame(self.width, self.height);
        let prev = self.prev_camera.unwrap_or(*camera).frame(self.width, self.height);
        if settings.mode == Mode::Reference && self.prev_camera.is_some_and(|c| c != *camera) {
            self.accum.clear();
            self.accum_spp = 0;
        }
        let clock = PhaseClock::default();
        match settings.mode {
            Mode::Reference => self.render_reference(world, &cam, settings, &clock),
            _ => self.render_direct(world, &cam, &prev, settings, &clock),
        }
        self.prev_camera = Some(*camera);
        self.frame_index = self.frame_index.wrapping_add(1);
        let secs = |a: &AtomicU64| a.load(Ordering::Relaxed) as f64 * 1e-9;
        PhaseTimes {
            primary: secs(&clock.primary),
            u: secs(&clock.u),
            shadow: secs(&clock.shadow),
            composite: secs(&clock.composite),
            wall: start.elapsed().as_secs_f64(),
        }
    }

    fn render_direct(&mut self, world: &World, cam: &CameraFrame, prev: &CameraFrame, settings: &RenderSettings, clock: &PhaseClock) {
        let band = (BAND_ROWS * self.width) as usize;
        let width = self.width;
        let lights = world.scene.lights.len();
        let estimator = match settings.mode {
            Mode::Ratio | Mode::Stochastic => Some(Estimator::Mis),
            Mode::SoftShadow => Some(Estimator::AreaVisibility),
            Mode::Unshadowed | Mode::Reference => None,
        };
        let first_sample = self.frame_index.wrapping_mul(settings.spp);
        self.gbuf
            .par_chunks_mut(band)
            .zip(self.u.par_chunks_mut(band))
            .zip(self.un.par_chunks_mut(band))
            .zip(self.sn.par_chunks_mut(band))
            .zip(self.color.par_chunks_mut(band))
            .enumerate()
            .for_each_init(BandScratch::default, |scratch, (b, ((((gbuf, u), un), sn), color))| {
                let y0 = b as u32 * BAND_ROWS;
                let t = Instant::now();
                trace_rows(world, cam, prev, y0, PixelOffset::Centre, gbuf);
                let t = PhaseClock::add(&clock.primary, t);
                scratch.per_light.resize(gbuf.len() * lights, Vec3::ZERO);
                for (k, (g, u)) in gbuf.iter().zip(u.iter_mut()).enumerate() {
                    *u = analytic_u(world, g, &mut scratch.per_light[k * lights..(k + 1) * lights]);
                }
                let t = PhaseClock::add(&clock.u, t);
                un.fill(Vec3::ZERO);
                sn.fill(Vec3::ZERO);
                let t = if let Some(est) = estimator {
                    scratch.batch.clear();
                    for (k, g) in gbuf.iter().enumerate() {
                        let pixel = y0 * width + k as u32;
                        draw_samples(
                            world,
                            g,
                            &scratch.per_light[k * lights..(k + 1) * lights],
                            u[k],
                            est,
                            (pixel, first_sample, settings.seed),
                            settings.spp,
                            k as u32,
                            &mut un[k],
                            &mut scratch.batch,
                        );
                    }
                    scratch.batch.trace(&world.rt, settings.packet, |r| sn[r.slot as usize] += r.weight);
                    PhaseClock::add(&clock.shadow, t)
                } else {
                    t
                };
                for k in 0..gbuf.len() {
                    let lit = match settings.mode {
                        Mode::Unshadowed | Mode::Reference => u[k],
                        Mode::Ratio | Mode::SoftShadow => u[k] * ratio(sn[k], un[k]),
                        Mode::Stochastic => sn[k],
                    };
                    color[k] = finite_or_zero(gbuf[k].emission + lit);
                }
                PhaseClock::add(&clock.composite, t);
            });
    }

    /// Adds `settings.spp` jittered samples of the full MIS estimator per
    /// pixel to the running average.
    fn render_reference(&mut self, world: &World, cam: &CameraFrame, settings: &RenderSettings, clock: &PhaseClock) {
        let n = self.pixel_count();
        if self.accum.len() != n {
            self.accum = vec![Vec3::ZERO; n];
            self.accum_spp = 0;
        }
        let band = (BAND_ROWS * self.width) as usize;
        let width = self.width;
        let lights = world.scene.lights.len();
        let first = self.accum_spp;
        self.gbuf
            .par_chunks_mut(band)
            .zip(self.u.par_chunks_mut(band))
            .zip(self.un.par_chunks_mut(band))
            .zip(self.sn.par_chunks_mut(band))
            .zip(self.accum.par_chunks_mut(band))
            .enumerate()
            .for_each_init(BandScratch::default, |scratch, (b, ((((gbuf, u), un), sn), accum))| {
                let y0 = b as u32 * BAND_ROWS;
                scratch.per_light.resize(gbuf.len() * lights, Vec3::ZERO);
                for s in 0..settings.spp {
                    let index = first.wrapping_add(s);
                    let t = Instant::now();
                    let jitter = PixelOffset::Jitter { seed: settings.seed, sample: index };
                    // The reference never reprojects: the camera is its own previous camera.
                    trace_rows(world, cam, cam, y0, jitter, gbuf);
                    let t = PhaseClock::add(&clock.primary, t);
                    for (k, (g, u)) in gbuf.iter().zip(u.iter_mut()).enumerate() {
                        *u = analytic_u(world, g, &mut scratch.per_light[k * lights..(k + 1) * lights]);
                    }
                    let t = PhaseClock::add(&clock.u, t);
                    un.fill(Vec3::ZERO);
                    sn.fill(Vec3::ZERO);
                    scratch.batch.clear();
                    for (k, g) in gbuf.iter().enumerate() {
                        let pixel = y0 * width + k as u32;
                        draw_samples(
                            world,
                            g,
                            &scratch.per_light[k * lights..(k + 1) * lights],
                            u[k],
                            Estimator::Mis,
                            (pixel, index, settings.seed),
                            1,
                            k as u32,
                            &mut un[k],
                            &mut scratch.batch,
                        );
                    }
                    scratch.batch.trace(&world.rt, settings.packet, |r| sn[r.slot as usize] += r.weight);
                    let t = PhaseClock::add(&clock.shadow, t);
                    for k in 0..gbuf.len() {
                        accum[k] += finite_or_zero(gbuf[k].emission + sn[k]);
                    }
                    PhaseClock::add(&clock.composite, t);
                }
            });
        self.accum_spp += settings.spp;
        let inv = 1.0 / self.accum_spp as f32;
        self.color.par_iter_mut().zip(&self.accum).for_each(|(c, a)| *c = *a * inv);
    }

    /// Whether pixel `k` shows a receiver surface.
    pub fn is_surface(&self, k: usize) -> bool {
        self.gbuf[k].kind == PixelKind::Surface
    }
}

/// The last line of defence of the no-NaN rule: a non-finite value becomes 0.
#[inline]
pub fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() { v } else { Vec3::ZERO }
}

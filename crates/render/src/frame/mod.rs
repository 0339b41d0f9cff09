//! One frame, run as the stages its [`FramePlan`] names: the band pass
//! (primary rays, `U`, samples and shadow rays per band of rows over
//! rayon), the denoiser, upsampling of reduced-rate visibility, the
//! composite and the temporal resolve. State that outlives a frame
//! (histories, previous camera, reference accumulation) lives here too.
//!
//! One file a stage: `pass` (the band pass over the frame) and `band` (one
//! band's primary rays, `U`, samples and shadow rays), `quarter` (visibility at a quarter of the pixels and
//! its upsampling), `composite` (the colour and its temporal resolve),
//! `reference` (the converged estimate); `clock` holds what a frame
//! measured of itself.

mod band;
mod clock;
mod composite;
mod pass;
mod quarter;
mod reference;

pub use band::BAND_ROWS;
pub use clock::PhaseTimes;
pub use composite::finite_or_zero;

use self::clock::PhaseClock;

use crate::gbuffer::GSample;
use crate::guides::Guides;
use crate::plan::FramePlan;
use crate::primary::PixelOffset;
use crate::quads::Quads;
use crate::settings::RenderSettings;
use crate::settings::VisibilityRate;
use crate::solo::SoloHistory;
use crate::world::World;
use glam::{Vec2, Vec3};
use penumbra_denoise::{CameraMotion, DenoiseSettings, Denoiser, GuideBuffers, Resolve};
use penumbra_kernels::sampling::sequence::frame_jitter;
use penumbra_scene::{Camera, Light};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// The buffers of a frame, one entry per pixel, row-major, row 0 at the top.
pub struct Frame {
    pub width: u32,
    pub height: u32,
    pub gbuf: Vec<GSample>,
    /// Analytic unshadowed light.
    pub u: Vec<Vec3>,
    /// Stochastic estimates of `U` and `S` from the same samples (denoised,
    /// and at a reduced visibility rate brought to every pixel, when the
    /// plan says so).
    pub un: Vec<Vec3>,
    pub sn: Vec<Vec3>,
    /// The frame's linear radiance.
    pub color: Vec<Vec3>,
    /// The denoiser's and the resolve's guides (filled by the band pass).
    guide: Guides,
    /// Quad-resolution visibility (allocated on the first reduced-rate frame).
    quads: Option<Quads>,
    /// Surface pixels that sampled themselves this frame (see `quads`,
    /// `solo`), and their samples' history.
    orphans: Vec<u32>,
    solo: Option<SoloHistory>,
    denoiser: Denoiser,
    /// The rate the denoiser's history was built at.
    history_rate: Option<VisibilityRate>,
    resolve: Resolve,
    /// The denoiser's history and the resolve's hold the same frame (the
    /// last one ran both at the frame's own size, and nothing was dropped
    /// since): a moving camera's resolve reuses the denoiser's taps.
    shared_taps: bool,
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
            guide: Guides::new(width, height),
            quads: None,
            orphans: Vec::new(),
            solo: None,
            denoiser: Denoiser::new(width, height),
            history_rate: None,
            resolve: Resolve::new(width, height),
            shared_taps: false,
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

    /// The guides of the last frame (positions, normals, depths, motion)
    /// and its `U`.
    pub fn guides(&self) -> GuideBuffers<'_> {
        self.guide.buffers(&self.u)
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Surface pixels that drew their own samples in the last reduced-rate
    /// frame: no quad around them sampled their surface, or their lobe is
    /// too narrow for a neighbour's samples to stand in for theirs.
    pub fn orphan_count(&self) -> usize {
        self.orphans.len()
    }

    /// Whether surface pixel `k` drew its own samples in the last
    /// reduced-rate frame (see `orphan_count`).
    pub fn sampled_itself(&self, k: usize) -> bool {
        self.orphans.binary_search(&(k as u32)).is_ok()
    }

    /// Forgets history: the next frame starts accumulation afresh.
    pub fn reset_history(&mut self) {
        self.denoiser.reset();
        if let Some(s) = self.solo.as_mut() {
            s.reset();
        }
        self.resolve.reset();
        self.shared_taps = false;
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
        let plan = FramePlan::of(settings);
        let cam = camera.frame(self.width, self.height);
        let prev = self
            .prev_camera
            .unwrap_or(*camera)
            .frame(self.width, self.height);
        if plan.reference && self.prev_camera.is_some_and(|c| c != *camera) {
            self.accum.clear();
            self.accum_spp = 0;
        }
        if world.lights.declared() != self.prev_lights {
            if self.prev_camera.is_some() {
                self.reset_history();
            }
            self.prev_lights = world.lights.declared().to_vec();
        }
        if plan.denoise && self.history_rate != Some(plan.rate) {
            // A history built at another rate describes other pixels.
            self.denoiser.reset();
            if let Some(s) = self.solo.as_mut() {
                s.reset();
            }
            self.history_rate = Some(plan.rate);
        }
        let clock = PhaseClock::default();
        let motion = if self.prev_camera == Some(*camera) {
            CameraMotion::Still
        } else {
            CameraMotion::Moved
        };
        let offset = if plan.jitter {
            PixelOffset::Frame(frame_jitter(self.jitter_index))
        } else {
            PixelOffset::Centre
        };
        // The denoiser at the frame's own size, then the resolve: both
        // reproject onto the same previous frame.
        let both = plan.denoise && plan.rate != VisibilityRate::Quarter && plan.resolve.is_some();
        let reuse_taps = both && self.shared_taps && motion == CameraMotion::Moved;
        self.denoiser.keep_taps(reuse_taps);
        let (mut denoise, mut upsample) = (0.0, 0.0);
        if plan.reference {
            self.render_reference(world, &cam, settings, &clock);
        } else {
            let unsampled = self.settled_tiles(&plan, motion);
            self.band_pass(
                world,
                (&cam, &prev),
                offset,
                settings,
                &plan,
                &unsampled,
                &clock,
            );
            if plan.denoise {
                let t = Instant::now();
                // Under a still, jittered camera `U` changes between frames
                // only through the jitter: the per-pixel light test would
                // drop history all over glossy, normal-mapped surfaces (a
                // light change resets the whole history above instead).
                self.denoise(
                    plan.rate,
                    !plan.jitter || motion == CameraMotion::Moved,
                    &unsampled,
                );
                denoise = t.elapsed().as_secs_f64();
                if plan.rate == VisibilityRate::Quarter {
                    let t = Instant::now();
                    self.upsample(world, (&cam, &prev), offset, settings, &plan, &clock);
                    upsample = t.elapsed().as_secs_f64();
                }
                let t = Instant::now();
                self.composite(plan.composite);
                PhaseClock::add(&clock.composite, t);
            }
        }
        let mut resolve = 0.0;
        if let Some(input) = plan.resolve {
            let t = Instant::now();
            self.resolve_colour(input, motion, reuse_taps);
            resolve = t.elapsed().as_secs_f64();
        }
        self.jitter = match offset {
            PixelOffset::Frame(o) => o,
            _ => Vec2::splat(0.5),
        };
        self.shared_taps = both;
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
            upsample,
            wall: start.elapsed().as_secs_f64(),
            shadow_rays: clock.shadow_rays.load(Ordering::Relaxed),
            u_pairs: clock.u_pairs.each_ref().map(|c| c.load(Ordering::Relaxed)),
        }
    }

    /// The index of this frame's first sample of a pixel: frames that
    /// sample a pixel take consecutive indices of its sequence.
    fn first_sample(&self, rate: VisibilityRate, spp: u32) -> u32 {
        match rate {
            VisibilityRate::Full => self.frame_index.wrapping_mul(spp),
            VisibilityRate::Quarter => (self.frame_index / 4).wrapping_mul(spp),
        }
    }

    /// The tiles that draw no samples this frame: under a still camera,
    /// those the denoiser found settled (exactly lit or in umbra, with a
    /// long history), less the ones whose turn it is to refresh: each
    /// settled tile draws again one frame in `REFRESH_PERIOD`, at a phase
    /// of its own, so a change the history missed is seen within that
    /// many frames. Per tile its class, 0 where samples are drawn.
    fn settled_tiles(&self, plan: &FramePlan, motion: CameraMotion) -> Vec<u8> {
        if !plan.settle || motion != CameraMotion::Still {
            return Vec::new();
        }
        let mut tiles = self.denoiser.settled_tiles(SETTLED_HISTORY);
        for (t, class) in tiles.iter_mut().enumerate() {
            let phase = (t as u32).wrapping_mul(0x9E37_79B9) >> 28;
            if self
                .frame_index
                .wrapping_add(phase)
                .is_multiple_of(REFRESH_PERIOD)
            {
                *class = 0;
            }
        }
        tiles
    }

    fn denoise(&mut self, rate: VisibilityRate, light_test: bool, unsampled: &[u8]) {
        let settings = DenoiseSettings {
            light_test,
            ..DenoiseSettings::default()
        };
        match (rate, self.quads.as_mut()) {
            (VisibilityRate::Quarter, Some(q)) => {
                let guide = q.guide.buffers(&q.u);
                self.denoiser
                    .denoise(&guide, &mut q.un, &mut q.sn, &settings);
            }
            _ => {
                let guide = self.guide.buffers(&self.u);
                self.denoiser.denoise_sparse(
                    &guide,
                    &mut self.un,
                    &mut self.sn,
                    unsampled,
                    &settings,
                );
            }
        }
    }
}

/// Frames of history every pixel of a tile needs before the tile may draw
/// no samples, and how often a settled tile draws them again.
const SETTLED_HISTORY: f32 = 8.0;
const REFRESH_PERIOD: u32 = 8;

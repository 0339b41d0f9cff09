//! One frame, run as the stages its [`FramePlan`] names: the band pass
//! (primary rays, `U`, samples and shadow rays per band of rows over
//! rayon), the denoiser, upsampling of reduced-rate visibility, the
//! composite and the temporal resolve. State that outlives a frame
//! (histories, previous camera, reference accumulation) lives here too.

use super::estimate::{
    Estimator, SampleSink, SampleStream, UCounts, analytic_u_band, draw_samples, ratio,
};
use super::gbuffer::GSample;
use super::guides::{GuideMut, Guides};
use super::plan::{Composite, FramePlan, ResolveInput, VisibilityRate};
use super::primary::{PACKET_H, PixelOffset, trace_rows};
use super::quads::{self, FullRes, QUAD_ORDER, Quads};
use super::shadow::{PacketWidth, ShadowBatch};
use super::solo::SoloHistory;
use super::world::World;
use crate::denoise::{
    CameraMotion, DenoiseSettings, Denoiser, GuideBuffers, Resolve, ResolveSettings, TILE,
    luminance,
};
use crate::sampling::sequence::frame_jitter;
use crate::scene::{Camera, CameraFrame, Light};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Rows per parallel work item: two packet rows, so a band's G-buffer stays
/// in cache between the passes that read it. Even, so no quad straddles two
/// bands.
pub const BAND_ROWS: u32 = 2 * PACKET_H;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    pub mode: super::mode::Mode,
    /// Light samples per sampled pixel per frame (`reference`: per call).
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
    /// Which pixels draw visibility samples each frame (denoised ratio and
    /// soft-shadow; every other plan samples every pixel).
    pub visibility: VisibilityRate,
    /// Under a still camera, tiles whose visibility has settled (exactly
    /// lit or in umbra, with a long history) draw no samples, but for a
    /// periodic refresh (denoised, full rate).
    pub settle: bool,
    /// The `U` stage's light culling: every surface pixel's `U` is at
    /// least `1 - light_tolerance` of the sum over every light
    /// (`analytic_u_band`); 0 evaluates every light at every pixel.
    pub light_tolerance: f32,
    /// The frame is rendered below its output's size and resolved there
    /// (`render::upscaled`): its camera rays are jittered as under `taa`,
    /// but its own temporal resolve is left out.
    pub upscaled: bool,
}

/// The shipped light culling tolerance: a fiftieth of `U`, well inside
/// the LTC fit's own error (docs/accuracy.md).
pub const LIGHT_TOLERANCE: f32 = 0.02;

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: super::mode::Mode::Ratio,
            spp: 1,
            seed: 0,
            packet: PacketWidth::Sixteen,
            denoise: true,
            taa: true,
            visibility: VisibilityRate::default(),
            settle: true,
            light_tolerance: LIGHT_TOLERANCE,
            upscaled: false,
        }
    }
}

/// What a band pass computes: where its camera rays go and which samples
/// it draws. The same steps serve every plan, the reference included.
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
    light_tolerance: f32,
    clock: &'a PhaseClock,
}

impl BandJob<'_, '_> {
    /// The samples pixel `pixel` draws this frame.
    fn stream(&self, pixel: u32) -> SampleStream {
        SampleStream {
            pixel,
            first: self.first_sample,
            count: self.spp,
            seed: self.seed,
        }
    }

    /// Primary rays and `U` per light for the band starting at row `y0`.
    /// Returns the time it finished, for the next stage's clock.
    fn primary_and_u(
        &self,
        y0: u32,
        scratch: &mut BandScratch,
        gbuf: &mut [GSample],
        u: &mut [Vec3],
    ) -> Instant {
        let (world, clock) = (self.world, self.clock);
        let t = Instant::now();
        trace_rows(world, self.cam, self.prev, y0, self.offset, gbuf);
        let t = PhaseClock::add(&clock.primary, t);
        let lights = world.lights.len();
        scratch.per_light.resize(gbuf.len() * lights, Vec3::ZERO);
        scratch.spec_share.resize(gbuf.len(), 0.0);
        let counts = analytic_u_band(
            world,
            gbuf,
            self.cam.width as usize,
            self.light_tolerance,
            &mut scratch.per_light,
            u,
            &mut scratch.spec_share,
        );
        clock.count_u(&counts);
        PhaseClock::add(&clock.u, t)
    }

    /// Samples and shadow rays of the band's pixels `pixels`, pairs of an
    /// index into the band (whose first row is `y0`) and the slot `m` its
    /// samples add to: `un[m]` and, when unoccluded, `sn[m]`.
    #[allow(clippy::too_many_arguments)]
    fn samples(
        &self,
        y0: u32,
        scratch: &mut BandScratch,
        gbuf: &[GSample],
        u: &[Vec3],
        pixels: impl Iterator<Item = (usize, usize)>,
        un: &mut [Vec3],
        sn: &mut [Vec3],
        since: Instant,
    ) -> Instant {
        un.fill(Vec3::ZERO);
        sn.fill(Vec3::ZERO);
        let Some(est) = self.estimator else {
            return since;
        };
        let world = self.world;
        let lights = world.lights.len();
        scratch.batch.clear();
        let width = self.cam.width;
        for (k, m) in pixels {
            draw_samples(
                world,
                &gbuf[k],
                &scratch.per_light[k * lights..(k + 1) * lights],
                u[k],
                est,
                self.stream(y0 * width + k as u32),
                &mut SampleSink {
                    un: &mut un[m],
                    batch: &mut scratch.batch,
                    slot: m as u32,
                    trace: None,
                },
            );
        }
        scratch
            .batch
            .trace(&world.rt, self.packet, |r| sn[r.slot as usize] += r.weight);
        self.clock
            .shadow_rays
            .fetch_add(scratch.batch.rays.len() as u64, Ordering::Relaxed);
        PhaseClock::add(&self.clock.shadow, since)
    }

    /// Primary rays, `U`, then samples at every pixel of the band.
    fn run(
        &self,
        y0: u32,
        scratch: &mut BandScratch,
        gbuf: &mut [GSample],
        u: &mut [Vec3],
        un: &mut [Vec3],
        sn: &mut [Vec3],
    ) -> Instant {
        let t = self.primary_and_u(y0, scratch, gbuf, u);
        let n = gbuf.len();
        self.samples(y0, scratch, gbuf, u, (0..n).map(|k| (k, k)), un, sn, t)
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
    /// Band pixels sampled this frame (reduced rate).
    sampled: Vec<usize>,
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
    /// Wall time of bringing reduced-rate visibility to every pixel,
    /// the samples of the pixels no quad vouched for included.
    pub upsample: f64,
    pub wall: f64,
    /// Shadow rays traced this frame.
    pub shadow_rays: u64,
    /// (surface pixel, light) pairs of the `U` stage: both lobes evaluated,
    /// the Lambert lobe only, culled (`analytic_u_band`).
    pub u_pairs: [u64; 3],
}

#[derive(Default)]
struct PhaseClock {
    primary: AtomicU64,
    u: AtomicU64,
    shadow: AtomicU64,
    composite: AtomicU64,
    shadow_rays: AtomicU64,
    u_pairs: [AtomicU64; 3],
}

impl PhaseClock {
    fn count_u(&self, c: &UCounts) {
        for (slot, n) in self.u_pairs.iter().zip([c.full, c.diffuse_only, c.culled]) {
            slot.fetch_add(n, Ordering::Relaxed);
        }
    }

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
            self.resolve_colour(input, motion);
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

    /// The band pass: primary rays, `U`, samples and shadow rays at the
    /// plan's rate, the guides, and (when nothing is denoised) the colour.
    #[allow(clippy::too_many_arguments)]
    fn band_pass(
        &mut self,
        world: &World,
        (cam, prev): (&CameraFrame, &CameraFrame),
        offset: PixelOffset,
        settings: &RenderSettings,
        plan: &FramePlan,
        unsampled: &[u8],
        clock: &PhaseClock,
    ) {
        let job = BandJob {
            world,
            cam,
            prev,
            offset,
            estimator: plan.estimator,
            first_sample: self.first_sample(plan.rate, settings.spp),
            spp: settings.spp,
            seed: settings.seed,
            packet: settings.packet,
            light_tolerance: settings.light_tolerance,
            clock,
        };
        let (width, height) = (self.width, self.height);
        let quarter = plan.rate == VisibilityRate::Quarter;
        if quarter
            && self
                .quads
                .as_ref()
                .is_none_or(|q| q.un.len() != quad_count(width, height))
        {
            self.quads = Some(Quads::new(width, height));
        }
        let quad_offset = QUAD_ORDER[(self.frame_index % 4) as usize];
        // Taken out while the bands borrow the frame's buffers.
        let mut quad_buffers = self.quads.take();
        if let Some(q) = quad_buffers.as_mut() {
            q.offset = quad_offset;
        }
        let mut quad_bands = quad_buffers
            .as_mut()
            .filter(|_| quarter)
            .map(|q| quad_bands(q).into_iter());
        let bands: Vec<(BandMut, Option<QuadBand>)> = self
            .bands()
            .into_iter()
            .map(|b| (b, quad_bands.as_mut().and_then(|q| q.next())))
            .collect();
        bands
            .into_par_iter()
            .for_each_init(BandScratch::default, |scratch, (mut band, quad)| {
                let n = band.gbuf.len();
                let mut t = job.primary_and_u(band.y0, scratch, band.gbuf, band.u);
                match quad {
                    Some(mut q) => {
                        t = sample_quads(&job, scratch, &mut band, &mut q, quad_offset, t);
                    }
                    None => {
                        let (w, row0) = (width as usize, band.y0 as usize);
                        let tiles_w = w.div_ceil(TILE);
                        // Settled tiles draw nothing this frame (`settled_tiles`).
                        let drawn = (0..n)
                            .filter(|&k| {
                                let (x, y) = (k % w, row0 + k / w);
                                unsampled.is_empty()
                                    || unsampled[(y / TILE) * tiles_w + x / TILE] == 0
                            })
                            .map(|k| (k, k));
                        t = job.samples(
                            band.y0, scratch, band.gbuf, band.u, drawn, band.un, band.sn, t,
                        );
                    }
                }
                if plan.needs_guides() {
                    for (k, g) in band.gbuf.iter().enumerate() {
                        band.guide.set(k, g, scratch.spec_share[k], g.prev_pixel);
                    }
                }
                // The resolve's factor, while the band is in cache (an
                // undenoised frame's is its colour, filled below).
                match plan.resolve {
                    Some(ResolveInput::Modulated) => {
                        for (k, g) in band.gbuf.iter().enumerate() {
                            band.resolve_in[k] = g.emission + band.u[k];
                        }
                    }
                    Some(ResolveInput::Additive) => {
                        for (k, g) in band.gbuf.iter().enumerate() {
                            band.resolve_in[k] = g.emission;
                        }
                    }
                    Some(ResolveInput::Whole) | None => {}
                }
                if !plan.denoise {
                    for k in 0..n {
                        band.color[k] = shade(
                            plan.composite,
                            &band.gbuf[k],
                            band.u[k],
                            band.un[k],
                            band.sn[k],
                        );
                    }
                    if plan.resolve == Some(ResolveInput::Whole) {
                        band.resolve_in.copy_from_slice(band.color);
                    }
                } else if plan.filter_against_u {
                    band.un.copy_from_slice(band.u);
                }
                PhaseClock::add(&clock.composite, t);
            });
        self.quads = quad_buffers;
    }

    /// Splits every per-pixel buffer into the same bands of rows.
    fn bands(&mut self) -> Vec<BandMut<'_>> {
        let n = (BAND_ROWS * self.width).max(1) as usize;
        let mut guides = self.guide.bands(BAND_ROWS);
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
                    width: self.width,
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

    /// Brings the denoised quad signals to every pixel; the pixels no quad
    /// vouched for, and the sharp-lobed ones, draw their own samples, which
    /// their own history averages over frames (`solo`).
    fn upsample(
        &mut self,
        world: &World,
        (cam, prev): (&CameraFrame, &CameraFrame),
        offset: PixelOffset,
        settings: &RenderSettings,
        plan: &FramePlan,
        clock: &PhaseClock,
    ) {
        let Some(q) = self.quads.as_ref() else {
            return;
        };
        let solo = self
            .solo
            .get_or_insert_with(|| SoloHistory::new(self.width, self.height));
        solo.begin_frame();
        let full = FullRes {
            width: self.width,
            height: self.height,
            gbuf: &self.gbuf,
            lobe: &self.guide.lobe,
        };
        quads::upsample(
            &full,
            q,
            &self.u,
            &mut self.un,
            &mut self.sn,
            &mut self.orphans,
        );
        if self.orphans.is_empty() {
            return;
        }
        let job = BandJob {
            world,
            cam,
            prev,
            offset,
            estimator: plan.estimator,
            first_sample: self.frame_index.wrapping_mul(settings.spp),
            spp: settings.spp,
            seed: settings.seed,
            packet: settings.packet,
            light_tolerance: settings.light_tolerance,
            clock,
        };
        let samples: Vec<(u32, Vec3, Vec3)> = self
            .orphans
            .par_chunks(ORPHAN_CHUNK)
            .flat_map_iter(|chunk| orphan_samples(&job, &self.gbuf, &self.u, chunk))
            .collect();
        if let Some(solo) = self.solo.as_mut() {
            for (k, un, sn) in samples {
                let k = k as usize;
                (self.un[k], self.sn[k]) = solo.accumulate(k, &self.gbuf[k], un, sn);
            }
        }
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
    fn resolve_colour(&mut self, input: ResolveInput, motion: CameraMotion) {
        let guide = self.guide.buffers(&self.u);
        self.resolve.resolve(
            &guide,
            (&mut self.resolve_in, &mut self.color),
            motion,
            &ResolveSettings::default(),
            &DenoiseSettings::default(),
        );
        if input == ResolveInput::Whole {
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
                *c = match input {
                    ResolveInput::Modulated if depth > 0.0 => finite_or_zero(*b * ratio(*sn, *un)),
                    ResolveInput::Additive => finite_or_zero(*b + *sn),
                    _ => *b,
                }
            });
    }

    fn composite(&mut self, composite: Composite) {
        self.color
            .par_iter_mut()
            .zip(&self.gbuf)
            .zip(&self.u)
            .zip(&self.un)
            .zip(&self.sn)
            .for_each(|((((c, g), u), un), sn)| *c = shade(composite, g, *u, *un, *sn));
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
                            light_tolerance: settings.light_tolerance,
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

/// Frames of history every pixel of a tile needs before the tile may draw
/// no samples, and how often a settled tile draws them again.
const SETTLED_HISTORY: f32 = 8.0;
const REFRESH_PERIOD: u32 = 8;

/// Orphan pixels per parallel work item.
const ORPHAN_CHUNK: usize = 64;

fn quad_count(width: u32, height: u32) -> usize {
    width.div_ceil(2) as usize * height.div_ceil(2) as usize
}

/// The samples of the pixels that sample themselves at the reduced rate:
/// `U` per light (for the light choice), then the plan's estimator.
fn orphan_samples(
    job: &BandJob,
    gbuf: &[GSample],
    u: &[Vec3],
    chunk: &[u32],
) -> Vec<(u32, Vec3, Vec3)> {
    let Some(est) = job.estimator else {
        return Vec::new();
    };
    let world = job.world;
    // `U` per light (for the light choice) by the batched path the band
    // pass takes, so each pixel gets the values its band computed.
    let points: Vec<GSample> = chunk.iter().map(|&k| gbuf[k as usize]).collect();
    let lights = world.lights.len();
    let mut per_light = vec![Vec3::ZERO; points.len() * lights];
    let (mut total, mut share) = (vec![Vec3::ZERO; points.len()], vec![0.0; points.len()]);
    // One row: the tiles are runs of orphans, near in the frame.
    let counts = analytic_u_band(
        world,
        &points,
        points.len(),
        job.light_tolerance,
        &mut per_light,
        &mut total,
        &mut share,
    );
    job.clock.count_u(&counts);
    let mut batch = ShadowBatch::default();
    let mut out: Vec<(u32, Vec3, Vec3)> = Vec::with_capacity(chunk.len());
    for (m, (&k, g)) in chunk.iter().zip(&points).enumerate() {
        let mut un = Vec3::ZERO;
        draw_samples(
            world,
            g,
            &per_light[m * lights..(m + 1) * lights],
            u[k as usize],
            est,
            job.stream(k),
            &mut SampleSink {
                un: &mut un,
                batch: &mut batch,
                slot: m as u32,
                trace: None,
            },
        );
        out.push((k, un, Vec3::ZERO));
    }
    batch.trace(&world.rt, job.packet, |r| {
        out[r.slot as usize].2 += r.weight
    });
    job.clock
        .shadow_rays
        .fetch_add(batch.rays.len() as u64, Ordering::Relaxed);
    out
}

/// One band's rows of the quad buffers.
struct QuadBand<'a> {
    un: &'a mut [Vec3],
    sn: &'a mut [Vec3],
    u: &'a mut [Vec3],
    guide: GuideMut<'a>,
}

/// Splits the quad buffers into the bands of `Frame::bands` (half as many rows).
fn quad_bands(q: &mut Quads) -> Vec<QuadBand<'_>> {
    let rows = BAND_ROWS / 2;
    let n = (rows * q.width).max(1) as usize;
    let mut guides = q.guide.bands(rows);
    q.un.chunks_mut(n)
        .zip(q.sn.chunks_mut(n))
        .zip(q.u.chunks_mut(n))
        .map(|((un, sn), u)| QuadBand {
            un,
            sn,
            u,
            guide: guides.next().expect("guides have the same bands"),
        })
        .collect()
}

/// Samples one pixel of each quad of the band (the one at `offset`) into
/// the quad buffers, with the quads' guides from that pixel.
fn sample_quads(
    job: &BandJob,
    scratch: &mut BandScratch,
    band: &mut BandMut,
    q: &mut QuadBand,
    offset: (u32, u32),
    since: Instant,
) -> Instant {
    let (width, height) = (job.cam.width, job.cam.height);
    let qw = width.div_ceil(2);
    let qj0 = band.y0 / 2;
    let quads = q.un.len() as u32 / qw.max(1);
    let mut sampled = std::mem::take(&mut scratch.sampled);
    sampled.clear();
    for dj in 0..quads {
        for i in 0..qw {
            let (x, y) = quads::sampled_pixel(i, qj0 + dj, offset, width, height);
            let k = ((y - band.y0) * width + x) as usize;
            let m = (dj * qw + i) as usize;
            let g = &band.gbuf[k];
            q.u[m] = band.u[k];
            let prev = quads::quad_prev_pixel(g, x, y, i, qj0 + dj);
            q.guide.set(m, g, scratch.spec_share[k], prev);
            sampled.push(k);
        }
    }
    let t = job.samples(
        band.y0,
        scratch,
        band.gbuf,
        band.u,
        sampled.iter().enumerate().map(|(m, &k)| (k, m)),
        q.un,
        q.sn,
        since,
    );
    // A quad's history mixes the samples of its four pixels, whose `U` may
    // differ a hundredfold (the edge of a glossy highlight): scaled by
    // 1 / U, each pixel's samples estimate its visibility with one weight,
    // and the brightest pixel no longer decides the quad's ratio. One
    // factor for both signals keeps each pixel's own ratio as it was.
    for ((un, sn), u) in q.un.iter_mut().zip(q.sn.iter_mut()).zip(q.u.iter()) {
        let l = luminance(*u);
        if l > 1e-20 && l.is_finite() {
            let inv = 1.0 / l;
            *un *= inv;
            *sn *= inv;
        }
    }
    scratch.sampled = sampled;
    t
}

/// A pixel's colour from its estimates.
#[inline]
fn shade(composite: Composite, g: &GSample, u: Vec3, un: Vec3, sn: Vec3) -> Vec3 {
    let lit = match composite {
        Composite::Unshadowed => u,
        Composite::Ratio => u * ratio(sn, un),
        Composite::Stochastic => sn,
    };
    finite_or_zero(g.emission + lit)
}

/// One band of rows of every per-pixel buffer.
struct BandMut<'a> {
    y0: u32,
    #[allow(dead_code)]
    width: u32,
    gbuf: &'a mut [GSample],
    u: &'a mut [Vec3],
    un: &'a mut [Vec3],
    sn: &'a mut [Vec3],
    color: &'a mut [Vec3],
    /// The resolve's noise-free factor (see `ResolveInput`).
    resolve_in: &'a mut [Vec3],
    guide: GuideMut<'a>,
}

/// The last line of defence of the no-NaN rule: a non-finite value becomes 0.
#[inline]
pub fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() { v } else { Vec3::ZERO }
}

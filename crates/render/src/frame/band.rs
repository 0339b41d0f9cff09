//! The band pass: primary rays, `U`, samples and shadow rays for a band
//! of rows at a time, over rayon, each band's buffers kept in cache
//! between the steps that read them.

use super::clock::PhaseClock;
use crate::estimate::{
    BandDraw, Estimator, SampleScratch, SampleStream, analytic_u_band, draw_samples,
};
use crate::gbuffer::GSample;
use crate::guides::GuideMut;
use crate::plan::FramePlan;
use crate::primary::{PACKET_H, PixelOffset, trace_rows};
use crate::settings::RenderSettings;
use crate::shadow::{PacketWidth, ShadowBatch};
use crate::world::World;
use glam::Vec3;
use penumbra_scene::CameraFrame;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Rows per parallel work item: one packet row, so that a band's G-buffer
/// (about 0.7 MB at 1280 pixels a row) stays in a 2 MB second-level cache
/// between the passes that read it (docs/performance.md). Even, so no quad
/// straddles two bands.
pub const BAND_ROWS: u32 = PACKET_H;

/// What a band pass computes: where its camera rays go and which samples
/// it draws. The same steps serve every plan, the reference included.
#[derive(Clone, Copy)]
pub(super) struct BandJob<'a, 'd> {
    pub(super) world: &'a World<'d>,
    pub(super) cam: &'a CameraFrame,
    pub(super) prev: &'a CameraFrame,
    pub(super) offset: PixelOffset,
    /// `None`: no samples (`U` only).
    pub(super) estimator: Option<Estimator>,
    pub(super) first_sample: u32,
    pub(super) spp: u32,
    pub(super) seed: u32,
    pub(super) packet: PacketWidth,
    pub(super) light_tolerance: f32,
    pub(super) clock: &'a PhaseClock,
}

impl<'a, 'd> BandJob<'a, 'd> {
    /// The job of a frame's plan: its estimator and the settings' samples,
    /// from `first_sample` of each pixel's sequence.
    pub(super) fn planned(
        world: &'a World<'d>,
        (cam, prev): (&'a CameraFrame, &'a CameraFrame),
        offset: PixelOffset,
        (settings, plan): (&RenderSettings, &FramePlan),
        first_sample: u32,
        clock: &'a PhaseClock,
    ) -> Self {
        BandJob {
            world,
            cam,
            prev,
            offset,
            estimator: plan.estimator,
            first_sample,
            spp: settings.spp,
            seed: settings.seed,
            packet: settings.packet,
            light_tolerance: settings.light_tolerance,
            clock,
        }
    }

    /// The samples pixel `pixel` draws this frame.
    pub(super) fn stream(&self, pixel: u32) -> SampleStream {
        SampleStream {
            pixel,
            first: self.first_sample,
            count: self.spp,
            seed: self.seed,
        }
    }

    /// Primary rays and `U` per light for the band starting at row `y0`.
    /// Returns the time it finished, for the next stage's clock.
    pub(super) fn primary_and_u(
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
    pub(super) fn samples(
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
        scratch.batch.clear();
        scratch.drawn.clear();
        scratch.drawn.extend(pixels);
        draw_samples(
            world,
            &BandDraw {
                gbuf,
                per_light: &scratch.per_light,
                u,
                estimator: est,
                base: y0 * self.cam.width,
                first: self.first_sample,
                spp: self.spp,
                seed: self.seed,
            },
            &scratch.drawn,
            un,
            &mut scratch.batch,
            &mut scratch.samples,
        );
        scratch
            .batch
            .trace(&world.rt, self.packet, |r| sn[r.slot as usize] += r.weight);
        self.clock
            .shadow_rays
            .fetch_add(scratch.batch.rays.len() as u64, Ordering::Relaxed);
        PhaseClock::add(&self.clock.shadow, since)
    }

    /// Primary rays, `U`, then samples at every pixel of the band.
    pub(super) fn run(
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
pub(super) struct BandScratch {
    /// Analytic `U` of each light at each pixel of the band.
    pub(super) per_light: Vec<Vec3>,
    /// Share of the specular lobe in each pixel's `U` (luminance).
    pub(super) spec_share: Vec<f32>,
    pub(super) batch: ShadowBatch,
    /// The pixels a band draws samples at, (band index, slot) pairs.
    pub(super) drawn: Vec<(usize, usize)>,
    /// `draw_samples`' streams.
    pub(super) samples: SampleScratch,
    /// Band pixels sampled this frame (reduced rate).
    pub(super) sampled: Vec<usize>,
}

/// One band of rows of every per-pixel buffer.
pub(super) struct BandMut<'a> {
    pub(super) y0: u32,
    #[allow(dead_code)]
    pub(super) width: u32,
    pub(super) gbuf: &'a mut [GSample],
    pub(super) u: &'a mut [Vec3],
    pub(super) un: &'a mut [Vec3],
    pub(super) sn: &'a mut [Vec3],
    pub(super) color: &'a mut [Vec3],
    /// The resolve's noise-free factor (see `ResolveInput`).
    pub(super) resolve_in: &'a mut [Vec3],
    pub(super) guide: GuideMut<'a>,
}

//! Visibility at a quarter of the pixels: one pixel of each 2x2 quad
//! samples per frame, and the denoised quads are brought to every pixel;
//! the pixels no quad vouches for sample themselves.

use super::Frame;
use super::band::{BAND_ROWS, BandJob, BandMut, BandScratch};
use super::clock::PhaseClock;
use crate::estimate::{SampleSink, analytic_u_band, draw_pixel_samples};
use crate::gbuffer::GSample;
use crate::guides::GuideMut;
use crate::plan::FramePlan;
use crate::primary::PixelOffset;
use crate::quads::{self, FullRes, Quads};
use crate::settings::RenderSettings;
use crate::shadow::ShadowBatch;
use crate::solo::SoloHistory;
use crate::world::World;
use glam::Vec3;
use penumbra_denoise::luminance;
use penumbra_scene::CameraFrame;
use rayon::prelude::*;
use std::sync::atomic::Ordering;
use std::time::Instant;

/// Orphan pixels per parallel work item.
pub(super) const ORPHAN_CHUNK: usize = 64;

pub(super) fn quad_count(width: u32, height: u32) -> usize {
    width.div_ceil(2) as usize * height.div_ceil(2) as usize
}

/// The samples of the pixels that sample themselves at the reduced rate:
/// `U` per light (for the light choice), then the plan's estimator.
pub(super) fn orphan_samples(
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
        draw_pixel_samples(
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
pub(super) struct QuadBand<'a> {
    pub(super) un: &'a mut [Vec3],
    pub(super) sn: &'a mut [Vec3],
    pub(super) u: &'a mut [Vec3],
    pub(super) guide: GuideMut<'a>,
}

/// Splits the quad buffers into the bands of `Frame::bands` (half as many rows).
pub(super) fn quad_bands(q: &mut Quads) -> Vec<QuadBand<'_>> {
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
pub(super) fn sample_quads(
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

impl Frame {
    /// Brings the denoised quad signals to every pixel; the pixels no quad
    /// vouched for, and the sharp-lobed ones, draw their own samples, which
    /// their own history averages over frames (`solo`).
    pub(super) fn upsample(
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
        let first = self.frame_index.wrapping_mul(settings.spp);
        let job = BandJob::planned(world, (cam, prev), offset, (settings, plan), first, clock);
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
}

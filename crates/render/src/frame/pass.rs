//! The band pass over a whole frame: the frame's buffers cut into bands of
//! rows, each band run on rayon as `band` describes (primary rays, `U`,
//! then samples at the plan's rate: every pixel, or one of each quad as in
//! `quarter`), the guides and the resolve's input written while the band
//! is in cache.

use super::Frame;
use super::band::{BAND_ROWS, BandJob, BandMut, BandScratch};
use super::clock::PhaseClock;
use super::composite::shade;
use super::quarter::{QuadBand, quad_bands, quad_count, sample_quads};
use crate::plan::{FramePlan, ResolveInput};
use crate::primary::PixelOffset;
use crate::quads::{QUAD_ORDER, Quads};
use crate::settings::RenderSettings;
use crate::settings::VisibilityRate;
use crate::world::World;
use penumbra_denoise::TILE;
use penumbra_scene::CameraFrame;
use rayon::prelude::*;

impl Frame {
    /// The band pass: primary rays, `U`, samples and shadow rays at the
    /// plan's rate, the guides, and (when nothing is denoised) the colour.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn band_pass(
        &mut self,
        world: &World,
        (cam, prev): (&CameraFrame, &CameraFrame),
        offset: PixelOffset,
        settings: &RenderSettings,
        plan: &FramePlan,
        unsampled: &[u8],
        clock: &PhaseClock,
    ) {
        let first = self.first_sample(plan.rate, settings.spp);
        let job = BandJob::planned(world, (cam, prev), offset, (settings, plan), first, clock);
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
                        // Walked row by row: no division per pixel.
                        let drawn = (0..n / w.max(1)).flat_map(|r| {
                            let tiles = (!unsampled.is_empty()).then(|| {
                                let at = (row0 + r) / TILE * tiles_w;
                                &unsampled[at..at + tiles_w]
                            });
                            (0..w)
                                .filter(move |&x| tiles.is_none_or(|t| t[x / TILE] == 0))
                                .map(move |x| (r * w + x, r * w + x))
                        });
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
    pub(super) fn bands(&mut self) -> Vec<BandMut<'_>> {
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
}

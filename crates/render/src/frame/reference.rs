//! The converged estimate: every pixel's jittered samples of the full MIS
//! estimator, averaged over calls.

use super::Frame;
use super::band::{BAND_ROWS, BandJob, BandScratch};
use super::clock::PhaseClock;
use super::composite::finite_or_zero;
use crate::estimate::Estimator;
use crate::primary::PixelOffset;
use crate::settings::RenderSettings;
use crate::world::World;
use glam::Vec3;
use penumbra_scene::CameraFrame;
use rayon::prelude::*;

impl Frame {
    /// Adds `settings.spp` jittered samples of the full MIS estimator per
    /// pixel to the running average.
    pub(super) fn render_reference(
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

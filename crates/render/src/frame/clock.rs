//! What a frame measured of itself: each stage's time, the shadow rays and
//! the `U` stage's light counts.

use crate::estimate::UCounts;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

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
pub(super) struct PhaseClock {
    pub(super) primary: AtomicU64,
    pub(super) u: AtomicU64,
    pub(super) shadow: AtomicU64,
    pub(super) composite: AtomicU64,
    pub(super) shadow_rays: AtomicU64,
    pub(super) u_pairs: [AtomicU64; 3],
}

impl PhaseClock {
    pub(super) fn count_u(&self, c: &UCounts) {
        for (slot, n) in self.u_pairs.iter().zip([c.full, c.diffuse_only, c.culled]) {
            slot.fetch_add(n, Ordering::Relaxed);
        }
    }

    pub(super) fn add(slot: &AtomicU64, since: Instant) -> Instant {
        let now = Instant::now();
        slot.fetch_add((now - since).as_nanos() as u64, Ordering::Relaxed);
        now
    }
}

//! Joint denoiser for the ratio estimator: `U_N` and `S_N` are filtered with
//! exactly the same per-pixel weights, so `denoise(S_N) / denoise(U_N)` is a
//! weighted average of the same samples on top and bottom (Heitz et al. 2018).
//!
//! One call runs, in order:
//! 1. [`temporal`]: reproject last frame's accumulation (bilinear, every tap
//!    validated against depth, normal and tangent plane), reject it where the
//!    analytic `U` changed, blend with one factor per pixel for both signals.
//! 2. [`tiles`]: classify 8x8 tiles whose ratio is exactly 1 (lit) or 0
//!    (shadowed) everywhere; such a tile whose neighbours are uniform too is
//!    skipped by the spatial filter (FidelityFX shadow denoiser idea).
//! 3. [`noise`]: per pixel, a noise estimate of the ratio (temporal moments, or
//!    spatial moments while the history is short) sets how many à-trous levels
//!    the pixel needs: clean pixels (long history, constant ratio) get none.
//! 4. [`spatial`]: edge-aware à-trous (3x3 taps, step doubling per level),
//!    weights from plane distance, normal, `U` luminance, the ratio and the
//!    specular lobe (`lobe`: a near-mirror's sharp reflected shadow is not
//!    averaged with its neighbours'), computed once per tap and applied to
//!    both signals.
//!
//! After the composite, [`resolve`] averages the finished colour over
//! jittered frames (TAA); it is a separate stage and never touches `U_N`/`S_N`.
//! [`upscale`] is the same stage for frames rendered below the output's
//! size: its history has the output's size.
//!
//! Depends only on `glam` and `rayon`; all buffers are allocated on the first
//! frame (or a resize) and reused afterwards.

mod history;
mod lobe;
mod neighbourhood;
mod noise;
mod resolve;
mod spatial;
mod temporal;
mod tiles;
mod upscale;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::Instant;

pub use lobe::Lobe;
pub use resolve::{CameraMotion, Resolve, ResolveSettings};
pub use spatial::falloff;
pub use temporal::Taps;
pub use tiles::TILE;
pub use upscale::{EdgeHit, Upscale};

/// Per-pixel guides the renderer fills each frame (row-major, row 0 on top).
pub struct GuideBuffers<'a> {
    pub width: u32,
    pub height: u32,
    /// World-space hit point.
    pub position: &'a [Vec3],
    /// Unit normal facing the camera; zero where there is no surface.
    pub normal: &'a [Vec3],
    /// Distance from the eye; 0 means no surface: the pixel passes through
    /// unchanged and keeps no history.
    pub depth: &'a [f32],
    /// Where this point was in the previous frame, continuous pixel
    /// coordinates with pixel centres at +0.5.
    pub prev_pixel: &'a [Vec2],
    /// False where no reprojection is possible.
    pub prev_valid: &'a [bool],
    /// Analytic unshadowed light `U` (noise-free): edge guide, and the detector
    /// of light changes for the history.
    pub u: &'a [Vec3],
    /// Specular lobe per pixel (see [`Lobe`]): taps whose mirror directions
    /// lie lobe widths apart are not averaged. Empty: no lobe guide (every
    /// pixel treated as diffuse).
    pub lobe: &'a [Lobe],
}

/// Knobs of the denoiser. `Default` gives the tuned values.
#[derive(Clone, Debug)]
pub struct DenoiseSettings {
    /// Temporal accumulation on/off (off: each frame stands alone).
    pub temporal: bool,
    /// Spatial à-trous filter on/off.
    pub spatial: bool,
    /// History cap in frames: the blend factor never drops below 1/this, so
    /// changes the `U` test cannot see (a moving occluder) fade in that long.
    pub max_history: u16,
    /// Reprojection tap rejected when |d_prev - d| > this * d.
    pub depth_tolerance: f32,
    /// Reprojection tap rejected when dot(n_prev, n) < this.
    pub min_normal_dot: f32,
    /// Reprojection tap rejected when the previous point lies farther than
    /// this * d from the current tangent plane.
    pub plane_tolerance: f32,
    /// History dropped when the luminance of `U`'s diffuse part (of the
    /// whole `U` where that part is under 2 % of it) changed by more than
    /// this fraction (a light moved or was edited; see `temporal`).
    pub u_change: f32,
    /// The per-pixel light test above on/off. Off under a still, jittered
    /// camera: there `U` changes between frames only because the jitter
    /// moved the ray inside the pixel (a highlight on a normal-mapped floor
    /// varies by far more than 25 % within a pixel), and the renderer drops
    /// the whole history when the scene's lights change.
    pub light_test: bool,
    /// Most à-trous levels (3x3 taps at steps 1, 2, 4, ...: radius 2^n - 1),
    /// at most 8.
    pub max_levels: u8,
    /// Every surface pixel gets at least this many levels (0 = fully adaptive;
    /// above 0 also disables tile skipping). For tests and debugging views.
    pub min_levels: u8,
    /// Standard deviation of the ratio considered clean: a pixel gets levels
    /// until its estimated noise, halved per level, falls below this.
    pub noise_target: f32,
    /// Ratio edge-stopping: taps whose ratio differs by more than about this
    /// many noise deviations are dropped.
    pub sigma_ratio: f32,
    /// Plane edge-stopping: sine of the angle between the tangent plane and
    /// the direction to the tap.
    pub sigma_plane: f32,
    /// Normal edge-stopping: weight falls with (1 - dot) * this.
    pub normal_power: f32,
    /// `U` edge-stopping: relative luminance difference of `U`.
    pub sigma_u: f32,
    /// Lobe edge-stopping: weight falls with this times the squared
    /// separation of the mirror directions in lobe widths (0: off).
    pub lobe_scale: f32,
    /// Skip tiles whose ratio is uniformly 0 or 1 (and whose neighbours are
    /// uniform too).
    pub skip_tiles: bool,
}

impl Default for DenoiseSettings {
    fn default() -> Self {
        DenoiseSettings {
            temporal: true,
            spatial: true,
            max_history: 32,
            depth_tolerance: 0.1,
            min_normal_dot: 0.9,
            plane_tolerance: 0.02,
            u_change: 0.25,
            light_test: true,
            max_levels: 4,
            min_levels: 0,
            noise_target: 0.02,
            sigma_ratio: 3.0,
            sigma_plane: 0.1,
            normal_power: 64.0,
            sigma_u: 0.3,
            lobe_scale: 10.0,
            skip_tiles: true,
        }
    }
}

/// What one call cost and skipped.
#[derive(Clone, Debug, Default)]
pub struct DenoiseStats {
    pub temporal_ms: f64,
    /// Tile classification, noise estimate and à-trous levels.
    pub spatial_ms: f64,
    pub tiles_skipped: usize,
    pub tiles_total: usize,
    /// À-trous levels run this frame (the most any pixel needed).
    pub levels: u8,
}

/// Denoiser state: the history of the previous frame and scratch buffers.
pub struct Denoiser {
    width: u32,
    height: u32,
    /// `prev` is read by reprojection while `cur` is written; swapped per frame.
    prev: history::History,
    cur: history::History,
    /// Guide planes of the spatial filter (see `spatial::guide`), written by
    /// the temporal pass.
    guides: spatial::Planes,
    /// The accumulated signals and their ratio as planes (the first à-trous
    /// level's input), and the two ping-pong planes of the later levels.
    acc: spatial::Planes,
    ping: spatial::Planes,
    pong: spatial::Planes,
    /// Raw (this frame only) ratio per pixel, for the spatial noise estimate.
    moments: spatial::Planes,
    /// Class bits per pixel row and tile column (see `tiles`).
    row_class: Vec<u8>,
    /// Noise deviation of the accumulated ratio per pixel.
    sigma: Vec<f32>,
    /// À-trous levels each pixel needs.
    levels: Vec<u8>,
    tiles: tiles::Tiles,
    /// Which reprojection taps each pixel passed in the last call (`taps`),
    /// written while `keep_taps` is on.
    taps: Vec<temporal::Taps>,
    keep_taps: bool,
    taps_kept: bool,
}

pub use penumbra_scene::color::luminance;

/// Ratio of luminances in [0, 1]. Where `U_N` carries no light the ratio is
/// defined as 1 (nothing is known to be blocked), never a division by zero.
#[inline(always)]
pub fn luminance_ratio(sn: Vec3, un: Vec3) -> f32 {
    let lu = luminance(un);
    if lu > 1e-30 && lu.is_finite() {
        (luminance(sn) / lu).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Planes of a `width` x `height` frame with a border for `levels` à-trous
/// levels (at least the default count's).
fn planes(width: u32, height: u32, levels: u8, border: &[f32]) -> spatial::Planes {
    let levels = levels.max(DenoiseSettings::default().max_levels);
    spatial::Planes::new(
        width as usize,
        height as usize,
        spatial::pad_for(levels),
        border,
    )
}

impl Denoiser {
    pub fn new(width: u32, height: u32) -> Denoiser {
        let n = width as usize * height as usize;
        Denoiser {
            width,
            height,
            prev: history::History::new(width as usize, height as usize),
            cur: history::History::new(width as usize, height as usize),
            guides: planes(width, height, 0, &spatial::GUIDE_BORDER),
            acc: planes(width, height, 0, &spatial::SIGNAL_BORDER),
            ping: planes(width, height, 0, &spatial::SIGNAL_BORDER),
            pong: planes(width, height, 0, &spatial::SIGNAL_BORDER),
            moments: spatial::Planes::new(
                width as usize,
                height as usize,
                spatial::LANES,
                &[0.0; noise::COUNT],
            ),
            row_class: vec![0; height as usize * (width as usize).div_ceil(TILE)],
            sigma: vec![0.0; n],
            levels: vec![0; n],
            tiles: tiles::Tiles::new(width, height),
            taps: vec![0; n],
            keep_taps: false,
            taps_kept: false,
        }
    }

    /// Whether the next calls keep which reprojection taps each pixel
    /// passed, for `taps` (off by default: a byte a pixel written for
    /// nobody).
    pub fn keep_taps(&mut self, keep: bool) {
        self.keep_taps = keep;
    }

    /// Which reprojection taps each pixel passed in the last call, when it
    /// kept them (`keep_taps`): what the colour resolve reuses.
    pub fn taps(&self) -> Option<&[Taps]> {
        self.taps_kept.then_some(&self.taps[..])
    }

    /// Reallocates the planes when `levels` à-trous levels need a wider
    /// border than they have (a settings change, not a per-frame cost).
    fn fit_planes(&mut self, levels: u8) {
        let pad = spatial::pad_for(levels);
        if self.guides.pad < pad {
            let (w, h) = (self.width, self.height);
            self.guides = planes(w, h, levels, &spatial::GUIDE_BORDER);
            self.acc = planes(w, h, levels, &spatial::SIGNAL_BORDER);
            self.ping = planes(w, h, levels, &spatial::SIGNAL_BORDER);
            self.pong = planes(w, h, levels, &spatial::SIGNAL_BORDER);
        }
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// Drops the history (mode switch, camera cut, scene edit).
    pub fn reset(&mut self) {
        self.prev.clear();
        self.cur.clear();
    }

    /// History length (frames accumulated, capped) per pixel after the last
    /// call; 0 where there is no surface. For debug views and tests.
    pub fn history_len(&self) -> Vec<f32> {
        // After a call the freshest history sits in `prev` (swapped at the end).
        (0..self.prev.len())
            .map(|i| self.prev.get(history::field::LEN, i))
            .collect()
    }

    /// Denoises `un` and `sn` in place with identical per-pixel weights (the
    /// temporal blend included); runs on the current rayon pool. A size change
    /// reallocates and drops the history.
    // Out of line: a stage of `make profile` (scripts/profile.py).
    #[inline(never)]
    pub fn denoise(
        &mut self,
        guide: &GuideBuffers,
        un: &mut [Vec3],
        sn: &mut [Vec3],
        settings: &DenoiseSettings,
    ) -> DenoiseStats {
        self.denoise_sparse(guide, un, sn, &[], settings)
    }

    /// The tiles (`TILE` x `TILE`, row-major) that need no new samples: after
    /// the last call they and their 8 neighbours are exactly lit or exactly
    /// in umbra, and every pixel of theirs holds at least `min_history`
    /// frames. Per tile its class (nonzero) or 0; empty before the first
    /// call or after a size change.
    pub fn settled_tiles(&self, min_history: f32) -> Vec<u8> {
        let (w, h) = (self.width as usize, self.height as usize);
        let tw = self.tiles.columns();
        if self.prev.len() != w * h || self.tiles.count() == 0 {
            return Vec::new();
        }
        // After a call the freshest history sits in `prev`.
        let prev = &self.prev;
        (0..self.tiles.count())
            .into_par_iter()
            .map(|t| {
                let (tx, ty) = (t % tw, t / tw);
                if !self.tiles.skipped(tx, ty) {
                    return 0;
                }
                let columns = tx * TILE..((tx + 1) * TILE).min(w);
                let long = (ty * TILE..((ty + 1) * TILE).min(h)).all(|y| {
                    columns.clone().all(|x| {
                        prev.value(history::field::DEPTH, x, y) <= 0.0
                            || prev.value(history::field::LEN, x, y) >= min_history
                    })
                });
                if long { self.tiles.class(t) } else { 0 }
            })
            .collect()
    }

    /// `denoise` where the tiles `unsampled` marks (as `settled_tiles`
    /// gives them) drew no samples this frame: their pixels keep their
    /// history as it is.
    // Out of line: a stage of `make profile` (scripts/profile.py).
    #[inline(never)]
    pub fn denoise_sparse(
        &mut self,
        guide: &GuideBuffers,
        un: &mut [Vec3],
        sn: &mut [Vec3],
        unsampled: &[u8],
        settings: &DenoiseSettings,
    ) -> DenoiseStats {
        let n = guide.width as usize * guide.height as usize;
        assert!(
            guide.position.len() == n
                && guide.normal.len() == n
                && guide.depth.len() == n
                && guide.prev_pixel.len() == n
                && guide.prev_valid.len() == n
                && guide.u.len() == n
                && (guide.lobe.is_empty() || guide.lobe.len() == n)
                && un.len() == n
                && sn.len() == n,
            "denoise: every buffer must hold width * height pixels (the lobe guide may be empty)"
        );
        if guide.width != self.width || guide.height != self.height {
            let keep = self.keep_taps;
            *self = Denoiser::new(guide.width, guide.height);
            self.keep_taps = keep;
        }
        self.taps_kept = false;
        let mut stats = DenoiseStats {
            tiles_total: self.tiles.count(),
            ..DenoiseStats::default()
        };
        if n == 0 {
            return stats;
        }

        let t0 = Instant::now();
        if settings.spatial {
            self.fit_planes(settings.max_levels.max(settings.min_levels));
        }
        temporal::accumulate(
            guide,
            &self.prev,
            &mut self.cur,
            &mut self.guides,
            &mut self.acc,
            &mut self.moments,
            &mut self.row_class,
            un,
            sn,
            if unsampled.len() == self.tiles.count() {
                unsampled
            } else {
                &[]
            },
            (&mut self.taps, self.keep_taps),
            settings,
        );
        self.taps_kept = self.keep_taps;
        let t1 = Instant::now();
        stats.temporal_ms = (t1 - t0).as_secs_f64() * 1e3;

        if settings.spatial {
            let skip = settings.skip_tiles && settings.min_levels == 0;
            stats.tiles_skipped = self
                .tiles
                .classify(&self.row_class, guide.height as usize, skip);
            stats.levels = noise::estimate(
                &self.moments,
                &self.tiles,
                &mut self.sigma,
                &mut self.levels,
                settings,
            );
            let levels = stats.levels.min(spatial::MAX_LEVELS);
            if levels >= 2 {
                // The largest step a level that reads the ping-pong planes
                // takes, in tiles.
                self.tiles
                    .mark_halo((1usize << (levels - 1)).div_ceil(TILE));
            }
            let inputs = spatial::Inputs {
                guides: &self.guides,
                sigma: &self.sigma,
                levels: &self.levels,
                tiles: &self.tiles,
            };
            spatial::filter(
                &inputs,
                &self.acc,
                &mut self.ping,
                &mut self.pong,
                levels,
                un,
                sn,
                settings,
            );
            stats.spatial_ms = t1.elapsed().as_secs_f64() * 1e3;
        }

        std::mem::swap(&mut self.prev, &mut self.cur);
        stats
    }
}

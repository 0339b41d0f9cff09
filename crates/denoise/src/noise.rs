//! Noise estimate of the accumulated ratio, and from it the footprint.
//!
//! The variance of one frame's raw ratio comes from the temporal moments once
//! the history holds a few frames (SVGF), from a 3x3 spatial estimate before
//! that; averaging over 3x3 keeps a pixel whose few samples happened to agree
//! from being left unfiltered inside a penumbra. The accumulated ratio's
//! deviation is that over the history length, so a longer history means a
//! smaller footprint, and a locally constant ratio (fully lit or fully
//! shadowed) means no filtering at all. Each à-trous level roughly halves the
//! deviation, which gives the level count.

use super::DenoiseSettings;
use super::spatial::lanes::V;
use super::spatial::{LANES, Planes};
use super::tiles::{TILE, Tiles};
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// History length from which the temporal moments are trusted.
const TRUST_MOMENTS: f32 = 4.0;

/// The planes the temporal pass writes for the estimate, per surface pixel
/// (0 in every plane where there is none, so a 3x3 sum of each plane is the
/// sum over the surface pixels): this frame's raw ratio, the variance of the
/// accumulated moments, and the history length. The square of the raw ratio
/// and the surface count are derived here (the length is at least 1 on a
/// surface, 0 elsewhere) rather than stored: the pass is bound by the bytes
/// it moves, and two more planes cost 8 of them per pixel written and read.
pub(crate) const RAW: usize = 0;
pub(crate) const VAR_T: usize = 1;
pub(crate) const LEN: usize = 2;
pub(crate) const COUNT: usize = 3;

/// Per pixel the noise deviation of the accumulated ratio (`sigma_out`) and
/// the levels it needs; returns the most levels any pixel needs.
pub(crate) fn estimate(
    moments: &Planes,
    tiles: &Tiles,
    sigma_out: &mut [f32],
    levels: &mut [u8],
    s: &DenoiseSettings,
) -> u8 {
    let w = moments.width;
    (sigma_out.par_chunks_mut(w), levels.par_chunks_mut(w))
        .into_par_iter()
        .enumerate()
        .map(|(y, (sg, lv))| {
            isa::run(Row {
                moments,
                tiles,
                s,
                y,
                sg,
                lv,
            })
        })
        .max()
        .unwrap_or(0)
}

/// One row of the estimate, a lane group at a time.
struct Row<'a> {
    moments: &'a Planes,
    tiles: &'a Tiles,
    s: &'a DenoiseSettings,
    y: usize,
    sg: &'a mut [f32],
    lv: &'a mut [u8],
}

impl Kernel for Row<'_> {
    type Out = u8;
    #[inline(always)]
    fn run(self) -> u8 {
        let Row {
            moments: m,
            tiles,
            s,
            y,
            sg,
            lv,
        } = self;
        let w = m.width;
        let target = s.noise_target.max(1e-6);
        let views: [&[f32]; COUNT] = m.views();
        let block = m.block();
        let zero = V::splat(0.0);
        let mut row_max = 0u8;
        for tx in 0..tiles.columns() {
            let x0 = tx * LANES;
            let n = LANES.min(w - x0);
            if tiles.skipped(tx, y / TILE) {
                sg[x0..x0 + n].fill(0.0);
                lv[x0..x0 + n].fill(0);
                continue;
            }
            let c = m.index(x0, y);
            let (mut r1, mut r2, mut vt, mut cnt) = (zero, zero, zero, zero);
            let one = V::splat(1.0);
            for row in [c - block, c, c + block] {
                for at in [row - 1, row, row + 1] {
                    let raw = V::load(views[RAW], at);
                    r1 = r1 + raw;
                    r2 = r2 + raw * raw;
                    vt = vt + V::load(views[VAR_T], at);
                    cnt = cnt + V::load(views[LEN], at).gt(zero).select(one, zero);
                }
            }
            let len_here = V::load(views[LEN], c);
            let here = len_here.gt(zero);
            // cnt >= 1 wherever the pixel itself is a surface.
            let inv = V::splat(1.0) / here.select(cnt, V::splat(1.0));
            let var_t = vt * inv;
            let len = len_here.max(one);
            let mean = r1 * inv;
            let var_s = (r2 * inv - mean * mean).max(zero).max(var_t);
            let var_raw = len.ge(V::splat(TRUST_MOMENTS)).select(var_t, var_s);
            let sigma = here.select((var_raw / len).sqrt(), zero);
            // Smallest l with sigma / 2^l <= target, at most `max_levels`.
            let mut need = zero;
            let mut left = sigma;
            for _ in 0..s.max_levels {
                let more = left.gt(V::splat(target));
                need = need + more.select(V::splat(1.0), zero);
                left = more.select(left * 0.5, left);
            }
            for l in 0..n {
                let l_need = if len_here.0[l] > 0.0 {
                    (need.0[l] as u8).min(s.max_levels).max(s.min_levels)
                } else {
                    0
                };
                sg[x0 + l] = sigma.0[l];
                lv[x0 + l] = l_need;
                row_max = row_max.max(l_need);
            }
        }
        row_max
    }
}

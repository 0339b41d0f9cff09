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

use super::history::History;
use super::tiles::{TILE, Tiles};
use super::{DenoiseSettings, GuideBuffers};
use rayon::prelude::*;

/// History length from which the temporal moments are trusted.
const TRUST_MOMENTS: f32 = 4.0;

pub(crate) fn estimate(
    guide: &GuideBuffers,
    cur: &History,
    raw_ratio: &[f32],
    tiles: &Tiles,
    sigma_out: &mut [f32],
    levels: &mut [u8],
    s: &DenoiseSettings,
) -> u8 {
    let w = guide.width as usize;
    let h = guide.height as usize;
    let target = s.noise_target.max(1e-6);
    (sigma_out.par_chunks_mut(w), levels.par_chunks_mut(w))
        .into_par_iter()
        .enumerate()
        .map(|(y, (sg, lv))| {
            let mut row_max = 0u8;
            for x in 0..w {
                lv[x] = 0;
                sg[x] = 0.0;
                if cur.meta[y * w + x].depth <= 0.0 || tiles.skipped(x / TILE, y / TILE) {
                    continue;
                }
                let mut n = 0.0f32;
                let (mut r1, mut r2, mut vt) = (0.0f32, 0.0f32, 0.0f32);
                for ny in y.saturating_sub(1)..(y + 2).min(h) {
                    for nx in x.saturating_sub(1)..(x + 2).min(w) {
                        let j = ny * w + nx;
                        let m = &cur.meta[j];
                        if m.depth > 0.0 {
                            let r = raw_ratio[j];
                            r1 += r;
                            r2 += r * r;
                            vt += (m.m2 - m.m1 * m.m1).max(0.0);
                            n += 1.0;
                        }
                    }
                }
                let inv = 1.0 / n; // n >= 1: the pixel itself is a surface
                let var_t = vt * inv;
                let len = cur.meta[y * w + x].len.max(1.0);
                let var_raw = if len >= TRUST_MOMENTS {
                    var_t
                } else {
                    let mean = r1 * inv;
                    (r2 * inv - mean * mean).max(0.0).max(var_t)
                };
                let sigma = (var_raw / len).sqrt();
                sg[x] = sigma;
                // Smallest l with sigma / 2^l <= target.
                let mut need = 0u8;
                let mut left = sigma;
                while left > target && need < s.max_levels {
                    left *= 0.5;
                    need += 1;
                }
                let l = need.min(s.max_levels).max(s.min_levels);
                lv[x] = l;
                row_max = row_max.max(l);
            }
            row_max
        })
        .max()
        .unwrap_or(0)
}

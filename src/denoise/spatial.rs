//! Edge-aware à-trous filter (Dammertz 2010, as used by SVGF) on `U_N` and
//! `S_N` jointly.
//!
//! Why à-trous rather than a separable bilateral: the edge weights (plane,
//! normal, `U`, ratio) are not separable, and a separable bilateral leaks
//! along diagonal edges; à-trous reaches radius 2^L - 1 with 9 taps per level,
//! and the footprint adapts per pixel simply by how many levels the pixel
//! takes part in (see `noise`). 3x3 taps instead of SVGF's 5x5 keep the cost
//! at 9 weight evaluations per pixel and level on a CPU.
//!
//! Each tap's weight is computed once and multiplies both signals, so the
//! ratio of the outputs is a weighted average of the same samples.

use super::history::History;
use super::tiles::{TILE, Tiles};
use super::{DenoiseSettings, ratio};
use glam::Vec3;
use rayon::prelude::*;

/// 1D B-spline-like kernel of one à-trous level (1/4, 1/2, 1/4).
const KERNEL: [f32; 3] = [0.25, 0.5, 0.25];

/// Cheap monotone stand-in for exp(-e): (1 - e/8)^8, exactly 0 from e = 8.
/// A true exp per tap costs more than the rest of the tap together.
#[inline]
fn falloff(e: f32) -> f32 {
    let t = (1.0 - e * 0.125).max(0.0);
    let t2 = t * t;
    let t4 = t2 * t2;
    t4 * t4
}

/// Per-frame inputs of the filter besides the signals.
pub(crate) struct Inputs<'a> {
    pub width: usize,
    pub position: &'a [Vec3],
    pub normal: &'a [Vec3],
    /// Luminance of `U`; negative where there is no surface.
    pub lum_u: &'a [f32],
    /// Noise deviation of the accumulated ratio.
    pub sigma: &'a [f32],
    /// Levels each pixel takes part in.
    pub levels: &'a [u8],
    pub tiles: &'a Tiles,
}

/// Runs `max_level` à-trous levels. Level 0 reads the accumulation kept in
/// `cur`; the levels then ping-pong between the scratch buffers and the
/// caller's so that the last one lands in `un`/`sn` without a final copy.
///
/// Skipped tiles are never touched by a level: the caller's buffers already
/// hold their accumulated values (the temporal pass wrote them in place), and
/// they are copied once into the scratch buffers when a level reads those,
/// so neighbouring taps see them whichever buffer they read.
#[allow(clippy::too_many_arguments)]
pub(crate) fn filter(
    inp: &Inputs,
    cur: &History,
    max_level: u8,
    un: &mut [Vec3],
    sn: &mut [Vec3],
    scratch_un: &mut [Vec3],
    scratch_sn: &mut [Vec3],
    s: &DenoiseSettings,
) {
    let ctx = Ctx {
        inp,
        height: inp.lum_u.len() / inp.width,
        inv_plane2: 1.0 / (s.sigma_plane * s.sigma_plane).max(1e-12),
        normal_power: s.normal_power,
        inv_u: 1.0 / s.sigma_u.max(1e-6),
        sigma_ratio: s.sigma_ratio,
    };
    if max_level >= 2 {
        ctx.copy_skipped(cur, scratch_un, scratch_sn);
    }
    for level in 0..max_level {
        let to_caller = (max_level - 1 - level).is_multiple_of(2);
        match (level == 0, to_caller) {
            (true, true) => ctx.level(level, &cur.un, &cur.sn, un, sn),
            (true, false) => ctx.level(level, &cur.un, &cur.sn, scratch_un, scratch_sn),
            (false, true) => ctx.level(level, scratch_un, scratch_sn, un, sn),
            (false, false) => ctx.level(level, un, sn, scratch_un, scratch_sn),
        }
    }
}

struct Ctx<'a> {
    inp: &'a Inputs<'a>,
    height: usize,
    inv_plane2: f32,
    normal_power: f32,
    inv_u: f32,
    sigma_ratio: f32,
}

impl Ctx<'_> {
    /// Copies the accumulated values of skipped tiles into `dst`.
    fn copy_skipped(&self, cur: &History, dst_un: &mut [Vec3], dst_sn: &mut [Vec3]) {
        let w = self.inp.width;
        let tiles = self.inp.tiles;
        (dst_un.par_chunks_mut(w), dst_sn.par_chunks_mut(w))
            .into_par_iter()
            .enumerate()
            .for_each(|(y, (du, ds))| {
                let row = y * w;
                for tx in 0..tiles.columns() {
                    if tiles.skipped(tx, y / TILE) {
                        let (x0, x1) = (tx * TILE, (tx * TILE + TILE).min(w));
                        du[x0..x1].copy_from_slice(&cur.un[row + x0..row + x1]);
                        ds[x0..x1].copy_from_slice(&cur.sn[row + x0..row + x1]);
                    }
                }
            });
    }

    /// One à-trous level with step 2^level over the tiles not skipped,
    /// parallel over rows.
    fn level(
        &self,
        level: u8,
        src_un: &[Vec3],
        src_sn: &[Vec3],
        dst_un: &mut [Vec3],
        dst_sn: &mut [Vec3],
    ) {
        let w = self.inp.width;
        let tiles = self.inp.tiles;
        (dst_un.par_chunks_mut(w), dst_sn.par_chunks_mut(w))
            .into_par_iter()
            .enumerate()
            .for_each(|(y, (du, ds))| {
                let row = y * w;
                for tx in 0..tiles.columns() {
                    if tiles.skipped(tx, y / TILE) {
                        continue;
                    }
                    for x in tx * TILE..(tx * TILE + TILE).min(w) {
                        let i = row + x;
                        if self.inp.levels[i] <= level {
                            du[x] = src_un[i];
                            ds[x] = src_sn[i];
                        } else {
                            (du[x], ds[x]) = self.tap_sum(level, x, y, src_un, src_sn);
                        }
                    }
                }
            });
    }

    /// Weighted 3x3 sum at step 2^level around (x, y); one weight per tap for
    /// both signals.
    #[inline]
    fn tap_sum(
        &self,
        level: u8,
        x: usize,
        y: usize,
        src_un: &[Vec3],
        src_sn: &[Vec3],
    ) -> (Vec3, Vec3) {
        let inp = self.inp;
        let (w, h) = (inp.width, self.height);
        let i = y * w + x;
        let (p_pos, p_n, p_lu) = (inp.position[i], inp.normal[i], inp.lum_u[i]);
        let step = 1usize << level;
        let rp = ratio(src_un[i], src_sn[i]);
        // The ratio's noise shrinks about twofold per level already run.
        let sig = (inp.sigma[i] * self.sigma_ratio / step as f32).max(1e-4);
        let inv_sig = 1.0 / sig;
        let hc = KERNEL[1] * KERNEL[1];
        let mut su = src_un[i] * hc;
        let mut ss = src_sn[i] * hc;
        let mut wsum = hc;
        for (ky, &hy) in KERNEL.iter().enumerate() {
            let Some(ty) = offset(y, ky, step, h) else {
                continue;
            };
            for (kx, &hx) in KERNEL.iter().enumerate() {
                if kx == 1 && ky == 1 {
                    continue;
                }
                let Some(tx) = offset(x, kx, step, w) else {
                    continue;
                };
                let j = ty * w + tx;
                let q_lu = inp.lum_u[j];
                if q_lu < 0.0 {
                    continue; // no surface
                }
                // Plane: squared sine of the angle between p's tangent plane
                // and the direction to q; scale-free, 0 on a common plane.
                let d = inp.position[j] - p_pos;
                let dn = p_n.dot(d);
                let e_plane = dn * dn * self.inv_plane2 / (d.length_squared() + 1e-30);
                let e_normal = (1.0 - p_n.dot(inp.normal[j])).max(0.0) * self.normal_power;
                let big = p_lu.max(q_lu);
                let e_u = if big > 1e-30 {
                    (p_lu - q_lu).abs() * self.inv_u / big
                } else {
                    0.0
                };
                let e_r = (rp - ratio(src_un[j], src_sn[j])).abs() * inv_sig;
                let wt = hx * hy * falloff(e_plane + e_normal + e_u + e_r);
                if wt > 0.0 {
                    su += src_un[j] * wt;
                    ss += src_sn[j] * wt;
                    wsum += wt;
                }
            }
        }
        let inv = 1.0 / wsum;
        (su * inv, ss * inv)
    }
}

/// Coordinate of kernel index k (0, 1, 2 = -step, 0, +step), if inside.
#[inline]
fn offset(c: usize, k: usize, step: usize, n: usize) -> Option<usize> {
    match k {
        0 => c.checked_sub(step),
        1 => Some(c),
        _ => Some(c + step).filter(|&v| v < n),
    }
}

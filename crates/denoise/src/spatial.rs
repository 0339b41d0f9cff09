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
use super::{DenoiseSettings, Lobe, luminance, luminance_ratio};
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// 1D B-spline-like kernel of one à-trous level (1/4, 1/2, 1/4).
const KERNEL: [f32; 3] = [0.25, 0.5, 0.25];

/// Cheap monotone stand-in for exp(-e): (1 - e/8)^8, exactly 0 from e = 8.
/// A true exp per tap costs more than the rest of the tap together.
#[inline(always)]
pub fn falloff(e: f32) -> f32 {
    let t = (1.0 - e * 0.125).max(0.0);
    let t2 = t * t;
    let t4 = t2 * t2;
    t4 * t4
}

/// What one tap needs of a pixel's guides, packed (44 bytes): the levels are
/// bound by memory traffic, and three separate arrays meant three streams
/// per tap.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Guide {
    pub pos: Vec3,
    pub normal: Vec3,
    /// Luminance of `U`; negative where there is no surface.
    pub lu: f32,
    pub lobe: Lobe,
}

/// Per-frame inputs of the filter besides the signals.
pub(crate) struct Inputs<'a> {
    pub width: usize,
    pub guides: &'a [Guide],
    /// Noise deviation of the accumulated ratio.
    pub sigma: &'a [f32],
    /// Levels each pixel takes part in.
    pub levels: &'a [u8],
    pub tiles: &'a Tiles,
}

/// One ping-pong buffer of the levels: both signals and their ratio, which is
/// computed once when a level writes a pixel rather than by every tap that
/// reads it.
pub(crate) struct Signals<'a> {
    pub un: &'a mut [Vec3],
    pub sn: &'a mut [Vec3],
    pub ratio: &'a mut [f32],
}

/// Read-only view of a source buffer of one level.
#[derive(Clone, Copy)]
struct Src<'a> {
    un: &'a [Vec3],
    sn: &'a [Vec3],
    ratio: &'a [f32],
}

/// Runs `max_level` à-trous levels. Level 0 reads the accumulation kept in
/// `cur` (its ratio in `cur_ratio`); the levels then ping-pong between
/// `scratch` and `out` (the caller's signals) so that the last one lands in
/// `out` without a final copy.
///
/// Skipped tiles are never touched by a level: the caller's buffers already
/// hold their accumulated values (the temporal pass wrote them in place), and
/// they are copied once into the scratch buffers (and their ratio into both
/// ratio buffers) when a level reads those, so neighbouring taps see them
/// whichever buffer they read.
pub(crate) fn filter(
    inp: &Inputs,
    cur: &History,
    cur_ratio: &[f32],
    max_level: u8,
    out: Signals,
    scratch: Signals,
    s: &DenoiseSettings,
) {
    let ctx = Ctx {
        inp,
        height: inp.guides.len() / inp.width,
        inv_plane2: 1.0 / (s.sigma_plane * s.sigma_plane).max(1e-12),
        normal_power: s.normal_power,
        inv_u: 1.0 / s.sigma_u.max(1e-6),
        sigma_ratio: s.sigma_ratio,
        lobe_scale: s.lobe_scale,
        acc_un: &cur.un,
    };
    let (mut out, mut scratch) = (out, scratch);
    if max_level >= 2 {
        ctx.copy_skipped(cur, cur_ratio, &mut scratch);
    }
    if max_level >= 3 {
        // Levels 2+ may read `out` as a source; its signals already hold the
        // skipped tiles' values, their ratio does not yet.
        out.ratio.copy_from_slice(cur_ratio);
    }
    let cur_src = Src {
        un: &cur.un,
        sn: &cur.sn,
        ratio: cur_ratio,
    };
    for level in 0..max_level {
        let to_caller = (max_level - 1 - level).is_multiple_of(2);
        let last = level + 1 == max_level;
        match (level == 0, to_caller) {
            (true, true) => ctx.level(level, cur_src, &mut out, last),
            (true, false) => ctx.level(level, cur_src, &mut scratch, last),
            (false, true) => ctx.level(level, view(&scratch), &mut out, last),
            (false, false) => ctx.level(level, view(&out), &mut scratch, last),
        }
    }
}

fn view<'a>(s: &'a Signals) -> Src<'a> {
    Src {
        un: s.un,
        sn: s.sn,
        ratio: s.ratio,
    }
}

struct Ctx<'a> {
    inp: &'a Inputs<'a>,
    height: usize,
    inv_plane2: f32,
    normal_power: f32,
    inv_u: f32,
    sigma_ratio: f32,
    lobe_scale: f32,
    /// The accumulated `U_N` (the levels' input), for each pixel's confidence.
    acc_un: &'a [Vec3],
}

impl Ctx<'_> {
    /// Copies the accumulated values of skipped tiles into `dst`.
    fn copy_skipped(&self, cur: &History, cur_ratio: &[f32], dst: &mut Signals) {
        let w = self.inp.width;
        let tiles = self.inp.tiles;
        (
            dst.un.par_chunks_mut(w),
            dst.sn.par_chunks_mut(w),
            dst.ratio.par_chunks_mut(w),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(y, (du, ds, dr))| {
                let row = y * w;
                for tx in 0..tiles.columns() {
                    if tiles.skipped(tx, y / TILE) {
                        let (x0, x1) = (tx * TILE, (tx * TILE + TILE).min(w));
                        du[x0..x1].copy_from_slice(&cur.un[row + x0..row + x1]);
                        ds[x0..x1].copy_from_slice(&cur.sn[row + x0..row + x1]);
                        dr[x0..x1].copy_from_slice(&cur_ratio[row + x0..row + x1]);
                    }
                }
            });
    }

    /// One à-trous level with step 2^level over the tiles not skipped,
    /// parallel over rows. The last level's ratio is never read, so it is not
    /// computed.
    fn level(&self, level: u8, src: Src, dst: &mut Signals, last: bool) {
        let w = self.inp.width;
        (
            dst.un.par_chunks_mut(w),
            dst.sn.par_chunks_mut(w),
            dst.ratio.par_chunks_mut(w),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(y, (du, ds, dr))| {
                isa::run(LevelRow {
                    ctx: self,
                    level,
                    src,
                    y,
                    dst: (du, ds, dr),
                    last,
                })
            });
    }

    /// Weighted 3x3 sum at step 2^level around (x, y); one weight per tap for
    /// both signals.
    #[inline(always)]
    fn tap_sum(&self, level: u8, x: usize, y: usize, src: Src) -> (Vec3, Vec3) {
        let inp = self.inp;
        let (w, h) = (inp.width, self.height);
        let i = y * w + x;
        let p = inp.guides[i];
        let step = 1usize << level;
        // The ratio the taps are compared with. At level 0 the centre is one
        // noisy sample: compared with itself, an outlier (one lit sample in
        // a shadow) stops every tap and survives as a speckle. Its 3x3 mean
        // is robust to that; later levels read filtered values already.
        let rp = if level == 0 {
            self.mean_ratio(x, y, src)
        } else {
            src.ratio[i]
        };
        // The ratio's noise shrinks about twofold per level already run.
        let sig = (inp.sigma[i] * self.sigma_ratio / step as f32).max(1e-4);
        let inv_sig = 1.0 / sig;
        // How much of `U` this pixel's own samples carry (1 on average).
        // A pixel whose samples carry almost none (a light sample far off a
        // near-mirror's lobe: positive but negligible weight) still has a
        // ratio of 0 or 1, which says nothing about its lobe; the lobe
        // guide would keep every neighbour out and leave that value. Its
        // lobe term is scaled down so the neighbours, weighted by their own
        // `U_N`, decide.
        let lobe_scale = self.lobe_scale * confidence(self.acc_un[i], p.lu);
        let hc = KERNEL[1] * KERNEL[1];
        let mut su = src.un[i] * hc;
        let mut ss = src.sn[i] * hc;
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
                let q = inp.guides[j];
                if q.lu < 0.0 {
                    continue; // no surface
                }
                // Plane: squared sine of the angle between p's tangent plane
                // and the direction to q; scale-free, 0 on a common plane.
                let d = q.pos - p.pos;
                let dn = p.normal.dot(d);
                let e_plane = dn * dn * self.inv_plane2 / (d.length_squared() + 1e-30);
                let e_normal = (1.0 - p.normal.dot(q.normal)).max(0.0) * self.normal_power;
                let big = p.lu.max(q.lu);
                let e_u = if big > 1e-30 {
                    (p.lu - q.lu).abs() * self.inv_u / big
                } else {
                    0.0
                };
                let e_r = (rp - src.ratio[j]).abs() * inv_sig;
                // Sharp shadows seen through a narrow specular lobe.
                let e_lobe = p.lobe.separation2(&q.lobe) * lobe_scale;
                let wt = hx * hy * falloff(e_plane + e_normal + e_u + e_r + e_lobe);
                if wt > 0.0 {
                    su += src.un[j] * wt;
                    ss += src.sn[j] * wt;
                    wsum += wt;
                }
            }
        }
        let inv = 1.0 / wsum;
        (su * inv, ss * inv)
    }
}

/// One row of one à-trous level: the level's hot loop, compiled per
/// instruction-set level.
struct LevelRow<'a, 'b> {
    ctx: &'a Ctx<'a>,
    level: u8,
    src: Src<'a>,
    y: usize,
    dst: (&'b mut [Vec3], &'b mut [Vec3], &'b mut [f32]),
    last: bool,
}

impl Kernel for LevelRow<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let LevelRow {
            ctx,
            level,
            src,
            y,
            dst: (du, ds, dr),
            last,
        } = self;
        let w = ctx.inp.width;
        let tiles = ctx.inp.tiles;
        let row = y * w;
        for tx in 0..tiles.columns() {
            if tiles.skipped(tx, y / TILE) {
                continue;
            }
            for x in tx * TILE..(tx * TILE + TILE).min(w) {
                let i = row + x;
                if ctx.inp.levels[i] <= level {
                    du[x] = src.un[i];
                    ds[x] = src.sn[i];
                    dr[x] = src.ratio[i];
                } else {
                    let (u, s) = ctx.tap_sum(level, x, y, src);
                    du[x] = u;
                    ds[x] = s;
                    if !last {
                        dr[x] = luminance_ratio(s, u);
                    }
                }
            }
        }
    }
}

impl Ctx<'_> {
    /// Mean ratio over the surface pixels of the 3x3 block around (x, y).
    #[inline(always)]
    fn mean_ratio(&self, x: usize, y: usize, src: Src) -> f32 {
        let (w, h) = (self.inp.width, self.height);
        let (mut sum, mut n) = (0.0f32, 0.0f32);
        for ty in y.saturating_sub(1)..(y + 2).min(h) {
            for tx in x.saturating_sub(1)..(x + 2).min(w) {
                let j = ty * w + tx;
                if self.inp.guides[j].lu >= 0.0 {
                    sum += src.ratio[j];
                    n += 1.0;
                }
            }
        }
        if n > 0.0 {
            sum / n
        } else {
            src.ratio[y * w + x]
        }
    }
}

/// Luminance of `U_N` over that of `U`, in [0, 1]; 1 where `U` is dark.
#[inline(always)]
fn confidence(un: Vec3, lu: f32) -> f32 {
    if lu > 1e-30 {
        (luminance(un) / lu).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Coordinate of kernel index k (0, 1, 2 = -step, 0, +step), if inside.
#[inline(always)]
fn offset(c: usize, k: usize, step: usize, n: usize) -> Option<usize> {
    match k {
        0 => c.checked_sub(step),
        1 => Some(c),
        _ => Some(c + step).filter(|&v| v < n),
    }
}

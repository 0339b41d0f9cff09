//! Visibility at a quarter of the pixels: one pixel of each 2x2 quad draws
//! the frame's samples, the quad-resolution `U_N`, `S_N` are denoised
//! there, and both are brought back to every pixel with the SAME weights
//! (so the ratio stays a ratio of one weighted average of samples, as the
//! denoiser keeps it) from the quads around it whose sampled surface is the
//! pixel's own: same plane, same normal, same lobe. A pixel that no quad
//! around it vouches for (a sliver of geometry too thin to be sampled this
//! frame) draws its own samples instead.

use super::estimate::ratio;
use super::gbuffer::{GSample, PixelKind};
use super::guides::Guides;
use glam::{Vec2, Vec3};
use penumbra_denoise::{Lobe, falloff};
use rayon::prelude::*;

/// The pixel of each quad sampled in frame `frame % 4`: a rotation that
/// visits the diagonal first, so two consecutive frames never sample
/// neighbouring pixels of a row or a column.
pub const QUAD_ORDER: [(u32, u32); 4] = [(0, 0), (1, 1), (1, 0), (0, 1)];

/// Upsampling: a tap's spatial weight falls as a Gaussian of its distance
/// in full-resolution pixels (taps lie at most 3 pixels away on each axis).
const SPATIAL_SIGMA: f32 = 1.25;
const REACH: i32 = 3;
/// A tap is refused when its point lies farther than this fraction of the
/// pixel's depth from the pixel's tangent plane (the denoiser's own
/// reprojection tolerance), when its depth differs by more than
/// `MAX_DEPTH_CHANGE` of the pixel's, or when its normal turns more than
/// `MIN_NORMAL_DOT` allows: the ratio is never carried across an edge.
const PLANE_TOLERANCE: f32 = 0.02;
const MAX_DEPTH_CHANGE: f32 = 0.1;
const MIN_NORMAL_DOT: f32 = 0.9;
/// Lobe edge-stopping, as in the denoiser's spatial filter.
const LOBE_SCALE: f32 = 10.0;
/// A pixel whose neighbour's lobe weight (`exp(-LOBE_SCALE x separation^2)`)
/// falls below `e^-SHARP_SEPARATION` samples itself (see `sharp`).
const SHARP_SEPARATION: f32 = 1.0;

/// Quad-resolution signals and guides, and which pixel each quad sampled.
pub struct Quads {
    pub width: u32,
    pub height: u32,
    pub guide: Guides,
    /// `U` of each quad's sampled pixel (the denoiser's edge guide).
    pub u: Vec<Vec3>,
    pub un: Vec<Vec3>,
    pub sn: Vec<Vec3>,
    /// Which pixel of its quad each quad sampled (`QUAD_ORDER`).
    pub offset: (u32, u32),
}

impl Quads {
    /// Quads covering a `width` x `height` frame (an odd last column or row
    /// makes quads of one pixel's width).
    pub fn new(width: u32, height: u32) -> Quads {
        let (w, h) = (width.div_ceil(2), height.div_ceil(2));
        let n = w as usize * h as usize;
        Quads {
            width: w,
            height: h,
            guide: Guides::new(w, h),
            u: vec![Vec3::ZERO; n],
            un: vec![Vec3::ZERO; n],
            sn: vec![Vec3::ZERO; n],
            offset: QUAD_ORDER[0],
        }
    }
}

/// The pixel quad `(i, j)` samples with `offset`, clamped into the frame.
#[inline]
pub fn sampled_pixel(i: u32, j: u32, offset: (u32, u32), width: u32, height: u32) -> (u32, u32) {
    (
        (2 * i + offset.0).min(width - 1),
        (2 * j + offset.1).min(height - 1),
    )
}

/// Where a quad's sample was in the previous frame, in quad coordinates:
/// the quad's own centre moved by half the pixel's motion. A still camera
/// thus reprojects each quad onto itself whichever pixel it samples, and its
/// history averages the visibility of its four pixels.
#[inline]
pub fn quad_prev_pixel(g: &GSample, x: u32, y: u32, i: u32, j: u32) -> Vec2 {
    let motion = g.prev_pixel - Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
    Vec2::new(i as f32 + 0.5, j as f32 + 0.5) + 0.5 * motion
}

/// What upsampling reads of the full-resolution frame.
pub struct FullRes<'a> {
    pub width: u32,
    pub height: u32,
    pub gbuf: &'a [GSample],
    pub lobe: &'a [Lobe],
}

/// Brings the denoised quad ratios to every pixel (see the module docs):
/// pixel `k` gets `un[k] = u[k]`, its own analytic `U`, and `sn[k]` that
/// times the weighted average of the quads' denoised ratios `S_N / U_N`.
/// The quads' signals are averaged and their ratio taken, not the ratios
/// averaged: the signals are scaled by 1 / U of their sampled pixel (see
/// `sample_quads`), so no highlight outweighs the other taps, and a tap
/// whose samples carry little of its `U` (a light sample far off a
/// near-mirror's lobe, whose own ratio is 0 or 1 whatever its weight)
/// counts as little as its `U_N`. Where every tap's `S_N` equals its `U_N`
/// the ratio is exactly 1, so `sn[k] == un[k]`.
/// Surface pixels no quad vouches for, and those with a lobe too narrow
/// for any quad to stand in for them (`sharp`), are listed in `orphans`
/// (in pixel order) and left at zero: they sample themselves
/// (`super::solo`); even a fresh history's one sample describes such a
/// pixel better than its neighbours do. Pixels off surfaces get zero.
// Out of line: a stage of `make profile` (scripts/profile.py).
#[inline(never)]
pub fn upsample(
    full: &FullRes,
    quads: &Quads,
    u: &[Vec3],
    un: &mut [Vec3],
    sn: &mut [Vec3],
    orphans: &mut Vec<u32>,
) {
    let w = full.width as usize;
    let spatial = spatial_weights();
    let rows: Vec<Vec<u32>> = un
        .par_chunks_mut(w)
        .zip(sn.par_chunks_mut(w))
        .enumerate()
        .map(|(y, (un_row, sn_row))| {
            let mut lost = Vec::new();
            for x in 0..w {
                let k = y * w + x;
                let g = &full.gbuf[k];
                if g.kind != PixelKind::Surface {
                    un_row[x] = Vec3::ZERO;
                    sn_row[x] = Vec3::ZERO;
                    continue;
                }
                if sharp(full, x, y) {
                    lost.push(k as u32);
                    continue;
                }
                match gather(full, quads, &spatial, x as u32, y as u32) {
                    Some(r) => {
                        un_row[x] = u[k];
                        sn_row[x] = u[k] * r;
                    }
                    None => {
                        un_row[x] = Vec3::ZERO;
                        sn_row[x] = Vec3::ZERO;
                        lost.push(k as u32);
                    }
                }
            }
            lost
        })
        .collect();
    orphans.clear();
    for r in rows {
        orphans.extend(r);
    }
}

/// Whether pixel `(x, y)`'s specular lobe is so narrow that its right or
/// lower neighbour on the same surface looks at other directions (the
/// neighbour's lobe weight below `e^-SHARP_SEPARATION`): what such a pixel
/// sees of a shadow changes from pixel to pixel, and a quad that sampled
/// a neighbour cannot tell it.
#[inline]
fn sharp(full: &FullRes, x: usize, y: usize) -> bool {
    let w = full.width as usize;
    let k = y * w + x;
    let lobe = &full.lobe[k];
    if lobe.sharpness <= 0.0 {
        return false;
    }
    let depth = full.gbuf[k].depth;
    let apart = |n: usize| {
        let g = &full.gbuf[n];
        g.kind == PixelKind::Surface
            && (g.depth - depth).abs() <= MAX_DEPTH_CHANGE * depth
            && LOBE_SCALE * lobe.separation2(&full.lobe[n]) > SHARP_SEPARATION
    };
    (x + 1 < w && apart(k + 1)) || (k + w < full.gbuf.len() && apart(k + w))
}

/// The weighted average of the ratios of the 3x3 quads around pixel
/// `(x, y)`, or `None` where none of them sampled the pixel's surface.
#[inline]
fn gather(full: &FullRes, quads: &Quads, spatial: &SpatialWeights, x: u32, y: u32) -> Option<Vec3> {
    let k = (y * full.width + x) as usize;
    let g = &full.gbuf[k];
    let lobe = &full.lobe[k];
    let (qi, qj) = (x / 2, y / 2);
    let (mut wsum, mut un, mut sn) = (0.0f32, Vec3::ZERO, Vec3::ZERO);
    for j in qj.saturating_sub(1)..=(qj + 1).min(quads.height - 1) {
        for i in qi.saturating_sub(1)..=(qi + 1).min(quads.width - 1) {
            let q = (j * quads.width + i) as usize;
            let depth = quads.guide.depth[q];
            if depth <= 0.0 {
                continue;
            }
            if (depth - g.depth).abs() > MAX_DEPTH_CHANGE * g.depth {
                continue;
            }
            let n = quads.guide.normal[q];
            if n.dot(g.ng) < MIN_NORMAL_DOT {
                continue;
            }
            let plane = g.ng.dot(quads.guide.position[q] - g.position).abs();
            if plane > PLANE_TOLERANCE * g.depth {
                continue;
            }
            let (sx, sy) = sampled_pixel(i, j, quads.offset, full.width, full.height);
            let mut wt = spatial.at(sx as i32 - x as i32, sy as i32 - y as i32);
            if lobe.sharpness > 0.0 {
                wt *= falloff(LOBE_SCALE * lobe.separation2(&quads.guide.lobe[q]));
            }
            if wt.is_nan() || wt <= 0.0 {
                continue;
            }
            wsum += wt;
            un += quads.un[q] * wt;
            sn += quads.sn[q] * wt;
        }
    }
    // Where every tap's `S_N` equals its `U_N` the two sums are the same
    // sums of the same numbers, and their ratio is exactly 1.
    (wsum > 0.0).then(|| ratio(sn, un))
}

/// The spatial weight of every tap offset within `REACH`, computed once
/// per frame instead of once per tap.
struct SpatialWeights([f32; (2 * REACH + 1) as usize * (2 * REACH + 1) as usize]);

fn spatial_weights() -> SpatialWeights {
    let side = 2 * REACH + 1;
    let inv_2s2 = 1.0 / (2.0 * SPATIAL_SIGMA * SPATIAL_SIGMA);
    SpatialWeights(std::array::from_fn(|k| {
        let (dx, dy) = (k as i32 % side - REACH, k as i32 / side - REACH);
        (-((dx * dx + dy * dy) as f32) * inv_2s2).exp()
    }))
}

impl SpatialWeights {
    #[inline]
    fn at(&self, dx: i32, dy: i32) -> f32 {
        let side = 2 * REACH + 1;
        let (dx, dy) = (dx.clamp(-REACH, REACH), dy.clamp(-REACH, REACH));
        self.0[((dy + REACH) * side + dx + REACH) as usize]
    }
}

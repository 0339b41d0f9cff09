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
//!
//! Layout: every guide and signal is an `f32` plane ([`Planes`]), and a level
//! runs over [`LANES`] neighbouring pixels of a row at once (one tile row:
//! `LANES == TILE`), so each tap is one contiguous load per plane and the
//! weight arithmetic is one vector instruction per operation. The planes
//! carry a border of "no surface" pixels at least one step wide on every
//! side: a tap that leaves the frame lands on it and gets weight 0 like any
//! tap without a surface, so the tap loop has no bounds test.

use super::DenoiseSettings;
use super::tiles::{TILE, Tiles};
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};
use penumbra_scene::color::LUMA;
use rayon::prelude::*;

/// Pixels per lane group: one tile row.
pub(crate) const LANES: usize = TILE;

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

/// Guide planes: position, normal, luminance of `U` (negative: no surface),
/// mirror direction of the specular lobe and its weight `lobe_k` (the lobe's
/// sharpness times the lobe scale times the pixel's confidence, see
/// [`lobe_weight`]).
pub(crate) mod guide {
    pub const PX: usize = 0;
    pub const PY: usize = 1;
    pub const PZ: usize = 2;
    pub const NX: usize = 3;
    pub const NY: usize = 4;
    pub const NZ: usize = 5;
    pub const LU: usize = 6;
    pub const DX: usize = 7;
    pub const DY: usize = 8;
    pub const DZ: usize = 9;
    pub const LOBE_K: usize = 10;
    pub const COUNT: usize = 11;
}

/// Signal planes: `U_N`, `S_N` and their luminance ratio (computed once
/// when a level writes a pixel, not by every tap that reads it).
pub(crate) mod signal {
    pub const UR: usize = 0;
    pub const SR: usize = 3;
    pub const RATIO: usize = 6;
    pub const COUNT: usize = 7;
}

/// `count` planes of `width` x `height` pixels with a border of `pad` pixels
/// on every side, stored row by row: a padded row of plane 0, of plane 1,
/// and so on, so one image row of every plane is one contiguous block that a
/// parallel pass writes on its own. The border is written once, at
/// allocation, and never again.
pub(crate) struct Planes {
    pub data: Vec<f32>,
    pub count: usize,
    /// Padded row length of one plane.
    pub stride: usize,
    pub pad: usize,
    pub width: usize,
    pub height: usize,
}

impl Planes {
    /// Planes whose border holds `border[k]` in plane k (the interior too,
    /// until the first frame writes it).
    pub fn new(width: usize, height: usize, pad: usize, border: &[f32]) -> Planes {
        let count = border.len();
        // Whole lane groups per row, so the last tile of a row reads no
        // further than the border.
        let stride = pad + width.div_ceil(LANES) * LANES + pad;
        let block = count * stride;
        let mut data = vec![0.0; block * (height + 2 * pad)];
        for row in data.chunks_mut(block) {
            for (k, &b) in border.iter().enumerate() {
                row[k * stride..(k + 1) * stride].fill(b);
            }
        }
        Planes {
            data,
            count,
            stride,
            pad,
            width,
            height,
        }
    }

    /// Index of pixel (x, y) of plane k.
    #[inline(always)]
    pub fn at(&self, k: usize, x: usize, y: usize) -> usize {
        ((y + self.pad) * self.count + k) * self.stride + self.pad + x
    }

    /// Index of pixel (x, y) in every plane's view ([`Planes::views`]).
    #[inline(always)]
    pub fn index(&self, x: usize, y: usize) -> usize {
        (y + self.pad) * self.block() + self.pad + x
    }

    /// Each plane as a slice in which pixel (x, y) sits at
    /// [`Planes::index`], all of the same length: one bounds test on an
    /// index then serves that pixel of every plane.
    #[inline(always)]
    pub fn views<const N: usize>(&self) -> [&[f32]; N] {
        let len = self.data.len() - (N - 1) * self.stride;
        let mut out: [&[f32]; N] = [&[]; N];
        for (k, o) in out.iter_mut().enumerate() {
            *o = &self.data[k * self.stride..k * self.stride + len];
        }
        out
    }

    /// Length of the block of one image row of every plane.
    #[inline]
    pub fn block(&self) -> usize {
        self.count * self.stride
    }

    /// The blocks of the image rows (border rows excluded), for a parallel
    /// pass over rows; within a block pixel x of plane k sits at
    /// `k * stride + pad + x`.
    pub fn par_rows_mut(&mut self) -> rayon::slice::ChunksMut<'_, f32> {
        let block = self.block();
        let (a, b) = (self.pad * block, (self.pad + self.height) * block);
        self.data[a..b].par_chunks_mut(block)
    }
}

/// Border value of each guide plane: no surface.
pub(crate) const GUIDE_BORDER: [f32; guide::COUNT] =
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0];
/// Border value of each signal plane.
pub(crate) const SIGNAL_BORDER: [f32; signal::COUNT] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];

/// Most à-trous levels run (radius 255 pixels): the border grows with the
/// largest step.
pub(crate) const MAX_LEVELS: u8 = 8;

/// Border width that lets `levels` à-trous levels (largest step
/// 2^(levels - 1)) run without bounds tests.
pub(crate) fn pad_for(levels: u8) -> usize {
    let step = 1usize << (levels.clamp(1, MAX_LEVELS) - 1);
    step.max(LANES).div_ceil(LANES) * LANES
}

/// The lobe term's weight per lane: how sharp its specular lobe is
/// (`sharpness`), times the lobe scale, times how much of `U` its own
/// samples carry (`confidence`). Sanitised: 0 unless finite and positive.
#[inline(always)]
pub(crate) fn lobe_weight(sharpness: V, lobe_scale: f32, confidence: V) -> V {
    let k = sharpness * (V::splat(lobe_scale) * confidence);
    sharpness
        .gt(V::splat(0.0))
        .and(k.abs().lt(V::splat(f32::INFINITY)))
        .select(k, V::splat(0.0))
}

/// Luminance of `U_N` over that of `U` per lane, in [0, 1]; 1 where `U` is
/// dark.
///
/// A pixel whose samples carry almost none of `U` (a light sample far off a
/// near-mirror's lobe: positive but negligible weight) still has a ratio of
/// 0 or 1, which says nothing about its lobe; the lobe guide would keep
/// every neighbour out and leave that value. Its lobe term is scaled down so
/// the neighbours, weighted by their own `U_N`, decide.
#[inline(always)]
pub(crate) fn confidence(un_luminance: V, lu: V) -> V {
    let ok = lu.gt(V::splat(1e-30));
    ok.select(
        lanes::clamp01(un_luminance / ok.select(lu, V::splat(1.0))),
        V::splat(1.0),
    )
}

/// Per-frame inputs of the filter besides the signals.
pub(crate) struct Inputs<'a> {
    pub guides: &'a Planes,
    /// Noise deviation of the accumulated ratio (row-major, unpadded).
    pub sigma: &'a [f32],
    /// Levels each pixel takes part in (row-major, unpadded).
    pub levels: &'a [u8],
    pub tiles: &'a Tiles,
}

/// Runs `max_level` à-trous levels. Level 0 reads the accumulation in
/// `acc` (the temporal pass wrote it); the levels then ping-pong between
/// `ping` and `pong`, and the last one writes the caller's `un`/`sn`
/// directly, at the pixels that take part in at least one level (the rest
/// already hold their accumulated values there).
///
/// Skipped tiles are never touched by a level; the accumulated values of
/// those within a tap's reach of a filtered tile are copied once into the
/// ping-pong planes a level reads, so neighbouring taps see them whichever
/// planes they read.
#[allow(clippy::too_many_arguments)]
pub(crate) fn filter(
    inp: &Inputs,
    acc: &Planes,
    ping: &mut Planes,
    pong: &mut Planes,
    max_level: u8,
    un: &mut [Vec3],
    sn: &mut [Vec3],
    s: &DenoiseSettings,
) {
    if max_level == 0 {
        return;
    }
    let ctx = Ctx {
        inp,
        inv_plane2: 1.0 / (s.sigma_plane * s.sigma_plane).max(1e-12),
        normal_power: s.normal_power,
        inv_u: 1.0 / s.sigma_u.max(1e-6),
        sigma_ratio: s.sigma_ratio,
    };
    // Level l >= 1 reads `ping` for odd l, `pong` for even l.
    if max_level >= 2 {
        ctx.copy_skipped(acc, ping);
    }
    if max_level >= 3 {
        ctx.copy_skipped(acc, pong);
    }
    for level in 0..max_level {
        let last = level + 1 == max_level;
        let (src, dst): (&Planes, &mut Planes) = match (level, level % 2) {
            (0, _) => (acc, &mut *ping),
            (_, 1) => (&*ping, &mut *pong),
            _ => (&*pong, &mut *ping),
        };
        if last {
            ctx.level_out(level, src, un, sn);
        } else {
            ctx.level(level, src, dst);
        }
    }
}

struct Ctx<'a> {
    inp: &'a Inputs<'a>,
    inv_plane2: f32,
    normal_power: f32,
    inv_u: f32,
    sigma_ratio: f32,
}

impl Ctx<'_> {
    /// Copies the accumulated values of the skipped tiles that a tap can
    /// read (`Tiles::halo`) into `dst`; the others are never read there.
    fn copy_skipped(&self, acc: &Planes, dst: &mut Planes) {
        let tiles = self.inp.tiles;
        let (stride, pad, w) = (acc.stride, acc.pad, acc.width);
        let block = acc.block();
        let a0 = acc.pad * block;
        dst.par_rows_mut().enumerate().for_each(|(y, row)| {
            let from = &acc.data[a0 + y * block..a0 + (y + 1) * block];
            for tx in 0..tiles.columns() {
                if tiles.halo(tx, y / TILE) {
                    let x0 = pad + tx * TILE;
                    let n = TILE.min(w - tx * TILE);
                    for k in 0..signal::COUNT {
                        let o = k * stride + x0;
                        // A whole tile row as one fixed copy (a copy of
                        // variable length is a library call).
                        if n == TILE {
                            row[o..o + TILE].copy_from_slice(&from[o..o + TILE]);
                        } else {
                            row[o..o + n].copy_from_slice(&from[o..o + n]);
                        }
                    }
                }
            }
        });
    }

    /// One à-trous level with step 2^level into planes, over the tiles not
    /// skipped, parallel over rows.
    fn level(&self, level: u8, src: &Planes, dst: &mut Planes) {
        dst.par_rows_mut().enumerate().for_each(|(y, row)| {
            isa::run(LevelRow {
                ctx: self,
                level,
                src,
                y,
                dst: Dst::Planes(row),
            })
        });
    }

    /// The last level: writes the caller's signals.
    fn level_out(&self, level: u8, src: &Planes, un: &mut [Vec3], sn: &mut [Vec3]) {
        let w = src.width;
        (un.par_chunks_mut(w), sn.par_chunks_mut(w))
            .into_par_iter()
            .enumerate()
            .for_each(|(y, (u, s))| {
                isa::run(LevelRow {
                    ctx: self,
                    level,
                    src,
                    y,
                    dst: Dst::Caller(u, s),
                })
            });
    }
}

/// Where one row of a level goes.
enum Dst<'b> {
    /// The row's block of the next level's planes.
    Planes(&'b mut [f32]),
    /// The caller's `U_N` and `S_N` rows (the last level).
    Caller(&'b mut [Vec3], &'b mut [Vec3]),
}

/// One row of one à-trous level: the level's hot loop, compiled per
/// instruction-set level.
struct LevelRow<'a, 'b> {
    ctx: &'a Ctx<'a>,
    level: u8,
    src: &'a Planes,
    y: usize,
    dst: Dst<'b>,
}

/// Lane arithmetic: every operation a fixed loop over the lanes, inlined,
/// which LLVM turns into one vector instruction per operation (one loop
/// over a whole tap's arithmetic stayed scalar at the AVX2 level). Each
/// lane computes exactly what the scalar code would, so the vector width
/// never changes a result.
pub(crate) mod lanes {
    use super::LANES;
    use std::ops::{Add, Div, Mul, Sub};

    /// `[f(0), f(1), ...]`, as a plain loop (which stays inline).
    #[inline(always)]
    pub fn each<T: Copy + Default>(f: impl Fn(usize) -> T) -> [T; LANES] {
        let mut a = [T::default(); LANES];
        for (l, x) in a.iter_mut().enumerate() {
            *x = f(l);
        }
        a
    }

    /// One `f32` per lane.
    #[derive(Clone, Copy, Debug, Default)]
    pub struct V(pub [f32; LANES]);

    /// All ones or all zeros per lane.
    #[derive(Clone, Copy, Debug)]
    pub struct M([u32; LANES]);

    #[inline(always)]
    fn bit(b: bool) -> u32 {
        u32::from(b).wrapping_neg()
    }

    impl V {
        #[inline(always)]
        pub fn splat(x: f32) -> V {
            V([x; LANES])
        }
        /// The lanes of `v` from `at`.
        #[inline(always)]
        pub fn load(v: &[f32], at: usize) -> V {
            let mut out = [0.0; LANES];
            out.copy_from_slice(&v[at..at + LANES]);
            V(out)
        }
        #[inline(always)]
        pub fn store(self, v: &mut [f32], at: usize) {
            v[at..at + LANES].copy_from_slice(&self.0);
        }
        /// `self` where larger than `o`, else `o` (so a NaN lane gives `o`).
        #[inline(always)]
        pub fn max(self, o: V) -> V {
            V(each(|l| {
                if self.0[l] > o.0[l] {
                    self.0[l]
                } else {
                    o.0[l]
                }
            }))
        }
        /// `self` where smaller than `o`, else `o`.
        #[inline(always)]
        pub fn min(self, o: V) -> V {
            V(each(|l| {
                if self.0[l] < o.0[l] {
                    self.0[l]
                } else {
                    o.0[l]
                }
            }))
        }
        #[inline(always)]
        pub fn abs(self) -> V {
            V(each(|l| self.0[l].abs()))
        }
        #[inline(always)]
        pub fn gt(self, o: V) -> M {
            M(each(|l| bit(self.0[l] > o.0[l])))
        }
        #[inline(always)]
        pub fn ge(self, o: V) -> M {
            M(each(|l| bit(self.0[l] >= o.0[l])))
        }
        #[inline(always)]
        pub fn le(self, o: V) -> M {
            M(each(|l| bit(self.0[l] <= o.0[l])))
        }
        #[inline(always)]
        pub fn sqrt(self) -> V {
            V(each(|l| self.0[l].sqrt()))
        }
        #[inline(always)]
        pub fn lt(self, o: V) -> M {
            M(each(|l| bit(self.0[l] < o.0[l])))
        }
        #[inline(always)]
        pub fn eq(self, o: V) -> M {
            M(each(|l| bit(self.0[l] == o.0[l])))
        }
    }

    /// Lanes `0..n` set, the rest clear (`n <= LANES`): a row of a table,
    /// one load.
    #[inline(always)]
    pub fn below(n: usize) -> M {
        const ROWS: [[u32; LANES]; LANES + 1] = {
            let mut rows = [[0; LANES]; LANES + 1];
            let mut n = 0;
            while n <= LANES {
                let mut l = 0;
                while l < n {
                    rows[n][l] = u32::MAX;
                    l += 1;
                }
                n += 1;
            }
            rows
        };
        M(ROWS[n])
    }

    /// `f32::clamp(v, 0, 1)` per lane (a NaN stays NaN).
    #[inline(always)]
    pub fn clamp01(v: V) -> V {
        let v = v.lt(V::splat(0.0)).select(V::splat(0.0), v);
        v.gt(V::splat(1.0)).select(V::splat(1.0), v)
    }

    impl M {
        #[inline(always)]
        pub fn from_fn(f: impl Fn(usize) -> bool) -> M {
            M(each(|l| bit(f(l))))
        }
        /// `a` where set, `b` elsewhere.
        #[inline(always)]
        pub fn select(self, a: V, b: V) -> V {
            // Bitwise: written as an `if`, LLVM may pick between the
            // operands lane by lane.
            V(each(|l| {
                f32::from_bits((a.0[l].to_bits() & self.0[l]) | (b.0[l].to_bits() & !self.0[l]))
            }))
        }
        #[inline(always)]
        pub fn and(self, o: M) -> M {
            M(each(|l| self.0[l] & o.0[l]))
        }
        /// Whether lane `l` is set.
        #[inline(always)]
        pub fn lane(self, l: usize) -> bool {
            self.0[l] != 0
        }
        /// Whether every lane is set.
        #[inline(always)]
        pub fn all(self) -> bool {
            self.0.iter().all(|&b| b != 0)
        }
    }

    macro_rules! binop {
        ($tr:ident, $f:ident, $op:tt) => {
            impl $tr for V {
                type Output = V;
                #[inline(always)]
                fn $f(self, o: V) -> V {
                    V(each(|l| self.0[l] $op o.0[l]))
                }
            }
            impl $tr<f32> for V {
                type Output = V;
                #[inline(always)]
                fn $f(self, o: f32) -> V {
                    V(each(|l| self.0[l] $op o))
                }
            }
        };
    }
    binop!(Add, add, +);
    binop!(Sub, sub, -);
    binop!(Mul, mul, *);
    binop!(Div, div, /);
}

use lanes::{M, V};

/// The filtered lanes of one lane group: `U_N` and `S_N` channels.
struct Filtered {
    u: [V; 3],
    s: [V; 3],
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
            mut dst,
        } = self;
        let w = src.width;
        let tiles = ctx.inp.tiles;
        let g = ctx.inp.guides;
        let to_planes = matches!(dst, Dst::Planes(_));
        for tx in 0..tiles.columns() {
            if tiles.skipped(tx, y / TILE) {
                continue;
            }
            let x0 = tx * LANES;
            let n = LANES.min(w - x0);
            let mut lv = [0u8; LANES];
            let levels = &ctx.inp.levels[y * w + x0..y * w + x0 + n];
            // A whole group as one fixed copy (a variable one is a call).
            if n == LANES {
                lv.copy_from_slice(levels);
            } else {
                lv[..n].copy_from_slice(levels);
            }
            let active = lv.iter().any(|&l| l > level);
            // A group none of whose pixels took part in the previous level
            // holds its final values in the level before that one's
            // output, which is the plane this level writes (the two
            // ping-pong planes alternate): passing them on again would
            // move 56 bytes per pixel for nothing. At the last level a
            // group with no pixel in any level keeps the values already in
            // the caller's buffers.
            let settled = if to_planes {
                level >= 2 && !lv.iter().any(|&l| l >= level)
            } else {
                lv.iter().all(|&l| l == 0)
            };
            if settled {
                continue;
            }
            // Source values: what a pixel that takes no part in this level
            // passes on.
            let mut val = [V::default(); 6];
            for (k, v) in val.iter_mut().enumerate() {
                *v = V::load(&src.data, src.at(k, x0, y));
            }
            let mut ratio = V::load(&src.data, src.at(signal::RATIO, x0, y));
            if active {
                let mut sigma = V::default();
                let sg = &ctx.inp.sigma[y * w + x0..y * w + x0 + n];
                if n == LANES {
                    sigma.0.copy_from_slice(sg);
                } else {
                    sigma.0[..n].copy_from_slice(sg);
                }
                let f = ctx.taps(level, src, g, x0, y, sigma);
                let take = M::from_fn(|l| lv[l] > level);
                for c in 0..3 {
                    val[c] = take.select(f.u[c], val[c]);
                    val[3 + c] = take.select(f.s[c], val[3 + c]);
                }
                if to_planes {
                    ratio = take.select(ratio_lanes(&f), ratio);
                }
            }
            match &mut dst {
                Dst::Planes(row) => {
                    let o = src.pad + x0;
                    for (k, v) in val.iter().enumerate() {
                        v.store(row, k * src.stride + o);
                    }
                    ratio.store(row, signal::RATIO * src.stride + o);
                }
                Dst::Caller(u, s) => {
                    // Pixels in no level keep the accumulated value already
                    // there (and a pixel without a surface its input).
                    for l in 0..n {
                        if lv[l] > 0 {
                            u[x0 + l] = Vec3::new(val[0].0[l], val[1].0[l], val[2].0[l]);
                            s[x0 + l] = Vec3::new(val[3].0[l], val[4].0[l], val[5].0[l]);
                        }
                    }
                }
            }
        }
    }
}

/// Luminance per lane, in `luminance`'s order of operations.
#[inline(always)]
pub(crate) fn luma(c: &[V; 3]) -> V {
    c[0] * LUMA.x + c[1] * LUMA.y + c[2] * LUMA.z
}

/// `luminance_ratio` per lane.
#[inline(always)]
fn ratio_lanes(f: &Filtered) -> V {
    let lu = luma(&f.u);
    let ls = luma(&f.s);
    let ok = lu
        .gt(V::splat(1e-30))
        .and(lu.abs().lt(V::splat(f32::INFINITY)));
    let q = ls / ok.select(lu, V::splat(1.0));
    ok.select(q.max(V::splat(0.0)).min(V::splat(1.0)), V::splat(1.0))
}

/// `falloff` per lane.
#[inline(always)]
fn falloff_lanes(e: V) -> V {
    let t = (V::splat(1.0) - e * 0.125).max(V::splat(0.0));
    let t2 = t * t;
    let t4 = t2 * t2;
    t4 * t4
}

impl Ctx<'_> {
    /// Weighted 3x3 sums at step 2^level around the lane group at (x0, y);
    /// one weight per tap and lane for both signals.
    #[inline(always)]
    fn taps(&self, level: u8, src: &Planes, g: &Planes, x0: usize, y: usize, sigma: V) -> Filtered {
        use guide::*;
        let step = 1usize << level;
        let gv: [&[f32]; guide::COUNT] = g.views();
        let sv: [&[f32]; signal::COUNT] = src.views();
        let gc = g.index(x0, y);
        let sc = src.index(x0, y);
        let gi = |k: usize| V::load(gv[k], gc);
        let (px, py, pz) = (gi(PX), gi(PY), gi(PZ));
        let (nx, ny, nz) = (gi(NX), gi(NY), gi(NZ));
        let lu = gi(LU);
        let (dx, dy, dz) = (gi(DX), gi(DY), gi(DZ));
        let lobe_k = gi(LOBE_K);
        let (gs, ss) = (g.block() as isize, src.block() as isize);
        let tap_at = |c: usize, row_block: isize, kx: usize, ky: usize, st: usize| {
            let off = (ky as isize - 1) * st as isize * row_block + (kx as isize - 1) * st as isize;
            c.wrapping_add_signed(off)
        };
        let zero = V::splat(0.0);

        // The ratio the taps are compared with. At level 0 the centre is one
        // noisy sample: compared with itself, an outlier (one lit sample in
        // a shadow) stops every tap and survives as a speckle. Its 3x3 mean
        // over the surface pixels is robust to that; later levels read
        // filtered values already.
        let rp = if level == 0 {
            let (mut sum, mut cnt) = (zero, zero);
            for ky in 0..3 {
                for kx in 0..3 {
                    let ql = V::load(gv[LU], tap_at(gc, gs, kx, ky, 1));
                    let qr = V::load(sv[signal::RATIO], tap_at(sc, ss, kx, ky, 1));
                    let v = ql.ge(zero);
                    sum = sum + v.select(qr, zero);
                    cnt = cnt + v.select(V::splat(1.0), zero);
                }
            }
            sum / cnt.max(V::splat(1.0))
        } else {
            V::load(sv[signal::RATIO], sc)
        };
        // The ratio's noise shrinks about twofold per level already run.
        let inv_sig = V::splat(1.0) / (sigma * self.sigma_ratio / step as f32).max(V::splat(1e-4));

        let hc = KERNEL[1] * KERNEL[1];
        let mut u = [V::default(); 3];
        let mut s = [V::default(); 3];
        for c in 0..3 {
            u[c] = V::load(sv[signal::UR + c], sc) * hc;
            s[c] = V::load(sv[signal::SR + c], sc) * hc;
        }
        let mut wsum = V::splat(hc);
        for (ky, &hy) in KERNEL.iter().enumerate() {
            for (kx, &hx) in KERNEL.iter().enumerate() {
                if kx == 1 && ky == 1 {
                    continue;
                }
                let gq = tap_at(gc, gs, kx, ky, step);
                let gl = |k: usize| V::load(gv[k], gq);
                let sq = tap_at(sc, ss, kx, ky, step);
                let sl = |k: usize| V::load(sv[k], sq);
                let ql = gl(LU);
                // Plane: squared sine of the angle between p's tangent
                // plane and the direction to q; scale-free, 0 on a common
                // plane.
                let (ddx, ddy, ddz) = (gl(PX) - px, gl(PY) - py, gl(PZ) - pz);
                let dn = nx * ddx + ny * ddy + nz * ddz;
                let d2 = ddx * ddx + ddy * ddy + ddz * ddz;
                let big = lu.max(ql);
                let ok_u = big.gt(V::splat(1e-30));
                // The plane's and `U`'s quotients over one division, the
                // slowest instruction of a tap: `a / p` and `b / q` as
                // `a q r` and `b p r` with `r = 1 / (p q)`. The product is
                // kept off zero; then `r p q <= 1`, and as `dn² <= d2` the
                // plane term stays within `inv_plane2`.
                let (p, q) = (d2 + 1e-30, ok_u.select(big, V::splat(1.0)));
                let r = V::splat(1.0) / (p * q).max(V::splat(f32::MIN_POSITIVE));
                let e_plane = dn * dn * self.inv_plane2 * (q * r);
                let nd = nx * gl(NX) + ny * gl(NY) + nz * gl(NZ);
                let e_normal = (V::splat(1.0) - nd).max(zero) * self.normal_power;
                let e_u = (lu - ql).abs() * self.inv_u * (p * r);
                let e_u = ok_u.select(e_u, zero);
                let e_r = (rp - sl(signal::RATIO)).abs() * inv_sig;
                // Sharp shadows seen through a narrow specular lobe.
                let (lx, ly, lz) = (dx - gl(DX), dy - gl(DY), dz - gl(DZ));
                let e_lobe = (lx * lx + ly * ly + lz * lz) * lobe_k;
                let f = falloff_lanes(e_plane + e_normal + e_u + e_r + e_lobe) * (hx * hy);
                // No surface at q (or off the frame): no weight.
                let wt = ql.ge(zero).select(f, zero);
                for c in 0..3 {
                    u[c] = u[c] + sl(signal::UR + c) * wt;
                    s[c] = s[c] + sl(signal::SR + c) * wt;
                }
                wsum = wsum + wt;
            }
        }
        let inv = V::splat(1.0) / wsum;
        Filtered {
            u: [u[0] * inv, u[1] * inv, u[2] * inv],
            s: [s[0] * inv, s[1] * inv, s[2] * inv],
        }
    }
}

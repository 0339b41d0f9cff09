//! The colour range of each render pixel over its 3x3 neighbours on its
//! surface (the moving upscale's clamp), in lanes of pixels.
//!
//! The render-size fields the test reads (depth, position, normal, colour)
//! are laid out once per frame as padded planes, so that a row's run of
//! `LANES` pixels and each of its eight neighbour runs are one load per
//! field; the border and the row's tail hold no surface (depth 0), so a
//! neighbour off the frame fails the surface test like any other and the
//! loop has no edge cases. Per pixel the result is the scalar rule's, bit
//! for bit: the same tests in the same order of operations, and a
//! neighbour off the surface stands in as the pixel itself.

use super::DenoiseSettings;
use super::spatial::LANES;
use super::spatial::lanes::V;
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// The planes, in this order.
const DEPTH: usize = 0;
const POSITION: usize = 1;
const NORMAL: usize = 4;
const COLOUR: usize = 7;
const FIELDS: usize = 10;

/// Padded structure-of-arrays planes of one render frame.
#[derive(Default)]
pub(crate) struct Neighbourhood {
    width: usize,
    height: usize,
    /// Floats per plane row: the width rounded up to `LANES`, and a border
    /// column each side.
    stride: usize,
    /// Floats per plane: `stride` times the height and a border row each
    /// side.
    plane: usize,
    data: Vec<f32>,
}

impl Neighbourhood {
    /// The planes of a `width` x `height` frame: `px` holds each pixel's
    /// sanitised colour and surface depth (0: no surface), `position` and
    /// `normal` its surface.
    pub fn fill(
        &mut self,
        (width, height): (usize, usize),
        px: &[[f32; 4]],
        position: &[Vec3],
        normal: &[Vec3],
    ) {
        let stride = width.div_ceil(LANES) * LANES + 2;
        let plane = stride * (height + 2);
        if (width, height) != (self.width, self.height) {
            // The border and the tails stay 0 from here on: only the
            // pixels are written.
            self.data.clear();
            self.data.resize(FIELDS * plane, 0.0);
            (self.width, self.height, self.stride, self.plane) = (width, height, stride, plane);
        }
        self.data
            .par_chunks_mut(plane)
            .enumerate()
            .for_each(|(f, out)| {
                let field = |i: usize| match f {
                    DEPTH => px[i][3],
                    COLOUR..FIELDS => px[i][f - COLOUR],
                    POSITION..NORMAL => position[i][f - POSITION],
                    _ => normal[i][f - NORMAL],
                };
                for y in 0..height {
                    let row = &mut out[(y + 1) * stride + 1..][..width];
                    for (x, v) in row.iter_mut().enumerate() {
                        *v = field(y * width + x);
                    }
                }
            });
    }

    /// Row `y`'s ranges: `set(x, lo, hi)` for each pixel of the row, `lo`
    /// and `hi` the least and greatest colour over its 3x3 neighbours on
    /// its surface (within the denoiser's depth, tangent plane and normal
    /// tolerances `s`), itself included.
    pub fn row<F: FnMut(usize, [f32; 3], [f32; 3])>(&self, y: usize, s: &DenoiseSettings, set: F) {
        isa::run(Row { n: self, y, s, set })
    }
}

impl Neighbourhood {
    /// Field `f`'s lanes from plane offset `at`.
    #[inline(always)]
    fn load(&self, f: usize, at: usize) -> V {
        V::load(&self.data, f * self.plane + at)
    }

    /// The three fields from `f`.
    #[inline(always)]
    fn load3(&self, f: usize, at: usize) -> [V; 3] {
        [self.load(f, at), self.load(f + 1, at), self.load(f + 2, at)]
    }
}

/// `Neighbourhood::row` as a `Kernel` (`isa`).
struct Row<'a, F> {
    n: &'a Neighbourhood,
    y: usize,
    s: &'a DenoiseSettings,
    set: F,
}

impl<F: FnMut(usize, [f32; 3], [f32; 3])> Kernel for Row<'_, F> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let Row { n, y, s, mut set } = self;
        let stride = n.stride;
        let (tol_d, tol_p, min_dot) = (
            V::splat(s.depth_tolerance),
            V::splat(s.plane_tolerance),
            V::splat(s.min_normal_dot),
        );
        for x0 in (0..n.width).step_by(LANES) {
            let at = (y + 1) * stride + x0 + 1;
            let d = n.load(DEPTH, at);
            let (p, nrm, c) = (
                n.load3(POSITION, at),
                n.load3(NORMAL, at),
                n.load3(COLOUR, at),
            );
            let (mut lo, mut hi) = (c, c);
            for j in [
                at - stride - 1,
                at - stride,
                at - stride + 1,
                at - 1,
                at,
                at + 1,
                at + stride - 1,
                at + stride,
                at + stride + 1,
            ] {
                let (dj, pj, nj) = (n.load(DEPTH, j), n.load3(POSITION, j), n.load3(NORMAL, j));
                // As glam's `Vec3::dot`: products summed left to right.
                let plane_gap =
                    nrm[0] * (pj[0] - p[0]) + nrm[1] * (pj[1] - p[1]) + nrm[2] * (pj[2] - p[2]);
                let facing = nj[0] * nrm[0] + nj[1] * nrm[1] + nj[2] * nrm[2];
                let holds = dj
                    .gt(V::splat(0.0))
                    .and((dj - d).abs().le(tol_d * d))
                    .and(plane_gap.abs().le(tol_p * d))
                    .and(facing.ge(min_dot));
                for k in 0..3 {
                    let cj = holds.select(n.load(COLOUR + k, j), c[k]);
                    lo[k] = lo[k].min(cj);
                    hi[k] = hi[k].max(cj);
                }
            }
            for l in 0..LANES.min(n.width - x0) {
                let lane = |v: &[V; 3]| [v[0].0[l], v[1].0[l], v[2].0[l]];
                set(x0 + l, lane(&lo), lane(&hi));
            }
        }
    }
}

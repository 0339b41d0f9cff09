//! The colour range of each render pixel over its 3x3 neighbours on its
//! surface (the moving upscale's clamp), in lanes of pixels.
//!
//! The render-size fields the test reads (depth, position, normal, colour)
//! are laid out once per frame as the denoiser's padded planes
//! (`spatial::Planes`), so that a row's run of `LANES` pixels and each of
//! its eight neighbour runs are one load per field; the border and the
//! rows' tails hold no surface (depth 0), so a neighbour off the frame
//! fails the surface test like any other and the loop has no edge cases.
//! Per pixel the result is the scalar rule's, bit for bit: the same tests
//! in the same order of operations, and a neighbour off the surface stands
//! in as the pixel itself.

use super::DenoiseSettings;
use super::spatial::lanes::V;
use super::spatial::{LANES, Planes};
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// The planes, in this order.
const DEPTH: usize = 0;
const POSITION: usize = 1;
const NORMAL: usize = 4;
const COLOUR: usize = 7;
const FIELDS: usize = 10;

/// The render frame's fields as planes with a one-pixel border that holds
/// no surface (`spatial::Planes`); none before the first frame.
#[derive(Default)]
pub(crate) struct Neighbourhood {
    planes: Option<Planes>,
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
        let planes = match &mut self.planes {
            Some(p) if (p.width, p.height) == (width, height) => p,
            // The border and the rows' tails stay 0 from here on: only the
            // pixels are written.
            slot => slot.insert(Planes::new(width, height, 1, &[0.0; FIELDS])),
        };
        let (stride, pad) = (planes.stride, planes.pad);
        planes.par_rows_mut().enumerate().for_each(|(y, block)| {
            for x in 0..width {
                let i = y * width + x;
                let (c, p, n) = (px[i], position[i], normal[i]);
                let fields = [c[3], p.x, p.y, p.z, n.x, n.y, n.z, c[0], c[1], c[2]];
                for (k, v) in fields.into_iter().enumerate() {
                    block[k * stride + pad + x] = v;
                }
            }
        });
    }

    /// Row `y`'s ranges: `set(x, lo, hi)` for each pixel of the row, `lo`
    /// and `hi` the least and greatest colour over its 3x3 neighbours on
    /// its surface (within the denoiser's depth, tangent plane and normal
    /// tolerances `s`), itself included. Nothing before `fill`.
    pub fn row<F: FnMut(usize, [f32; 3], [f32; 3])>(&self, y: usize, s: &DenoiseSettings, set: F) {
        if let Some(planes) = &self.planes {
            isa::run(Row { planes, y, s, set })
        }
    }
}

/// `Neighbourhood::row` as a `Kernel` (`isa`).
struct Row<'a, F> {
    planes: &'a Planes,
    y: usize,
    s: &'a DenoiseSettings,
    set: F,
}

/// Field `f`'s lanes from `at` in the planes' views.
#[inline(always)]
fn load(views: &[&[f32]; FIELDS], f: usize, at: usize) -> V {
    V::load(views[f], at)
}

/// The three fields from `f`.
#[inline(always)]
fn load3(views: &[&[f32]; FIELDS], f: usize, at: usize) -> [V; 3] {
    [
        load(views, f, at),
        load(views, f + 1, at),
        load(views, f + 2, at),
    ]
}

impl<F: FnMut(usize, [f32; 3], [f32; 3])> Kernel for Row<'_, F> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let Row {
            planes,
            y,
            s,
            mut set,
        } = self;
        let views = planes.views::<FIELDS>();
        let block = planes.block();
        let (tol_d, tol_p, min_dot) = (
            V::splat(s.depth_tolerance),
            V::splat(s.plane_tolerance),
            V::splat(s.min_normal_dot),
        );
        for x0 in (0..planes.width).step_by(LANES) {
            let at = planes.index(x0, y);
            let d = load(&views, DEPTH, at);
            let (p, nrm, c) = (
                load3(&views, POSITION, at),
                load3(&views, NORMAL, at),
                load3(&views, COLOUR, at),
            );
            let (mut lo, mut hi) = (c, c);
            for j in [
                at - block - 1,
                at - block,
                at - block + 1,
                at - 1,
                at,
                at + 1,
                at + block - 1,
                at + block,
                at + block + 1,
            ] {
                let (dj, pj, nj) = (
                    load(&views, DEPTH, j),
                    load3(&views, POSITION, j),
                    load3(&views, NORMAL, j),
                );
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
                    let cj = holds.select(load(&views, COLOUR + k, j), c[k]);
                    lo[k] = lo[k].min(cj);
                    hi[k] = hi[k].max(cj);
                }
            }
            for l in 0..LANES.min(planes.width - x0) {
                let lane = |v: &[V; 3]| [v[0].0[l], v[1].0[l], v[2].0[l]];
                set(x0 + l, lane(&lo), lane(&hi));
            }
        }
    }
}

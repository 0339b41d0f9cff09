//! Temporal upscaling: a resolve whose history has the output's size while
//! the frames are rendered smaller (the viewer's dynamic resolution,
//! `render --render-scale`).
//!
//! Each frame's camera rays go through one jittered point per render pixel
//! (`sampling::sequence::frame_jitter`, a (0,m,2)-net over the render pixel
//! in its first 2^m frames), so over frames the render pixels' samples
//! cover every output pixel. Each output pixel takes the current sample
//! that falls inside it (at most one while the render is no larger than the
//! output) and averages it into its history with equal weights: the
//! history length counts samples, not frames, so a pixel no sample fell in
//! this frame keeps its history unchanged. For a still camera the result is
//! the mean of the jittered samples inside the output pixel, the box filter
//! `reference` computes; at half the size a side, the first 4 frames put
//! one sample in each output pixel and the first 16 put 4, stratified. A
//! pixel with no sample yet shows the bilinear interpolation of the current
//! frame, which counts for nothing once a sample arrives.
//!
//! A moving camera reprojects the output history along the motion vector
//! of the render pixel whose sample lies nearest the output pixel's centre
//! (bilinear), clamps it to the range of that pixel's 3x3 render
//! neighbours on its surface (no ghost trails), and caps it short, as
//! [`super::resolve`] does at the frame's own size. The history is kept
//! only where it shows the same surface and light: the witness is the
//! previous frame's render pixel whose sample lay nearest the reprojected
//! point (the previous frame's guides are kept, at the render size), which
//! must pass the denoiser's disocclusion test (depth, tangent plane,
//! normal) against the current one and show the same analytic `U` within
//! its tolerance (a glossy reflection that moved with the view).
//!
//! The output pass is a memory pass, so it is built as one: the history is
//! one `[r, g, b, len]` record per output pixel (the surface tests read
//! render-size buffers, a sixteenth of the output at a quarter scale); which render
//! sample lands in which output column and row, the nearest render pixel
//! and the fallback's bilinear taps depend on one axis each and are tables
//! built per frame; the blend weight `1 / len` is a table too. A still
//! camera updates the history in place (each pixel reads only itself), a
//! moving one writes the other buffer. Each finished row is handed to the
//! caller while it is in cache (`resolve_rows`: the viewer's display
//! transform), so upscale and display are one pass over the output.
//!
//! Where some of an output pixel's render taps show a surface and some do
//! not (a light's rim, the background beyond a silhouette), the nearest
//! render pixel may be on the other side from the output pixel's own
//! centre: at a quarter scale a light would spill up to two output pixels
//! onto the wall beside it, at hundreds of times the wall's radiance,
//! whenever the history is short. The caller traces camera rays at the
//! output's resolution for exactly those pixels ([`Upscale::edge_pixels`],
//! then [`EdgeHit`]): an output pixel whose ray lands on the other side
//! than its nearest render pixel shows the light's or background's
//! radiance its ray sees, or the interpolation over the taps on its ray's
//! surface, until its own samples arrive. (Between two surfaces the
//! history's clamp already keeps each to its own; restarting those pixels
//! only added noise.)
//!
//! The history belongs to the output grid, so a change of render size (a
//! dynamic-resolution step) keeps it; a change of output size drops it. The
//! caller drops it when the lights change.

use super::neighbourhood::Neighbourhood;
use super::resolve::{CameraMotion, ResolveSettings};
use super::temporal::{light_changed, sanitize};
use super::{DenoiseSettings, GuideBuffers, luminance};
use glam::{Vec2, Vec3, Vec4};
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// One output pixel's history: the averaged colour and the number of
/// samples in it (capped; fractional after reprojection; 0: none yet).
pub type Texel = [f32; 4];

/// No render sample lands in this output column (or row).
const NONE: u32 = u32::MAX;

/// What the camera ray through the centre of an output pixel found, for
/// the pixels [`Upscale::edge_pixels`] names: the depth of its surface (0:
/// none, a light or the background) and, without a surface, the radiance
/// the ray sees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EdgeHit {
    /// Row-major index of the output pixel.
    pub index: u32,
    pub depth: f32,
    pub emission: Vec3,
}

/// Upscale state at the output's size.
pub struct Upscale {
    width: u32,
    height: u32,
    /// The history the next frame starts from.
    hist: Vec<Texel>,
    /// A moving camera's frame is written here, then swapped in.
    next: Vec<Texel>,
    /// The last frame's render-size guides: the witnesses of the history.
    witness: Witness,
    /// Per output row: whether its pixels with no sample yet show a
    /// placeholder, and whether it has any such pixel (`RowState`).
    complete: Vec<RowState>,
    /// Per render pixel, where the output pixels nearest it find their
    /// history and what clamps it (`Reproject`): one motion, one surface
    /// test and one 3x3 range per render pixel, which those output pixels
    /// share.
    motion: Vec<Reproject>,
    /// Per render pixel, this frame's sanitised colour and surface depth
    /// (0: no surface), read by the output pass in one load.
    px: Vec<[f32; 4]>,
    /// The render frame's planes for the clamp's 3x3 ranges.
    near: Neighbourhood,
    /// Per render pixel, whether the 2x2 taps it opens mix surfaces
    /// (`edge_pixels`).
    mixed: Vec<bool>,
}

/// Where the render's samples and taps fall on the output, for one frame.
struct Grid {
    ax: Axis,
    ay: Axis,
    map: (Map, Map),
    jitter: Vec2,
}

impl Grid {
    /// The grid of a render of `rw` x `rh` pixels, jittered by `jitter`,
    /// on an output of `ow` x `oh`.
    fn new((rw, rh): (usize, usize), (ow, oh): (usize, usize), jitter: Vec2) -> Grid {
        let jitter = if jitter.is_finite() {
            jitter.clamp(Vec2::ZERO, Vec2::ONE)
        } else {
            Vec2::splat(0.5)
        };
        let (mx, my) = Map::of((rw, rh), (ow, oh));
        Grid {
            ax: Axis::new(ow, rw, jitter.x, mx),
            ay: Axis::new(oh, rh, jitter.y, my),
            map: (mx, my),
            jitter,
        }
    }
}

/// Per-axis tables of one frame (see the module comment).
struct Axis {
    /// The render column (row) whose sample lands in this output column
    /// (row), or `NONE`.
    sample: Vec<u32>,
    /// The render column (row) whose sample lies nearest the centre.
    nearest: Vec<u32>,
    /// The fallback's bilinear taps: two render columns and the weight of
    /// the second.
    taps: Vec<(u32, u32, f32)>,
}

/// Where render coordinates land on the output: `o = a * r + b` (pixel
/// coordinates, both continuous). The camera keeps its vertical field of
/// view at every size, so both axes scale by the ratio of the heights;
/// horizontally the render's view is centred on the output's, and where
/// the rounded render size has another aspect than the output it spans a
/// little more or less of it.
#[derive(Clone, Copy, Debug, Default)]
struct Map {
    a: f32,
    b: f32,
}

impl Map {
    /// The horizontal and vertical maps of a render of `rw` x `rh` pixels
    /// onto an output of `ow` x `oh`.
    fn of((rw, rh): (usize, usize), (ow, oh): (usize, usize)) -> (Map, Map) {
        let a = oh as f32 / rh as f32;
        (
            Map {
                a,
                b: 0.5 * ow as f32 - 0.5 * rw as f32 * a,
            },
            Map { a, b: 0.0 },
        )
    }

    #[inline(always)]
    fn to_render(self, o: f32) -> f32 {
        (o - self.b) / self.a
    }
}

impl Axis {
    /// `out` output pixels over `n` render pixels, samples at `k + jitter`
    /// mapped by `map`.
    fn new(out: usize, n: usize, jitter: f32, map: Map) -> Axis {
        let mut sample = vec![NONE; out];
        for k in 0..n {
            // Half-open output pixels: a sample on a boundary belongs to
            // exactly one. With the render larger than the output (not a
            // size the renderer picks) the last sample of a pixel is kept.
            let o = ((k as f32 + jitter) * map.a + map.b).floor();
            if o >= 0.0 && (o as usize) < out {
                sample[o as usize] = k as u32;
            }
        }
        let last = (n - 1) as f32;
        let (nearest, taps) = (0..out)
            .map(|o| {
                let r = map.to_render(o as f32 + 0.5);
                let nearest = (r - jitter + 0.5).max(0.0).min(last) as u32;
                // Samples at +0.5 in the interpolation's coordinates.
                let p = (r - jitter).clamp(0.0, last);
                let k0 = p.floor();
                let k1 = (k0 + 1.0).min(last);
                (nearest, (k0 as u32, k1 as u32, p - k0))
            })
            .unzip();
        Axis {
            sample,
            nearest,
            taps,
        }
    }
}

/// `1 / n` for the blend, `n` samples: a table, so that no pixel divides.
const RECIP_LEN: usize = 258;

fn recip_table() -> [f32; RECIP_LEN] {
    std::array::from_fn(|n| if n == 0 { 1.0 } else { 1.0 / n as f32 })
}

impl Upscale {
    pub fn new(width: u32, height: u32) -> Upscale {
        let n = width as usize * height as usize;
        Upscale {
            width,
            height,
            hist: vec![[0.0; 4]; n],
            next: vec![[0.0; 4]; n],
            witness: Witness::default(),
            motion: Vec::new(),
            px: Vec::new(),
            near: Neighbourhood::default(),
            mixed: Vec::new(),
            complete: vec![RowState::Empty; height as usize],
        }
    }

    /// The output size.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Forgets the history: the next frame stands alone.
    pub fn reset(&mut self) {
        self.hist.fill([0.0; 4]);
        self.complete.fill(RowState::Empty);
    }

    /// Samples averaged per output pixel after the last call.
    pub fn history_len(&self) -> Vec<f32> {
        self.hist.iter().map(|t| t[3]).collect()
    }

    /// The output pixels of whose four bilinear render taps (among them
    /// the nearest render pixel) some show a surface and some do not,
    /// row-major, into `out`: those the caller traces camera rays for
    /// ([`EdgeHit`]) before it resolves the frame of these `guide`s and
    /// `jitter`.
    pub fn edge_pixels(&mut self, guide: &GuideBuffers, jitter: Vec2, out: &mut Vec<u32>) {
        out.clear();
        let (rw, rh) = (guide.width as usize, guide.height as usize);
        let (ow, oh) = (self.width as usize, self.height as usize);
        if rw * rh == 0 || ow * oh == 0 || guide.depth.len() != rw * rh {
            return;
        }
        let grid = Grid::new((rw, rh), (ow, oh), jitter);
        let surface = |i: usize| surface_depth(guide.depth[i]) > 0.0;
        self.mixed.resize(rw * rh, false);
        self.mixed
            .par_chunks_mut(rw)
            .enumerate()
            .for_each(|(y, row)| {
                let y1 = (y + 1).min(rh - 1);
                for (x, m) in row.iter_mut().enumerate() {
                    let x1 = (x + 1).min(rw - 1);
                    let s = surface(y * rw + x);
                    *m = [y * rw + x1, y1 * rw + x, y1 * rw + x1]
                        .into_iter()
                        .any(|j| surface(j) != s);
                }
            });
        // The output columns whose first tap is each render column: taps
        // rise with the column, so each is one run.
        let mut start = vec![ow as u32; rw + 1];
        for (ox, &(x0, _, _)) in grid.ax.taps.iter().enumerate().rev() {
            start[x0 as usize] = ox as u32;
        }
        for k in (0..rw).rev() {
            start[k] = start[k].min(start[k + 1]);
        }
        for (oy, &(y0, _, _)) in grid.ay.taps.iter().enumerate() {
            let blocks = &self.mixed[y0 as usize * rw..(y0 as usize + 1) * rw];
            for (bx, _) in blocks.iter().enumerate().filter(|(_, m)| **m) {
                let base = (oy * ow) as u32;
                out.extend((start[bx]..start[bx + 1]).map(|ox| base + ox));
            }
        }
    }

    /// The output's linear colour after the last call.
    pub fn color_into(&self, out: &mut [Vec3]) {
        out.par_iter_mut()
            .zip(&self.hist)
            .for_each(|(o, t)| *o = Vec3::new(t[0], t[1], t[2]));
    }

    /// Writes the output-size colour into `out` from one rendered frame:
    /// `color` and `guide` at the render size, `jitter` the sub-pixel offset
    /// its camera rays went through ((0.5, 0.5): pixel centres). `motion`
    /// `None`: the frames are not to be averaged (unjittered, or already
    /// accumulated by the renderer), so the history is dropped and `out` is
    /// the frame interpolated. `surface` holds the denoiser's disocclusion
    /// tolerance. `edges`: the camera rays at [`Upscale::edge_pixels`]'
    /// pixels, in their order (or none: the nearest render pixel stands in).
    #[allow(clippy::too_many_arguments)]
    pub fn resolve(
        &mut self,
        guide: &GuideBuffers,
        color: &[Vec3],
        jitter: Vec2,
        motion: Option<CameraMotion>,
        settings: &ResolveSettings,
        surface: &DenoiseSettings,
        edges: &[EdgeHit],
        out: &mut [Vec3],
    ) {
        let ow = self.width as usize;
        assert_eq!(
            out.len(),
            ow * self.height as usize,
            "upscale: out holds the output size"
        );
        self.resolve_rows(
            guide,
            color,
            jitter,
            motion,
            settings,
            surface,
            edges,
            out.par_chunks_mut(ow.max(1)),
            |row: &mut &mut [Vec3], texels: &[Texel], _| {
                for (o, t) in row.iter_mut().zip(texels) {
                    *o = Vec3::new(t[0], t[1], t[2]);
                }
            },
        );
    }

    /// [`Upscale::resolve`], handing each finished output row (its
    /// `[r, g, b, len]` texels) to `emit` with the matching item of `rows`
    /// (one per output row, e.g. the window's pixel rows), on the thread
    /// that wrote it, while it is in cache. The flag says whether the row
    /// may differ from the last call's: a still camera leaves the rows no
    /// sample landed in as they were, and a caller that keeps what it made
    /// of them may skip them.
    #[allow(clippy::too_many_arguments)]
    pub fn resolve_rows<R, E>(
        &mut self,
        guide: &GuideBuffers,
        color: &[Vec3],
        jitter: Vec2,
        motion: Option<CameraMotion>,
        settings: &ResolveSettings,
        surface: &DenoiseSettings,
        edges: &[EdgeHit],
        rows: R,
        emit: E,
    ) where
        R: IndexedParallelIterator,
        E: Fn(&mut R::Item, &[Texel], bool) + Sync,
    {
        let (rw, rh) = (guide.width as usize, guide.height as usize);
        let rn = rw * rh;
        assert!(
            color.len() == rn
                && guide.depth.len() == rn
                && guide.position.len() == rn
                && guide.normal.len() == rn
                && guide.prev_pixel.len() == rn
                && guide.prev_valid.len() == rn
                && guide.u.len() == rn,
            "upscale: every render buffer must hold width * height pixels"
        );
        let (ow, oh) = (self.width as usize, self.height as usize);
        assert_eq!(rows.len(), oh, "upscale: one output row each");
        if rn == 0 || ow * oh == 0 {
            return;
        }
        if motion.is_none() {
            self.reset();
        }
        let Grid {
            ax,
            ay,
            map: (mx, my),
            jitter,
        } = Grid::new((rw, rh), (ow, oh), jitter);
        // A moving camera's cap counts frames (how far back the history
        // reaches: samples per output pixel per frame times frames); a
        // still camera's counts samples, so that every scale converges to
        // the box filter of as many samples as the full-size resolve
        // averages.
        let per_frame = (rw * rh) as f32 / (ow * oh) as f32;
        let cap = match motion {
            Some(CameraMotion::Moved) => settings.max_history_moving.max(1) as f32 * per_frame,
            _ => settings.max_history_still.max(1) as f32,
        }
        .min((RECIP_LEN - 2) as f32);
        let blend = Blend {
            cap,
            inv_cap: 1.0 / cap,
            recip: recip_table(),
        };
        self.px.resize(rn, [0.0; 4]);
        self.px.par_iter_mut().enumerate().for_each(|(i, p)| {
            let c = sanitize(color[i]);
            *p = [c.x, c.y, c.z, surface_depth(guide.depth[i])];
        });
        if motion == Some(CameraMotion::Moved) {
            self.fill_reproject(guide, surface, settings.clamp, (mx, my), cap);
        }
        let frame = Current {
            px: &self.px,
            tolerance: surface.depth_tolerance,
            rw,
            ax: &ax,
            ay: &ay,
        };
        // Each output row's camera rays: a run of the sorted `edges`.
        let row_edges = |oy: usize| {
            let at = |o: usize| edges.partition_point(|e| (e.index as usize) < o * ow);
            &edges[at(oy)..at(oy + 1)]
        };
        match motion {
            Some(CameraMotion::Moved) => {
                let moved = Moved {
                    motion: &self.motion,
                    prev: &self.hist,
                    size: (ow, oh),
                };
                (
                    self.next.par_chunks_mut(ow),
                    self.complete.par_iter_mut(),
                    rows,
                )
                    .into_par_iter()
                    .enumerate()
                    .for_each(|(oy, (texels, complete, mut item))| {
                        *complete = if moved.row(&frame, &blend, oy, texels, row_edges(oy)) {
                            RowState::Complete
                        } else {
                            RowState::Filled
                        };
                        emit(&mut item, texels, true);
                    });
                std::mem::swap(&mut self.hist, &mut self.next);
            }
            _ => {
                (
                    self.hist.par_chunks_mut(ow),
                    self.complete.par_iter_mut(),
                    rows,
                )
                    .into_par_iter()
                    .enumerate()
                    .for_each(|(oy, (texels, complete, mut item))| {
                        let changed =
                            still_row(&frame, &blend, oy, texels, complete, row_edges(oy));
                        emit(&mut item, texels, changed);
                    });
            }
        }
        self.witness.keep(guide, jitter, (mx, my));
    }

    /// Each render pixel's `Reproject`: its motion vector at the output's
    /// scale, whether the history there shows its surface and light, and
    /// the range of its sanitised colour (`px`) over its 3x3 neighbours on
    /// its surface (`Neighbourhood`), so that a history cut back to it
    /// keeps nothing of another surface (a light's edge, a silhouette); a
    /// wide range, i.e. no clamp, when `clamp` is off. The range's fourth
    /// lane caps the history's length at `cap`.
    fn fill_reproject(
        &mut self,
        guide: &GuideBuffers,
        surface: &DenoiseSettings,
        clamp: bool,
        (mx, my): (Map, Map),
        cap: f32,
    ) {
        let (rw, rh) = (guide.width as usize, guide.height as usize);
        if clamp {
            self.near
                .fill((rw, rh), &self.px, guide.position, guide.normal);
        }
        let (witness, near) = (&self.witness, &self.near);
        self.motion.resize(rw * rh, Reproject::NONE);
        self.motion
            .par_chunks_mut(rw)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, m) in row.iter_mut().enumerate() {
                    let i = y * rw + x;
                    let p = guide.prev_pixel[i];
                    let keep = guide.prev_valid[i]
                        && surface_depth(guide.depth[i]) > 0.0
                        && same(
                            guide,
                            witness,
                            surface,
                            i,
                            Vec2::new(mx.a * p.x + mx.b, my.a * p.y + my.b),
                        );
                    if !keep {
                        *m = Reproject::NONE;
                        continue;
                    }
                    // Output pixels move by the render pixel's motion
                    // times the output pixels per render pixel (both axes
                    // scale alike).
                    let k = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                    *m = Reproject::of((p - k) * my.a, cap);
                }
                if clamp {
                    near.row(y, surface, |x, lo, hi| {
                        let m = &mut row[x];
                        if m.keep {
                            m.lo = Vec3::from_array(lo).extend(f32::MIN);
                            m.hi = Vec3::from_array(hi).extend(cap);
                        }
                    });
                }
            });
    }
}

/// The equal-weight blend of a sample into a history, capped.
struct Blend {
    cap: f32,
    inv_cap: f32,
    recip: [f32; RECIP_LEN],
}

impl Blend {
    /// History `h` of `len` samples and a sample `c` of weight `w` (0 or
    /// 1): the new average and length. The weight `w / min(len + w, cap)`
    /// is `w * max(1 / (len + w), 1 / cap)`, the first from the table (a
    /// fractional length rounds down: a slightly smaller weight), and at
    /// most 1 (a cap below one sample, a short history at a small scale,
    /// takes the sample alone).
    #[inline(always)]
    fn apply(&self, h: Texel, c: Vec3, w: f32) -> Texel {
        let n = h[3] + w;
        let k = (n as usize).min(RECIP_LEN - 1);
        let a = w * self.recip[k].max(self.inv_cap).min(1.0);
        [
            h[0] + (c.x - h[0]) * a,
            h[1] + (c.y - h[1]) * a,
            h[2] + (c.z - h[2]) * a,
            n.min(self.cap).max(w),
        ]
    }
}

/// The current frame as the output pass reads it.
struct Current<'a> {
    /// The render pixels' sanitised colours and depths (0: no surface), and
    /// the relative depth tolerance of "the same surface".
    px: &'a [[f32; 4]],
    tolerance: f32,
    rw: usize,
    ax: &'a Axis,
    ay: &'a Axis,
}

impl Current<'_> {
    /// The render pixel whose sample lands in output pixel (ox, oy) of a
    /// row whose sample row is `ky`, if one does.
    #[inline(always)]
    fn sample_px(&self, ky: u32, ox: usize) -> Option<[f32; 4]> {
        let kx = self.ax.sample[ox];
        (kx != NONE && ky != NONE).then(|| self.px[ky as usize * self.rw + kx as usize])
    }

    /// The sample landing in output pixel (ox, oy) of a row whose sample
    /// row is `ky`, and its weight (0: none; the colour is then unused).
    #[inline(always)]
    fn sample(&self, ky: u32, ox: usize) -> (Vec3, f32) {
        let kx = self.ax.sample[ox];
        let hit = kx != NONE && ky != NONE;
        let i = if hit {
            ky as usize * self.rw + kx as usize
        } else {
            0
        };
        let p = self.px[i];
        (Vec3::new(p[0], p[1], p[2]), if hit { 1.0 } else { 0.0 })
    }

    /// The render pixel whose sample lies nearest the output pixel's
    /// centre.
    #[inline(always)]
    fn nearest(&self, ox: usize, oy: usize) -> [f32; 4] {
        self.px[self.ay.nearest[oy] as usize * self.rw + self.ax.nearest[ox] as usize]
    }

    /// The bilinear interpolation of the frame at the output pixel's
    /// centre over the taps on the surface of the render pixel whose sample
    /// lies nearest it (by depth: no light or colour carried across a
    /// silhouette, nor between a light and a wall); that pixel alone where
    /// no tap is.
    #[inline]
    fn interpolated(&self, ox: usize, oy: usize) -> Vec3 {
        let here = self.nearest(ox, oy);
        self.interpolated_on(ox, oy, here[3])
            .unwrap_or(Vec3::new(here[0], here[1], here[2]))
    }

    /// The bilinear interpolation of the frame at the output pixel's
    /// centre over the taps at depth `d` (0: no surface), `None` where no
    /// tap is.
    #[inline]
    fn interpolated_on(&self, ox: usize, oy: usize, d: f32) -> Option<Vec3> {
        let (x0, x1, fx) = self.ax.taps[ox];
        let (y0, y1, fy) = self.ay.taps[oy];
        // In four lanes (the fourth, a depth, is summed and dropped): one
        // division instead of three.
        let (mut sum, mut wsum) = (Vec4::ZERO, 0.0f32);
        for (x, y, wt) in [
            (x0, y0, (1.0 - fx) * (1.0 - fy)),
            (x1, y0, fx * (1.0 - fy)),
            (x0, y1, (1.0 - fx) * fy),
            (x1, y1, fx * fy),
        ] {
            let q = Vec4::from_array(self.px[y as usize * self.rw + x as usize]);
            // A weight of 0 off the surface instead of a branch.
            let wt = if same_depth(d, q.w, self.tolerance) {
                wt
            } else {
                0.0
            };
            sum += q * wt;
            wsum += wt;
        }
        (wsum > 1e-6).then(|| (sum / wsum).truncate())
    }

    /// Where the camera ray through an output pixel's centre found `e`
    /// and its nearest render pixel is on the other side of a surface's
    /// edge (one shows a surface, the other none): what the pixel shows
    /// instead (the light's or background's radiance without a surface,
    /// else the interpolation over the taps on the ray's surface, or the
    /// nearest render pixel where none is); `None` where both show a
    /// surface or both none.
    #[inline]
    fn at_edge(&self, oy: usize, ow: usize, e: &EdgeHit) -> Option<(usize, Vec3)> {
        let ox = e.index as usize - oy * ow;
        let here = self.nearest(ox, oy);
        if (here[3] > 0.0) == (e.depth > 0.0) {
            return None;
        }
        let c = if e.depth > 0.0 {
            self.interpolated_on(ox, oy, e.depth)
                .unwrap_or(Vec3::new(here[0], here[1], here[2]))
        } else {
            sanitize(e.emission)
        };
        Some((ox, c))
    }
}

/// Whether depths `a` and `b` (0: no surface) show one surface: both none,
/// or both surfaces within the relative `tolerance` of `a`.
#[inline(always)]
fn same_depth(a: f32, b: f32, tolerance: f32) -> bool {
    // `&` and `|`, not branches: with `a` 0 the second test fails for any
    // `b` (`|b| <= 0` with `b > 0`), with `a` above 0 the first does.
    ((a == 0.0) & (b == 0.0)) | ((b > 0.0) & ((b - a).abs() <= tolerance * a))
}

/// A depth as the surface tests read it: 0 for no surface (or a value
/// that is not a depth).
#[inline(always)]
fn surface_depth(d: f32) -> f32 {
    if d.is_finite() && d > 0.0 { d } else { 0.0 }
}

/// What an output row's pixels with no sample (length 0) show.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RowState {
    /// Nothing yet (after a reset): they need the interpolated frame.
    Empty,
    /// The interpolated frame of an earlier frame of this still view (a
    /// placeholder until a sample lands; not refreshed, which would cost a
    /// pass over the row each frame for pixels about to be replaced).
    Filled,
    /// Every pixel holds a sample.
    Complete,
}

/// A still camera's output row, in place: each pixel averages the sample
/// that landed in it, if any, into its own history. Pixels with no sample
/// yet show the interpolated frame. Returns whether the row may have
/// changed.
fn still_row(
    frame: &Current,
    blend: &Blend,
    oy: usize,
    texels: &mut [Texel],
    state: &mut RowState,
    edges: &[EdgeHit],
) -> bool {
    let ky = frame.ay.sample[oy];
    let changed = ky != NONE || *state == RowState::Empty;
    if ky != NONE {
        for (ox, t) in texels.iter_mut().enumerate() {
            let (c, w) = frame.sample(ky, ox);
            *t = blend.apply(*t, c, w);
        }
    }
    *state = match *state {
        RowState::Empty if fill_empty(frame, oy, texels) => RowState::Complete,
        RowState::Empty => RowState::Filled,
        RowState::Filled if ky != NONE && texels.iter().all(|t| t[3] > 0.0) => RowState::Complete,
        other => other,
    };
    // A placeholder on the wrong side of an edge: the ray's surface
    // instead (the samples, once they land, average both sides).
    if changed {
        let ow = texels.len();
        for e in edges {
            if let Some((ox, c)) = frame.at_edge(oy, ow, e)
                && texels[ox][3] <= 0.0
            {
                texels[ox] = [c.x, c.y, c.z, 0.0];
            }
        }
    }
    changed
}

/// Pixels with no sample show the interpolated frame (and keep length 0);
/// returns whether the row had none.
fn fill_empty(frame: &Current, oy: usize, texels: &mut [Texel]) -> bool {
    let mut complete = true;
    for (ox, t) in texels.iter_mut().enumerate() {
        if t[3] <= 0.0 {
            let c = frame.interpolated(ox, oy);
            *t = [c.x, c.y, c.z, 0.0];
            complete = false;
        }
    }
    complete
}

/// The last frame's render-size guides, for the next frame's history
/// test.
#[derive(Default)]
struct Witness {
    width: usize,
    height: usize,
    /// Its jitter, and where its render coordinates land on the output.
    jitter: Vec2,
    map: (Map, Map),
    depth: Vec<f32>,
    position: Vec<Vec3>,
    normal: Vec<Vec3>,
    /// Luminance of the analytic `U` and of its diffuse part.
    lu: Vec<(f32, f32)>,
}

impl Witness {
    fn keep(&mut self, g: &GuideBuffers, jitter: Vec2, map: (Map, Map)) {
        (self.width, self.height) = (g.width as usize, g.height as usize);
        self.jitter = jitter;
        self.map = map;
        self.depth.clear();
        self.depth.extend(g.depth.iter().map(|&d| surface_depth(d)));
        self.position.clear();
        self.position.extend_from_slice(g.position);
        self.normal.clear();
        self.normal.extend_from_slice(g.normal);
        self.lu.clear();
        self.lu.extend((0..g.u.len()).map(|i| light_of(g, i)));
    }

    /// The render pixel of the last frame whose sample lay nearest `at`
    /// (output pixels); `None` before any frame.
    #[inline(always)]
    fn nearest(&self, at: Vec2) -> Option<usize> {
        if self.depth.is_empty() {
            return None;
        }
        let r =
            Vec2::new(self.map.0.to_render(at.x), self.map.1.to_render(at.y)) - self.jitter + 0.5;
        let x = r.x.max(0.0).min((self.width - 1) as f32) as usize;
        let y = r.y.max(0.0).min((self.height - 1) as f32) as usize;
        Some(y * self.width + x)
    }
}

/// Where the output pixels nearest one render pixel find their history:
/// they share its motion `d` (output pixels), so an output pixel `o` reads
/// the last output bilinearly at `o + d`, whose taps start at `o + (dx,
/// dy)` with the weights `w` of the fraction of `d`, the same for all of
/// them; and the range `lo..hi` their history is clamped to (the colour's
/// 3x3 range, then the length's cap in the fourth lane). `keep` false: no
/// history (disoccluded, another light, or a motion that is not finite or
/// leaves the frame far behind). `inv_all` is `1 / (w0 + w1 + w2 + w3)`
/// summed as the taps add up, what a pixel whose four taps all hold
/// samples (most) divides by. One 64-byte record: the output pixels of a
/// run read one cache line.
#[derive(Clone, Copy, Debug)]
struct Reproject {
    w: Vec4,
    lo: Vec4,
    hi: Vec4,
    inv_all: f32,
    dx: i32,
    dy: i32,
    keep: bool,
}

impl Reproject {
    const NONE: Reproject = Reproject {
        w: Vec4::ZERO,
        lo: Vec4::ZERO,
        hi: Vec4::ZERO,
        inv_all: 0.0,
        dx: 0,
        dy: 0,
        keep: false,
    };

    /// The taps of a motion `d` in output pixels, the colour unclamped
    /// (but for the sanitised colours' floor, 0) and the length capped at
    /// `cap`.
    fn of(d: Vec2, cap: f32) -> Reproject {
        if !(d.is_finite() && d.x.abs() <= 1e6 && d.y.abs() <= 1e6) {
            return Reproject::NONE;
        }
        let f = d.floor();
        let (fx, fy) = (d.x - f.x, d.y - f.y);
        let w = Vec4::new(
            (1.0 - fx) * (1.0 - fy),
            fx * (1.0 - fy),
            (1.0 - fx) * fy,
            fx * fy,
        );
        Reproject {
            w,
            lo: Vec3::ZERO.extend(f32::MIN),
            hi: Vec3::splat(f32::MAX).extend(cap),
            inv_all: 1.0 / (0.0 + w.x + w.y + w.z + w.w),
            dx: f.x as i32,
            dy: f.y as i32,
            keep: true,
        }
    }
}

/// What a moving camera's output pass reads besides the frame.
struct Moved<'a> {
    motion: &'a [Reproject],
    prev: &'a [Texel],
    size: (usize, usize),
}

/// One output row of a moving camera's pass, without its rims
/// (`Moved::pixels`), as a `Kernel` (`isa`).
struct MovedRow<'a, 'f> {
    moved: &'a Moved<'a>,
    frame: &'a Current<'f>,
    blend: &'a Blend,
    oy: usize,
    texels: &'a mut [Texel],
}

impl Kernel for MovedRow<'_, '_> {
    type Out = bool;
    #[inline(always)]
    fn run(self) -> bool {
        self.moved
            .pixels(self.frame, self.blend, self.oy, self.texels)
    }
}

impl Moved<'_> {
    /// One output row from the reprojected history; returns whether every
    /// pixel of it holds a sample.
    fn row(
        &self,
        frame: &Current,
        blend: &Blend,
        oy: usize,
        texels: &mut [Texel],
        edges: &[EdgeHit],
    ) -> bool {
        let mut complete = isa::run(MovedRow {
            moved: self,
            frame,
            blend,
            oy,
            texels,
        });
        // Where the nearest render pixel is on the other side of an edge
        // from the pixel's own ray, its history and clamp range are that
        // side's: the pixel starts again from its ray's side, and keeps this
        // frame's sample if it landed on that side.
        let ky = frame.ay.sample[oy];
        let ow = texels.len();
        for e in edges {
            let Some((ox, c)) = frame.at_edge(oy, ow, e) else {
                continue;
            };
            let mut t = [c.x, c.y, c.z, 0.0];
            if let Some(p) = frame.sample_px(ky, ox)
                && (p[3] > 0.0) == (e.depth > 0.0)
            {
                t = blend.apply(t, Vec3::new(p[0], p[1], p[2]), 1.0);
            }
            complete &= t[3] > 0.0;
            texels[ox] = t;
        }
        complete
    }

    /// The row's pixels: each reads the record of its nearest render pixel
    /// (a run of output pixels shares one) and the sample landing in it.
    #[inline(always)]
    fn pixels(&self, frame: &Current, blend: &Blend, oy: usize, texels: &mut [Texel]) -> bool {
        let rw = frame.rw;
        let ky = frame.ay.sample[oy];
        let iy = frame.ay.nearest[oy] as usize;
        let steps = &self.motion[iy * rw..(iy + 1) * rw];
        // The render row whose samples land in this output row (none: no
        // pixel of the row takes a sample this frame).
        let samples = if ky == NONE {
            &[][..]
        } else {
            &frame.px[ky as usize * rw..(ky as usize + 1) * rw]
        };
        let mut complete = true;
        for (ox, ((t, &nx), &kx)) in texels
            .iter_mut()
            .zip(&frame.ax.nearest)
            .zip(&frame.ax.sample)
            .enumerate()
        {
            let m = &steps[nx as usize];
            let (c, w) = match samples.get(kx as usize) {
                Some(p) => (Vec3::new(p[0], p[1], p[2]), 1.0),
                None => (Vec3::ZERO, 0.0),
            };
            let hist = if m.keep {
                self.reprojected(ox as i64 + m.dx as i64, oy as i64 + m.dy as i64, m)
            } else {
                None
            };
            *t = match hist {
                // Without a sample the history stands as clamped (the
                // blend's weight is 0): most pixels at a small scale.
                Some(h) if w > 0.0 => blend.apply(h.max(m.lo).min(m.hi).to_array(), c, w),
                Some(h) => h.max(m.lo).min(m.hi).to_array(),
                None if w > 0.0 => [c.x, c.y, c.z, 1.0],
                None => {
                    complete = false;
                    let c = frame.interpolated(ox, oy);
                    [c.x, c.y, c.z, 0.0]
                }
            };
        }
        complete
    }

    /// The previous output's texels at `(x, y)`, `(x + 1, y)`, `(x, y + 1)`
    /// and `(x + 1, y + 1)` with the weights `m.w`, over the taps on the
    /// output that hold samples; `None` where none does.
    #[inline(always)]
    fn reprojected(&self, x: i64, y: i64, m: &Reproject) -> Option<Vec4> {
        let (ow, oh, w) = (self.size.0 as i64, self.size.1 as i64, m.w);
        let (mut wsum, mut sum) = (0.0f32, Vec4::ZERO);
        let mut tap = |h: &Texel, wt: f32| {
            let h = Vec4::from_array(*h);
            // A weight of 0 for an empty tap instead of a branch.
            let wt = if h.w > 0.0 { wt } else { 0.0 };
            wsum += wt;
            sum += h * wt;
        };
        if x >= 0 && y >= 0 && x + 1 < ow && y + 1 < oh {
            // Inside the output: the four taps, two pairs side by side.
            let j = (y * ow + x) as usize;
            let ow = ow as usize;
            let (top, bottom) = (&self.prev[j..j + 2], &self.prev[j + ow..j + ow + 2]);
            if top[0][3] > 0.0 && top[1][3] > 0.0 && bottom[0][3] > 0.0 && bottom[1][3] > 0.0 {
                // The sums below with every weight kept, and the record's
                // division: the same bits.
                let sum = Vec4::ZERO
                    + Vec4::from_array(top[0]) * w.x
                    + Vec4::from_array(top[1]) * w.y
                    + Vec4::from_array(bottom[0]) * w.z
                    + Vec4::from_array(bottom[1]) * w.w;
                return Some(sum * m.inv_all);
            }
            tap(&top[0], w.x);
            tap(&top[1], w.y);
            tap(&bottom[0], w.z);
            tap(&bottom[1], w.w);
        } else {
            for (k, wt) in w.to_array().into_iter().enumerate() {
                let (tx, ty) = (x + (k & 1) as i64, y + (k >> 1) as i64);
                if wt > 0.0 && tx >= 0 && ty >= 0 && tx < ow && ty < oh {
                    tap(&self.prev[(ty * ow + tx) as usize], wt);
                }
            }
        }
        if wsum < 1e-3 {
            return None;
        }
        Some(sum * (1.0 / wsum))
    }
}

/// Whether the history at `at` (output pixels, last frame) shows the
/// surface and light of render pixel `i`: its witness passes the
/// denoiser's disocclusion test and shows the same light (`light_changed`,
/// as the full-size resolve tests it).
#[inline]
fn same(g: &GuideBuffers, w: &Witness, s: &DenoiseSettings, i: usize, at: Vec2) -> bool {
    let Some(j) = w.nearest(at) else {
        return false;
    };
    let (d, dj) = (g.depth[i], w.depth[j]);
    let n = g.normal[i];
    let surface = dj > 0.0
        && (dj - d).abs() <= s.depth_tolerance * d
        && n.dot(w.position[j] - g.position[i]).abs() <= s.plane_tolerance * d
        && w.normal[j].dot(n) >= s.min_normal_dot;
    surface && !(s.light_test && light_changed(light_of(g, i), w.lu[j], s.u_change))
}

/// Luminance of render pixel `i`'s analytic `U` and of its diffuse part:
/// the light test's witnesses (the diffuse part, where it carries a fair
/// share, does not change when only the camera moves).
#[inline]
fn light_of(g: &GuideBuffers, i: usize) -> (f32, f32) {
    let lu = luminance(g.u[i]);
    let lu = if lu.is_finite() { lu.max(0.0) } else { 0.0 };
    let share = g.lobe.get(i).map_or(0.0, |l| l.share);
    (lu, lu * (1.0 - share))
}

//! Temporal resolve (TAA): a stage after the composite, separate from the
//! denoiser. It averages one signal over jittered frames: the colour, or
//! the noise-free factor of the colour that no earlier stage has averaged
//! (the renderer decides; see `render::frame`).
//!
//! Every frame's camera rays go through one sub-pixel offset of a
//! low-discrepancy sequence (`sampling::sequence::frame_jitter`); this stage
//! averages the frames. For a still camera the blend is 1/n with n the
//! history length, so n frames are the exact mean of n jittered frames: the
//! box filter over the pixel that `reference` computes. When the camera moves,
//! the history is reprojected with the unjittered motion vectors (bilinear,
//! each tap checked with the denoiser's own disocclusion test), dropped where
//! the light changed (the denoiser's `U` test), clamped to the range of the
//! current frame's 3x3 neighbourhood (no ghost trails) and capped short
//! (bilinear resampling every frame would blur a long history).
//!
//! The composite itself is untouched: per frame it is still
//! `U · dn(S_N) / dn(U_N)` with one set of weights; this stage only averages
//! finished frames.

use super::history::{Meta, encode_normal};
use super::{DenoiseSettings, GuideBuffers, luminance};
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// Knobs of the resolve. `Default` gives the tuned values.
#[derive(Clone, Debug)]
pub struct ResolveSettings {
    /// History cap while the camera is still: up to this many jittered
    /// frames are averaged with equal weights.
    pub max_history_still: u16,
    /// History cap while the camera moves: the blend factor never drops below
    /// 1/this, so resampling blur and what the clamp lets through fade fast.
    pub max_history_moving: u16,
    /// Clamp the reprojected colour to the current 3x3 neighbourhood's range
    /// when the camera moves.
    pub clamp: bool,
}

impl Default for ResolveSettings {
    fn default() -> Self {
        ResolveSettings {
            max_history_still: 64,
            max_history_moving: 8,
            clamp: true,
        }
    }
}

/// What a reprojection tap reads of a previous pixel besides its signals,
/// packed so that one tap touches one small record.
#[derive(Clone, Copy, Debug, Default)]
struct Record {
    pos: Vec3,
    /// The normal as the denoiser's 16-bit octahedral history record gives
    /// it back (so both histories reject the same taps), decoded once when
    /// written instead of once per tap; not normalised.
    normal: Vec3,
    /// `normal.length_squared()`, for the angle test without a square root.
    normal_len2: f32,
    /// 0: no surface, the pixel has no history to give.
    depth: f32,
    /// Luminance of the analytic `U`, and of its diffuse part.
    lu: f32,
    lu_diffuse: f32,
    /// Frames accumulated (capped); fractional after bilinear reprojection.
    len: f32,
}

/// One frame of the resolved signals and what the next frame needs to
/// validate them.
struct ColorHistory {
    /// The noise-free factor of the colour (see `resolve`).
    factor: Vec<Vec3>,
    color: Vec<Vec3>,
    record: Vec<Record>,
    /// The history holds more than one surface (the jitter crossed an edge).
    mixed: Vec<bool>,
}

impl ColorHistory {
    fn new(n: usize) -> ColorHistory {
        ColorHistory {
            factor: vec![Vec3::ZERO; n],
            color: vec![Vec3::ZERO; n],
            record: vec![Record::default(); n],
            mixed: vec![false; n],
        }
    }
}

/// Channels of the two signals as planes: factor r, g, b, colour r, g, b.
const CHANNELS: usize = 6;

/// Resolve state: the previous resolved frame, the one being written, and
/// this frame's inputs (sanitised) as planes for the neighbourhood clamp.
pub struct Resolve {
    width: u32,
    height: u32,
    prev: ColorHistory,
    cur: ColorHistory,
    now: [Vec<f32>; CHANNELS],
}

/// How the camera moved since the previous frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMotion {
    /// Same camera (and lights): every pixel's history is its own.
    Still,
    /// Reproject along the motion vectors.
    Moved,
}

impl Resolve {
    pub fn new(width: u32, height: u32) -> Resolve {
        let n = width as usize * height as usize;
        Resolve {
            width,
            height,
            prev: ColorHistory::new(n),
            cur: ColorHistory::new(n),
            now: std::array::from_fn(|_| vec![0.0; n]),
        }
    }

    /// Forgets the history: the next frame stands alone.
    pub fn reset(&mut self) {
        for h in [&mut self.prev, &mut self.cur] {
            h.record.fill(Record::default());
            h.mixed.fill(false);
        }
    }

    /// Frames averaged per pixel after the last call (0 before any).
    pub fn history_len(&self) -> Vec<f32> {
        self.prev.record.iter().map(|m| m.len).collect()
    }

    /// Per pixel after the last call: whether its history holds more than
    /// one surface (the jitter or the motion crossed a geometric edge), so
    /// the resolved factor does not belong to this frame's surface alone.
    pub fn mixed(&self) -> &[bool] {
        &self.prev.mixed
    }

    /// Replaces `factor` and `color` by their temporal resolves, with the
    /// same weights. `factor` is the noise-free per-frame part of the colour
    /// (the renderer multiplies it by what its denoiser already averaged),
    /// `color` the whole frame, for the pixels whose history is
    /// [`mixed`](Self::mixed). `surface` holds the disocclusion and
    /// light-change tolerances of the denoiser's history, so both histories
    /// are dropped at the same places. A size change drops the history.
    ///
    /// Two passes over rows: the inputs sanitised into planes, then per
    /// chunk of a row the history taps (per pixel: gathers), the 3x3
    /// bounds (separable min/max over the planes) and the clamp and blend
    /// (lanes).
    pub fn resolve(
        &mut self,
        guide: &GuideBuffers,
        (factor, color): (&mut [Vec3], &mut [Vec3]),
        motion: CameraMotion,
        settings: &ResolveSettings,
        surface: &DenoiseSettings,
    ) {
        let (w, h) = (guide.width as usize, guide.height as usize);
        let n = w * h;
        assert!(
            color.len() == n
                && factor.len() == n
                && guide.depth.len() == n
                && guide.position.len() == n
                && guide.normal.len() == n
                && guide.prev_pixel.len() == n
                && guide.prev_valid.len() == n
                && guide.u.len() == n,
            "resolve: every buffer must hold width * height pixels"
        );
        if guide.width != self.width || guide.height != self.height {
            *self = Resolve::new(guide.width, guide.height);
        }
        if n == 0 {
            return;
        }
        {
            let [fr, fg, fb, cr, cg, cb] = &mut self.now;
            (
                (
                    fr.par_chunks_mut(w),
                    fg.par_chunks_mut(w),
                    fb.par_chunks_mut(w),
                ),
                (
                    cr.par_chunks_mut(w),
                    cg.par_chunks_mut(w),
                    cb.par_chunks_mut(w),
                ),
                factor.par_chunks(w),
                color.par_chunks(w),
            )
                .into_par_iter()
                .for_each(|((fr, fg, fb), (cr, cg, cb), f, c)| {
                    isa::run(Sanitize {
                        src: f,
                        dst: [fr, fg, fb],
                    });
                    isa::run(Sanitize {
                        src: c,
                        dst: [cr, cg, cb],
                    });
                });
        }
        let cap = match motion {
            CameraMotion::Still => settings.max_history_still,
            CameraMotion::Moved => settings.max_history_moving,
        }
        .max(1) as f32;
        let ctx = Context {
            w,
            h,
            guide,
            now: &self.now,
            prev: &self.prev,
            motion,
            cap,
            clamp: settings.clamp && motion == CameraMotion::Moved,
            s: surface,
        };
        let cur = &mut self.cur;
        (
            cur.factor.par_chunks_mut(w * BAND),
            cur.color.par_chunks_mut(w * BAND),
            cur.record.par_chunks_mut(w * BAND),
            cur.mixed.par_chunks_mut(w * BAND),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(band, (factor, color, record, mixed))| {
                isa::run(Row {
                    ctx: &ctx,
                    y0: band * BAND,
                    out: (factor, color, record, mixed),
                })
            });
        factor.copy_from_slice(&self.cur.factor);
        color.copy_from_slice(&self.cur.color);
        std::mem::swap(&mut self.prev, &mut self.cur);
    }
}

/// `c` with its channels negative or non-finite made 0 (a non-finite
/// channel zeroes the whole pixel), one row into planes.
struct Sanitize<'a> {
    src: &'a [Vec3],
    dst: [&'a mut [f32]; 3],
}

impl Kernel for Sanitize<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let [r, g, b] = self.dst;
        let n = self.src.len().min(r.len()).min(g.len()).min(b.len());
        for x in 0..n {
            let v = self.src[x];
            let ok = v.x.is_finite() & v.y.is_finite() & v.z.is_finite();
            r[x] = if ok & (v.x > 0.0) { v.x } else { 0.0 };
            g[x] = if ok & (v.y > 0.0) { v.y } else { 0.0 };
            b[x] = if ok & (v.z > 0.0) { v.z } else { 0.0 };
        }
    }
}

/// What every row of one call shares.
struct Context<'a> {
    w: usize,
    h: usize,
    guide: &'a GuideBuffers<'a>,
    now: &'a [Vec<f32>; CHANNELS],
    prev: &'a ColorHistory,
    motion: CameraMotion,
    cap: f32,
    /// The reprojected history is clamped to the 3x3 bounds.
    clamp: bool,
    s: &'a DenoiseSettings,
}

/// Pixels a row is processed in at once: the lanes' scratch lives on the
/// stack, so nothing is allocated per frame.
const CHUNK: usize = 64;

const ZERO: [f32; CHUNK] = [0.0; CHUNK];

/// Rows a parallel job resolves (sharing one scratch).
const BAND: usize = 4;

/// Rows `y0 ..` of the resolve (`out` holds whole rows).
struct Row<'a, 'b> {
    ctx: &'b Context<'a>,
    y0: usize,
    out: (
        &'b mut [Vec3],
        &'b mut [Vec3],
        &'b mut [Record],
        &'b mut [bool],
    ),
}

/// A chunk's pixels of this frame as lanes (padding lanes: no surface).
struct Here {
    live: [bool; CHUNK],
    depth: [f32; CHUNK],
    pos: [[f32; CHUNK]; 3],
    normal: [[f32; CHUNK]; 3],
    lu: [f32; CHUNK],
    lu_diffuse: [f32; CHUNK],
    share: [f32; CHUNK],
}

/// A chunk's histories as lanes: channels as `now`, frames, mixed. No
/// history is all zeros: its blend weight is then 1 and the blend gives the
/// current value exactly.
struct Hist {
    sig: [[f32; CHUNK]; CHANNELS],
    len: [f32; CHUNK],
    mixed: [bool; CHUNK],
}

/// One history tap of every lane of a chunk, gathered from the previous
/// frame's records into lanes, so that its test and its sums vectorise.
struct Tap {
    pos: [[f32; CHUNK]; 3],
    normal: [[f32; CHUNK]; 3],
    normal_len2: [f32; CHUNK],
    depth: [f32; CHUNK],
    lu: [f32; CHUNK],
    lu_diffuse: [f32; CHUNK],
    len: [f32; CHUNK],
    sig: [[f32; CHUNK]; CHANNELS],
    mixed: [bool; CHUNK],
}

/// The bilinear footprint of each lane's motion vector and the sums over
/// its taps.
struct Footprint {
    eligible: [bool; CHUNK],
    x0: [i32; CHUNK],
    y0: [i32; CHUNK],
    wt: [[f32; CHUNK]; 4],
    j: [u32; CHUNK],
    inside: [bool; CHUNK],
    wsum: [f32; CHUNK],
    lu: [f32; CHUNK],
    lu_diffuse: [f32; CHUNK],
}

/// Everything a row's chunks work in, set up once a row: each chunk
/// writes every field it reads.
struct Scratch {
    here: Here,
    hist: Hist,
    tap: Tap,
    foot: Footprint,
    len: [f32; CHUNK],
    blend: [f32; CHUNK],
    clamped: [bool; CHUNK],
    /// Per channel the blended result.
    res: [[f32; CHUNK]; CHANNELS],
    /// Column min/max of three rows (column x0 - 1 + k at index k), then
    /// the 3x3 bounds.
    cmin: [f32; CHUNK + 2],
    cmax: [f32; CHUNK + 2],
    lo: [f32; CHUNK],
    hi: [f32; CHUNK],
    /// The normal as the history record keeps it, and its squared length.
    oct: [[f32; CHUNK]; 3],
    oct_len2: [f32; CHUNK],
}

impl Scratch {
    fn new() -> Scratch {
        Scratch {
            here: Here {
                live: [false; CHUNK],
                depth: ZERO,
                pos: [ZERO; 3],
                normal: [ZERO; 3],
                lu: ZERO,
                lu_diffuse: ZERO,
                share: ZERO,
            },
            hist: Hist {
                sig: [ZERO; CHANNELS],
                len: ZERO,
                mixed: [false; CHUNK],
            },
            tap: Tap {
                pos: [ZERO; 3],
                normal: [ZERO; 3],
                normal_len2: ZERO,
                depth: ZERO,
                lu: ZERO,
                lu_diffuse: ZERO,
                len: ZERO,
                sig: [ZERO; CHANNELS],
                mixed: [false; CHUNK],
            },
            foot: Footprint {
                eligible: [false; CHUNK],
                x0: [0; CHUNK],
                y0: [0; CHUNK],
                wt: [ZERO; 4],
                j: [0; CHUNK],
                inside: [false; CHUNK],
                wsum: ZERO,
                lu: ZERO,
                lu_diffuse: ZERO,
            },
            len: ZERO,
            blend: ZERO,
            clamped: [false; CHUNK],
            res: [ZERO; CHANNELS],
            cmin: [0.0; CHUNK + 2],
            cmax: [0.0; CHUNK + 2],
            lo: ZERO,
            hi: ZERO,
            oct: [ZERO; 3],
            oct_len2: ZERO,
        }
    }
}

/// The tap test's tolerances, with what is uniform over a call hoisted.
#[derive(Clone, Copy)]
struct Tolerance {
    depth: f32,
    plane: f32,
    min_dot: f32,
    min_dot2: f32,
}

impl Tolerance {
    fn of(s: &DenoiseSettings) -> Tolerance {
        Tolerance {
            depth: s.depth_tolerance,
            plane: s.plane_tolerance,
            min_dot: s.min_normal_dot,
            min_dot2: s.min_normal_dot * s.min_normal_dot,
        }
    }
}

impl Kernel for Row<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let Row {
            ctx,
            y0,
            out: (band_f, band_c, band_rec, band_mixed),
        } = self;
        let (w, h) = (ctx.w, ctx.h);
        // On the stack, one a band: LLVM keeps its arrays apart from every
        // frame buffer, which a borrowed scratch would not tell it.
        let mut scratch = Scratch::new();
        let sc = &mut scratch;
        let rows = band_f.len() / w;
        for r in 0..rows {
            let (y, span) = (y0 + r, r * w..(r + 1) * w);
            let row = y * w;
            let (out_f, out_c) = (&mut band_f[span.clone()], &mut band_c[span.clone()]);
            let (out_rec, out_mixed) = (&mut band_rec[span.clone()], &mut band_mixed[span]);
            for x0 in (0..w).step_by(CHUNK) {
                let n = CHUNK.min(w - x0);
                here(ctx.guide, row + x0, n, &mut sc.here);
                match ctx.motion {
                    CameraMotion::Still => still_history(ctx, row + x0, sc),
                    CameraMotion::Moved => reprojected(ctx, row + x0, sc),
                }
                blend_weights(
                    &sc.hist,
                    (ctx.cap, ctx.clamp),
                    &mut sc.len,
                    &mut sc.blend,
                    &mut sc.clamped,
                );
                let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
                for (ch, plane) in ctx.now.iter().enumerate() {
                    if ctx.clamp {
                        bounds(
                            plane,
                            w,
                            (ya, y, yb),
                            (x0, n),
                            (&mut sc.cmin, &mut sc.cmax),
                            (&mut sc.lo, &mut sc.hi),
                        );
                    }
                    clamp_blend(
                        &sc.hist.sig[ch],
                        &plane[row + x0..row + x0 + n],
                        (&sc.lo, &sc.hi, &sc.clamped),
                        &sc.blend,
                        &mut sc.res[ch],
                    );
                }
                octahedral_lanes(&sc.here.normal, &mut sc.oct, &mut sc.oct_len2);
                let (p, res) = (&sc.here, &sc.res);
                for (k, x) in (x0..x0 + n).enumerate() {
                    out_f[x] = Vec3::new(res[0][k], res[1][k], res[2][k]);
                    out_c[x] = Vec3::new(res[3][k], res[4][k], res[5][k]);
                    out_rec[x] = Record {
                        pos: Vec3::new(p.pos[0][k], p.pos[1][k], p.pos[2][k]),
                        normal: Vec3::new(sc.oct[0][k], sc.oct[1][k], sc.oct[2][k]),
                        normal_len2: sc.oct_len2[k],
                        depth: p.depth[k],
                        lu: p.lu[k],
                        lu_diffuse: p.lu_diffuse[k],
                        len: sc.len[k],
                    };
                    out_mixed[x] = sc.hist.mixed[k];
                }
            }
        }
    }
}

// The lane loops below take each array they touch as its own reference
// argument: inlined, they keep the no-alias facts that let LLVM vectorise
// them, which borrows of fields of one scratch struct do not carry.

/// Blend weight 1/len per pixel (shared by the six channels), the capped
/// history length, and which histories are clamped.
#[inline(always)]
fn blend_weights(
    hist: &Hist,
    (cap, clamp): (f32, bool),
    len: &mut [f32; CHUNK],
    blend: &mut [f32; CHUNK],
    clamped: &mut [bool; CHUNK],
) {
    for k in 0..CHUNK {
        let l = hist.len[k] + 1.0;
        len[k] = if l < cap { l } else { cap };
        blend[k] = 1.0 / len[k];
        clamped[k] = clamp & (hist.len[k] > 0.0);
    }
}

/// One channel: the history clamped where asked, blended toward `cur`.
#[inline(always)]
fn clamp_blend(
    sig: &[f32; CHUNK],
    cur: &[f32],
    (lo, hi, clamped): (&[f32; CHUNK], &[f32; CHUNK], &[bool; CHUNK]),
    blend: &[f32; CHUNK],
    out: &mut [f32; CHUNK],
) {
    let n = cur.len().min(CHUNK);
    for k in 0..n {
        let v = sig[k];
        let t = if v < lo[k] { lo[k] } else { v };
        let t = if t > hi[k] { hi[k] } else { t };
        let v = if clamped[k] { t } else { v };
        out[k] = v + (cur[k] - v) * blend[k];
    }
}

/// [`octahedral`] of every lane, and the squared length.
#[inline(always)]
fn octahedral_lanes(
    normal: &[[f32; CHUNK]; 3],
    oct: &mut [[f32; CHUNK]; 3],
    len2: &mut [f32; CHUNK],
) {
    for k in 0..CHUNK {
        let v = octahedral(Vec3::new(normal[0][k], normal[1][k], normal[2][k]));
        [oct[0][k], oct[1][k], oct[2][k]] = v.to_array();
        len2[k] = v.length_squared();
    }
}

/// This frame's pixels `i0 .. i0 + n` as lanes.
#[inline(always)]
fn here(guide: &GuideBuffers, i0: usize, n: usize, p: &mut Here) {
    let (depth, u) = (&guide.depth[i0..i0 + n], &guide.u[i0..i0 + n]);
    let (pos, normal) = (&guide.position[i0..i0 + n], &guide.normal[i0..i0 + n]);
    match guide.lobe.get(i0..i0 + n) {
        Some(lobe) => {
            for (s, l) in p.share.iter_mut().zip(lobe) {
                *s = l.share;
            }
        }
        None => p.share[..n].fill(0.0),
    }
    for k in 0..n {
        p.live[k] = true;
        let d = depth[k];
        p.depth[k] = if (d > 0.0) & d.is_finite() { d } else { 0.0 };
        let lu = luminance(u[k]);
        p.lu[k] = if lu.is_finite() & (lu > 0.0) { lu } else { 0.0 };
        [p.pos[0][k], p.pos[1][k], p.pos[2][k]] = pos[k].to_array();
        [p.normal[0][k], p.normal[1][k], p.normal[2][k]] = normal[k].to_array();
    }
    for k in n..CHUNK {
        p.live[k] = false;
        p.depth[k] = 0.0;
        p.lu[k] = 0.0;
        p.share[k] = 0.0;
        for c in 0..3 {
            p.pos[c][k] = 0.0;
            p.normal[c][k] = 0.0;
        }
    }
    for k in 0..CHUNK {
        p.lu_diffuse[k] = p.lu[k] * (1.0 - p.share[k]);
    }
}

impl Tap {
    /// The previous frame's pixel `j[k]` (clamped into the frame) in lane `k`.
    #[inline(always)]
    fn gather(&mut self, prev: &ColorHistory, j: &[u32; CHUNK]) {
        let t = self;
        // Indices clamped to `last` and arrays sliced to `last + 1`: no
        // bounds checks in the loop.
        let last = prev.record.len() - 1;
        let (record, factor, color, mixed) = (
            &prev.record[..=last],
            &prev.factor[..=last],
            &prev.color[..=last],
            &prev.mixed[..=last],
        );
        for (k, &j) in j.iter().enumerate() {
            let i = (j as usize).min(last);
            let m = &record[i];
            [t.pos[0][k], t.pos[1][k], t.pos[2][k]] = m.pos.to_array();
            [t.normal[0][k], t.normal[1][k], t.normal[2][k]] = m.normal.to_array();
            t.normal_len2[k] = m.normal_len2;
            t.depth[k] = m.depth;
            t.lu[k] = m.lu;
            t.lu_diffuse[k] = m.lu_diffuse;
            t.len[k] = m.len;
            [t.sig[0][k], t.sig[1][k], t.sig[2][k]] = factor[i].to_array();
            [t.sig[3][k], t.sig[4][k], t.sig[5][k]] = color[i].to_array();
            t.mixed[k] = mixed[i];
        }
    }

    /// The disocclusion test of the tap in lane `k` (the denoiser's): it
    /// holds the same surface as lane `k` of `p` (depth, tangent plane and
    /// normal agree) and has something accumulated.
    #[inline(always)]
    fn same_surface(&self, p: &Here, k: usize, t: Tolerance) -> bool {
        let d = p.depth[k];
        let n = [p.normal[0][k], p.normal[1][k], p.normal[2][k]];
        let m = [self.normal[0][k], self.normal[1][k], self.normal[2][k]];
        let dot = m[0] * n[0] + m[1] * n[1] + m[2] * n[2];
        let len2 = self.normal_len2[k];
        let facing = if t.min_dot >= 0.0 {
            (dot >= 0.0) & (dot * dot >= t.min_dot2 * len2)
        } else {
            dot >= t.min_dot * len2.sqrt()
        };
        let (ex, ey, ez) = (
            self.pos[0][k] - p.pos[0][k],
            self.pos[1][k] - p.pos[1][k],
            self.pos[2][k] - p.pos[2][k],
        );
        let plane = n[0] * ex + n[1] * ey + n[2] * ez;
        let md = self.depth[k];
        (md > 0.0)
            & ((md - d).abs() <= t.depth * d)
            & (plane.abs() <= t.plane * d)
            & (self.len[k] > 0.0)
            & facing
    }
}

/// A still camera's history: the pixel's own. Nothing is rejected: the
/// static scene cannot have disoccluded anything, a different surface than
/// last frame is the jitter sampling another part of the pixel (what the
/// average is for; the history is then marked mixed), and `U` differs
/// between frames for the same reason; the renderer drops the history when
/// the lights change.
#[inline(always)]
fn still_history(ctx: &Context, i0: usize, sc: &mut Scratch) {
    for (k, j) in sc.foot.j.iter_mut().enumerate() {
        *j = (i0 + k) as u32;
    }
    sc.tap.gather(ctx.prev, &sc.foot.j);
    take_own(&sc.here, &sc.tap, &mut sc.hist, Tolerance::of(ctx.s));
}

/// The pixel's own history as it is, marked mixed where it holds another
/// surface.
#[inline(always)]
fn take_own(p: &Here, tap: &Tap, hist: &mut Hist, t: Tolerance) {
    for k in 0..CHUNK {
        let take = p.live[k] & (tap.len[k] > 0.0);
        let same = if p.depth[k] > 0.0 {
            tap.same_surface(p, k, t)
        } else {
            tap.depth[k] <= 0.0
        };
        for ch in 0..CHANNELS {
            hist.sig[ch][k] = if take { tap.sig[ch][k] } else { 0.0 };
        }
        hist.len[k] = if take { tap.len[k] } else { 0.0 };
        hist.mixed[k] = take & (tap.mixed[k] | !same);
    }
}

/// Bilinear fetch of the previous resolve at the unjittered motion
/// vector's end (pixel centres at +0.5), each tap validated like the
/// denoiser's; none where disoccluded or the light changed. One set of
/// weights serves both signals; a tap that fails adds an exact zero, so
/// the sums are those of the taps that pass, in tap order (the first
/// tap's sums start from its own terms, which is 0 + them exactly).
#[inline(always)]
fn reprojected(ctx: &Context, i0: usize, sc: &mut Scratch) {
    let t = Tolerance::of(ctx.s);
    let m = (ctx.guide.prev_pixel.len() - i0).min(CHUNK);
    footprint(
        &sc.here,
        &ctx.guide.prev_pixel[i0..i0 + m],
        &ctx.guide.prev_valid[i0..i0 + m],
        &mut sc.foot.eligible,
        (&mut sc.foot.x0, &mut sc.foot.y0),
        &mut sc.foot.wt,
    );
    let (w, h) = (ctx.w as i32, ctx.h as i32);
    for n in 0..4 {
        tap_index(
            n,
            (w, h),
            (&sc.foot.x0, &sc.foot.y0),
            &mut sc.foot.inside,
            &mut sc.foot.j,
        );
        sc.tap.gather(ctx.prev, &sc.foot.j);
        accumulate(
            n == 0,
            &sc.here,
            &sc.tap,
            &sc.foot.eligible,
            &sc.foot.inside,
            &sc.foot.wt[n],
            t,
            &mut sc.foot.wsum,
            &mut sc.foot.lu,
            &mut sc.foot.lu_diffuse,
            &mut sc.hist,
        );
    }
    normalise(
        ctx.s,
        &sc.here,
        &sc.foot.eligible,
        (&sc.foot.wsum, &sc.foot.lu, &sc.foot.lu_diffuse),
        &mut sc.hist,
    );
}

/// Per lane whether it reprojects at all, its footprint's corner and the
/// four bilinear weights. Lanes past `mv` (the row's end) never do.
#[inline(always)]
fn footprint(
    p: &Here,
    mv: &[glam::Vec2],
    valid: &[bool],
    eligible: &mut [bool; CHUNK],
    (x0, y0): (&mut [i32; CHUNK], &mut [i32; CHUNK]),
    wt: &mut [[f32; CHUNK]; 4],
) {
    let m = mv.len().min(valid.len()).min(CHUNK);
    for k in 0..m {
        let (px, py) = (mv[k].x - 0.5, mv[k].y - 0.5);
        let finite = (px.abs() <= 1e9) & (py.abs() <= 1e9);
        eligible[k] = p.live[k] & valid[k] & finite & (p.depth[k] > 0.0);
        let (px, py) = if finite { (px, py) } else { (0.0, 0.0) };
        let (x, y) = (floor(px), floor(py));
        let (fx, fy) = (px - x as f32, py - y as f32);
        (x0[k], y0[k]) = (x, y);
        wt[0][k] = (1.0 - fx) * (1.0 - fy);
        wt[1][k] = fx * (1.0 - fy);
        wt[2][k] = (1.0 - fx) * fy;
        wt[3][k] = fx * fy;
    }
    for k in m..CHUNK {
        eligible[k] = false;
        (x0[k], y0[k]) = (0, 0);
        for wt in wt.iter_mut() {
            wt[k] = 0.0;
        }
    }
}

/// Tap `n` of each footprint (0: top left, then right, below, below
/// right): whether it lies inside the frame and its index (0 outside).
#[inline(always)]
fn tap_index(
    n: usize,
    (w, h): (i32, i32),
    (x0, y0): (&[i32; CHUNK], &[i32; CHUNK]),
    inside: &mut [bool; CHUNK],
    j: &mut [u32; CHUNK],
) {
    let (dx, dy) = ((n & 1) as i32, (n >> 1) as i32);
    for k in 0..CHUNK {
        let (tx, ty) = (x0[k] + dx, y0[k] + dy);
        inside[k] = (tx >= 0) & (ty >= 0) & (tx < w) & (ty < h);
        j[k] = if inside[k] { (ty * w + tx) as u32 } else { 0 };
    }
}

/// Adds one tap's weighted terms where it passes the test.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn accumulate(
    first: bool,
    p: &Here,
    tap: &Tap,
    eligible: &[bool; CHUNK],
    inside: &[bool; CHUNK],
    wt: &[f32; CHUNK],
    t: Tolerance,
    wsum: &mut [f32; CHUNK],
    lu: &mut [f32; CHUNK],
    lu_diffuse: &mut [f32; CHUNK],
    hist: &mut Hist,
) {
    let sum = |s: f32, v: f32| if first { v } else { s + v };
    for k in 0..CHUNK {
        let wt = wt[k];
        let ok = eligible[k] & inside[k] & (wt > 0.0) & tap.same_surface(p, k, t);
        let take = |v: f32| if ok { v * wt } else { 0.0 };
        wsum[k] = sum(wsum[k], if ok { wt } else { 0.0 });
        for ch in 0..CHANNELS {
            hist.sig[ch][k] = sum(hist.sig[ch][k], take(tap.sig[ch][k]));
        }
        hist.len[k] = sum(hist.len[k], take(tap.len[k]));
        lu[k] = sum(lu[k], take(tap.lu[k]));
        lu_diffuse[k] = sum(lu_diffuse[k], take(tap.lu_diffuse[k]));
        hist.mixed[k] = (!first & hist.mixed[k]) | (ok & tap.mixed[k]);
    }
}

/// The sums divided by the weight that passed; no history where too
/// little passed or the light changed.
#[inline(always)]
fn normalise(
    s: &DenoiseSettings,
    p: &Here,
    eligible: &[bool; CHUNK],
    (wsum, lu, lu_diffuse): (&[f32; CHUNK], &[f32; CHUNK], &[f32; CHUNK]),
    hist: &mut Hist,
) {
    for k in 0..CHUNK {
        let inv = 1.0 / wsum[k];
        let changed = s.light_test
            & light_changed(
                (p.lu[k], p.lu_diffuse[k]),
                (lu[k] * inv, lu_diffuse[k] * inv),
                s.u_change,
            );
        let take = eligible[k] & (wsum[k] >= 1e-3) & !changed;
        for ch in 0..CHANNELS {
            hist.sig[ch][k] = if take { hist.sig[ch][k] * inv } else { 0.0 };
        }
        hist.len[k] = if take { hist.len[k] * inv } else { 0.0 };
        hist.mixed[k] &= take;
    }
}

/// Below this diffuse share of `U` (in either frame) the diffuse part is too
/// small a witness, and the whole `U` is compared (the denoiser's test).
const MIN_DIFFUSE_SHARE: f32 = 0.02;

/// Whether the light at a surface point changed between two frames, as the
/// denoiser's history decides it: the diffuse part of `U` (which a camera
/// move cannot change) where it carries a fair share, else the whole `U`.
/// Arguments: luminance of `U` and of its diffuse part, now and before.
#[inline(always)]
fn light_changed(now: (f32, f32), before: (f32, f32), tolerance: f32) -> bool {
    let differ = |a: f32, b: f32| {
        let big = if a > b { a } else { b };
        (big > 1e-30) & ((a - b).abs() > tolerance * big)
    };
    let diffuse_witness =
        (now.1 >= MIN_DIFFUSE_SHARE * now.0) & (before.1 >= MIN_DIFFUSE_SHARE * before.0);
    if diffuse_witness {
        differ(now.1, before.1)
    } else {
        differ(now.0, before.0)
    }
}

/// Truncation toward zero of |v| < 2^22, exact, as +0 where an integer
/// would be 0: adding and removing 1.5 * 2^23 rounds |v| to an integer,
/// one less where that rounded up.
#[inline(always)]
fn trunc(v: f32) -> f32 {
    const ROUND: f32 = 12_582_912.0;
    let a = v.abs();
    let r = (a + ROUND) - ROUND;
    let r = if r > a { r - 1.0 } else { r };
    r.copysign(v) + 0.0
}

/// floor as an integer for |v| <= 1e9, without a libm call (baseline
/// x86-64 has no roundss).
#[inline(always)]
fn floor(v: f32) -> i32 {
    let t = v as i32;
    if (t as f32) > v { t - 1 } else { t }
}

/// Per pixel of columns `x0 .. x0 + n` of row `rows.1`, the minimum and
/// maximum of `plane` over its 3x3 neighbourhood (cut at the frame's
/// edges: an edge pixel standing in for the missing one changes neither),
/// into `sc.lo` and `sc.hi`: the rows' column min/max first, then across
/// three columns, so each value is read once per row and shared by the
/// three pixels above it.
#[inline(always)]
fn bounds(
    plane: &[f32],
    w: usize,
    (ya, y, yb): (usize, usize, usize),
    (x0, n): (usize, usize),
    (cmin, cmax): (&mut [f32; CHUNK + 2], &mut [f32; CHUNK + 2]),
    (lo, hi): (&mut [f32; CHUNK], &mut [f32; CHUNK]),
) {
    let (cs, ce) = (x0.saturating_sub(1), (x0 + n + 1).min(w));
    let off = cs + 1 - x0;
    let m = ce - cs;
    let (ra, rb, rc) = (
        &plane[ya * w + cs..ya * w + ce],
        &plane[y * w + cs..y * w + ce],
        &plane[yb * w + cs..yb * w + ce],
    );
    {
        let (cmin, cmax) = (&mut cmin[off..off + m], &mut cmax[off..off + m]);
        for k in 0..m {
            let (a, b, c) = (ra[k], rb[k], rc[k]);
            let lo = if a < b { a } else { b };
            let hi = if a > b { a } else { b };
            cmin[k] = if lo < c { lo } else { c };
            cmax[k] = if hi > c { hi } else { c };
        }
    }
    if off == 1 {
        cmin[0] = cmin[1];
        cmax[0] = cmax[1];
    }
    if x0 + n == w {
        cmin[n + 1] = cmin[n];
        cmax[n + 1] = cmax[n];
    }
    for k in 0..CHUNK {
        let (a, b, c) = (cmin[k], cmin[k + 1], cmin[k + 2]);
        let t = if a < b { a } else { b };
        lo[k] = if t < c { t } else { c };
        let (a, b, c) = (cmax[k], cmax[k + 1], cmax[k + 2]);
        let t = if a > b { a } else { b };
        hi[k] = if t > c { t } else { c };
    }
}

/// `n` through the octahedral encoding of the denoiser's history (Cigolle
/// et al. 2014, 16 bits a coordinate) and back, branch-free.
#[inline(always)]
fn octahedral(n: Vec3) -> Vec3 {
    let sign = |v: f32| if v >= 0.0 { 1.0f32 } else { -1.0 };
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    let ok = (l1 > 0.0) & l1.is_finite();
    let (px, py) = (n.x / l1, n.y / l1);
    let (wx, wy) = ((1.0 - py.abs()) * sign(px), (1.0 - px.abs()) * sign(py));
    let (px, py) = if n.z < 0.0 { (wx, wy) } else { (px, py) };
    // Round half away from zero to the 16-bit code, kept as a float: the
    // value an integer round trip gives, without the conversions.
    let q = |v: f32| trunc(v * 32767.0 + 0.5f32.copysign(v));
    let (ex, ey) = if ok { (q(px), q(py)) } else { (0.0, 0.0) };
    let (px, py) = (ex * (1.0 / 32767.0), ey * (1.0 / 32767.0));
    let z = 1.0 - px.abs() - py.abs();
    let (wx, wy) = ((1.0 - py.abs()) * sign(px), (1.0 - px.abs()) * sign(py));
    let (px, py) = if z < 0.0 { (wx, wy) } else { (px, py) };
    Vec3::new(px, py, z)
}

/// What the resolve knows of the current pixel, in the history's record.
pub(super) struct Pixel {
    pub meta: Meta,
    pub normal: Vec3,
}

impl Pixel {
    #[inline]
    pub(super) fn of(guide: &GuideBuffers, i: usize) -> Pixel {
        let d = guide.depth[i];
        let surface = d > 0.0 && d.is_finite();
        let lu = luminance(guide.u[i]);
        let lu = if lu.is_finite() { lu.max(0.0) } else { 0.0 };
        let share = guide.lobe.get(i).map_or(0.0, |l| l.share);
        let normal = guide.normal[i];
        Pixel {
            meta: Meta {
                pos: guide.position[i],
                normal: encode_normal(normal),
                depth: if surface { d } else { 0.0 },
                lu,
                lu_diffuse: lu * (1.0 - share),
                ..Meta::default()
            },
            normal,
        }
    }
}

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
use glam::{Vec2, Vec3};
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
            cur.factor.par_chunks_mut(w),
            cur.color.par_chunks_mut(w),
            cur.record.par_chunks_mut(w),
            cur.mixed.par_chunks_mut(w),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(y, (factor, color, record, mixed))| {
                isa::run(Row {
                    ctx: &ctx,
                    y,
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

/// One row of the resolve.
struct Row<'a, 'b> {
    ctx: &'b Context<'a>,
    y: usize,
    out: (
        &'b mut [Vec3],
        &'b mut [Vec3],
        &'b mut [Record],
        &'b mut [bool],
    ),
}

/// A chunk's histories as lanes: channels as `now`, frames, mixed. No
/// history is all zeros: its blend weight is then 1 and the blend gives the
/// current value exactly.
struct Hist {
    sig: [[f32; CHUNK]; CHANNELS],
    len: [f32; CHUNK],
    mixed: [bool; CHUNK],
}

impl Kernel for Row<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let Row {
            ctx,
            y,
            out: (out_f, out_c, out_rec, out_mixed),
        } = self;
        let (w, h) = (ctx.w, ctx.h);
        let row = y * w;
        for x0 in (0..w).step_by(CHUNK) {
            let n = CHUNK.min(w - x0);
            let mut hist = Hist {
                sig: [[0.0; CHUNK]; CHANNELS],
                len: [0.0; CHUNK],
                mixed: [false; CHUNK],
            };
            records(ctx.guide, row + x0, &mut out_rec[x0..x0 + n]);
            for k in 0..n {
                let (x, i) = (x0 + k, row + x0 + k);
                let here = &out_rec[x];
                let normal = ctx.guide.normal[i];
                let taken = match ctx.motion {
                    CameraMotion::Still => still_history(ctx.prev, i, here, normal, ctx.s),
                    CameraMotion::Moved if here.depth > 0.0 && ctx.guide.prev_valid[i] => {
                        reprojected(ctx, i, here, normal)
                    }
                    CameraMotion::Moved => None,
                };
                if let Some((f, c, len, mixed)) = taken {
                    for (ch, v) in f.to_array().into_iter().chain(c.to_array()).enumerate() {
                        hist.sig[ch][k] = v;
                    }
                    hist.len[k] = len;
                    hist.mixed[k] = mixed;
                }
            }
            // Blend weight 1/len per pixel, shared by the six channels.
            let mut len = [0.0f32; CHUNK];
            let mut a = [0.0f32; CHUNK];
            let mut clamped = [false; CHUNK];
            for k in 0..CHUNK {
                let l = hist.len[k] + 1.0;
                len[k] = if l < ctx.cap { l } else { ctx.cap };
                a[k] = 1.0 / len[k];
                clamped[k] = ctx.clamp & (hist.len[k] > 0.0);
            }
            let mut res = [[0.0f32; CHUNK]; CHANNELS];
            let (ya, yb) = (y.saturating_sub(1), (y + 1).min(h - 1));
            for (ch, plane) in ctx.now.iter().enumerate() {
                let cur = &plane[row + x0..row + x0 + n];
                let sig = &hist.sig[ch];
                let out = &mut res[ch];
                if ctx.clamp {
                    let (lo, hi) = bounds(plane, w, (ya, y, yb), x0, n);
                    for k in 0..n {
                        let v = sig[k];
                        let t = if v < lo[k] { lo[k] } else { v };
                        let t = if t > hi[k] { hi[k] } else { t };
                        let v = if clamped[k] { t } else { v };
                        out[k] = v + (cur[k] - v) * a[k];
                    }
                } else {
                    for k in 0..n {
                        let v = sig[k];
                        out[k] = v + (cur[k] - v) * a[k];
                    }
                }
            }
            for k in 0..n {
                let x = x0 + k;
                out_f[x] = Vec3::new(res[0][k], res[1][k], res[2][k]);
                out_c[x] = Vec3::new(res[3][k], res[4][k], res[5][k]);
                out_rec[x].len = len[k];
                out_mixed[x] = hist.mixed[k];
            }
        }
    }
}

/// Per pixel of columns `x0 .. x0 + n` of row `rows.1`, the minimum and
/// maximum of `plane` over its 3x3 neighbourhood (cut at the frame's
/// edges: an edge pixel standing in for the missing one changes neither):
/// the rows' column min/max first, then across three columns, so each
/// value is read once per row and shared by the three pixels above it.
#[inline(always)]
fn bounds(
    plane: &[f32],
    w: usize,
    (ya, y, yb): (usize, usize, usize),
    x0: usize,
    n: usize,
) -> ([f32; CHUNK], [f32; CHUNK]) {
    // Column x0 - 1 + k at index k.
    let mut cmin = [0.0f32; CHUNK + 2];
    let mut cmax = [0.0f32; CHUNK + 2];
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
    let mut lo = [0.0f32; CHUNK];
    let mut hi = [0.0f32; CHUNK];
    for k in 0..CHUNK {
        let (a, b, c) = (cmin[k], cmin[k + 1], cmin[k + 2]);
        let t = if a < b { a } else { b };
        lo[k] = if t < c { t } else { c };
        let (a, b, c) = (cmax[k], cmax[k + 1], cmax[k + 2]);
        let t = if a > b { a } else { b };
        hi[k] = if t > c { t } else { c };
    }
    (lo, hi)
}

/// This frame's records of pixels `i0 ..` (`len` left 0): the
/// normal as the 16-bit octahedral encoding keeps it, in lanes.
#[inline(always)]
fn records(guide: &GuideBuffers, i0: usize, out: &mut [Record]) {
    let n = out.len();
    let normal = &guide.normal[i0..i0 + n];
    let depth = &guide.depth[i0..i0 + n];
    let u = &guide.u[i0..i0 + n];
    let pos = &guide.position[i0..i0 + n];
    let lobe = guide.lobe.get(i0..i0 + n);
    for k in 0..n {
        let d = depth[k];
        let lu = luminance(u[k]);
        let lu = if lu.is_finite() & (lu > 0.0) { lu } else { 0.0 };
        let share = lobe.map_or(0.0, |l| l[k].share);
        let nm = octahedral(normal[k]);
        out[k] = Record {
            pos: pos[k],
            normal: nm,
            normal_len2: nm.length_squared(),
            depth: if (d > 0.0) & d.is_finite() { d } else { 0.0 },
            lu,
            lu_diffuse: lu * (1.0 - share),
            len: 0.0,
        };
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
    // Round half away from zero; in range, so the i32 cast saturates nowhere.
    let q = |v: f32| (v * 32767.0 + 0.5f32.copysign(v)) as i32;
    let (ex, ey) = if ok { (q(px), q(py)) } else { (0, 0) };
    let (px, py) = (ex as f32 * (1.0 / 32767.0), ey as f32 * (1.0 / 32767.0));
    let z = 1.0 - px.abs() - py.abs();
    let (wx, wy) = ((1.0 - py.abs()) * sign(px), (1.0 - px.abs()) * sign(py));
    let (px, py) = if z < 0.0 { (wx, wy) } else { (px, py) };
    Vec3::new(px, py, z)
}

/// The disocclusion test of one history tap (the denoiser's): `m` holds
/// the same surface as the current pixel (depth, tangent plane and normal
/// agree) and has something accumulated.
#[inline(always)]
fn same_surface(m: &Record, depth: f32, pos: Vec3, normal: Vec3, s: &DenoiseSettings) -> bool {
    let d = m.normal.dot(normal);
    let facing = if s.min_normal_dot >= 0.0 {
        (d >= 0.0) & (d * d >= s.min_normal_dot * s.min_normal_dot * m.normal_len2)
    } else {
        d >= s.min_normal_dot * m.normal_len2.sqrt()
    };
    (m.depth > 0.0)
        & ((m.depth - depth).abs() <= s.depth_tolerance * depth)
        & (normal.dot(m.pos - pos).abs() <= s.plane_tolerance * depth)
        & (m.len > 0.0)
        & facing
}

/// A history: factor, colour, frames, mixed.
type Taken = (Vec3, Vec3, f32, bool);

/// A still camera's history: the pixel's own. Nothing is rejected: the
/// static scene cannot have disoccluded anything, a different surface than
/// last frame is the jitter sampling another part of the pixel (what the
/// average is for; the history is then marked mixed), and `U` differs
/// between frames for the same reason; the renderer drops the history when
/// the lights change.
#[inline(always)]
fn still_history(
    prev: &ColorHistory,
    i: usize,
    here: &Record,
    normal: Vec3,
    s: &DenoiseSettings,
) -> Option<Taken> {
    let m = &prev.record[i];
    if m.len <= 0.0 {
        return None;
    }
    let d = here.depth;
    let same = if d > 0.0 {
        same_surface(m, d, here.pos, normal, s)
    } else {
        m.depth <= 0.0
    };
    Some((prev.factor[i], prev.color[i], m.len, prev.mixed[i] || !same))
}

/// Bilinear fetch of the previous resolve at the unjittered motion
/// vector's end (pixel centres at +0.5), each tap validated like the
/// denoiser's; `None` where disoccluded or the light changed. One set of
/// weights serves both signals.
#[inline(always)]
fn reprojected(ctx: &Context, i: usize, here: &Record, normal: Vec3) -> Option<Taken> {
    let (w, h) = (ctx.w as i64, ctx.h as i64);
    let (prev, s) = (ctx.prev, ctx.s);
    let p = ctx.guide.prev_pixel[i] - Vec2::splat(0.5);
    if !p.is_finite() || p.x.abs() > 1e9 || p.y.abs() > 1e9 {
        return None;
    }
    let (x0, y0) = (floor(p.x), floor(p.y));
    let (fx, fy) = (p.x - x0 as f32, p.y - y0 as f32);
    let taps = [
        (x0, y0, (1.0 - fx) * (1.0 - fy)),
        (x0 + 1, y0, fx * (1.0 - fy)),
        (x0, y0 + 1, (1.0 - fx) * fy),
        (x0 + 1, y0 + 1, fx * fy),
    ];
    let (d, pos) = (here.depth, here.pos);
    let (mut f, mut c) = (Vec3::ZERO, Vec3::ZERO);
    let (mut len, mut mixed) = (0.0f32, false);
    let (mut wsum, mut lu, mut lu_diffuse) = (0.0f32, 0.0f32, 0.0f32);
    for (tx, ty, wt) in taps {
        if !(wt > 0.0 && tx >= 0 && ty >= 0 && tx < w && ty < h) {
            continue;
        }
        let j = (ty * w + tx) as usize;
        let m = &prev.record[j];
        if same_surface(m, d, pos, normal, s) {
            wsum += wt;
            f += prev.factor[j] * wt;
            c += prev.color[j] * wt;
            len += m.len * wt;
            mixed |= prev.mixed[j];
            lu += m.lu * wt;
            lu_diffuse += m.lu_diffuse * wt;
        }
    }
    if wsum < 1e-3 {
        return None;
    }
    let inv = 1.0 / wsum;
    if s.light_test
        && light_changed(
            (here.lu, here.lu_diffuse),
            (lu * inv, lu_diffuse * inv),
            s.u_change,
        )
    {
        return None;
    }
    Some((f * inv, c * inv, len * inv, mixed))
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
        let big = a.max(b);
        big > 1e-30 && (a - b).abs() > tolerance * big
    };
    let diffuse_witness =
        now.1 >= MIN_DIFFUSE_SHARE * now.0 && before.1 >= MIN_DIFFUSE_SHARE * before.0;
    if diffuse_witness {
        differ(now.1, before.1)
    } else {
        differ(now.0, before.0)
    }
}

/// floor as an integer without a libm call (baseline x86-64 has no roundss).
#[inline(always)]
fn floor(v: f32) -> i64 {
    let t = v as i64;
    if (t as f32) > v { t - 1 } else { t }
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

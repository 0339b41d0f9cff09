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
use super::temporal::{Taps, bilinear_footprint, light_changed, same_surface, sanitize};
use super::{DenoiseSettings, GuideBuffers, luminance};
use glam::Vec3;
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

/// One frame of the resolved signals and what the next frame needs to
/// validate them.
struct ColorHistory {
    /// The noise-free factor of the colour (see `resolve`).
    factor: Vec<Vec3>,
    color: Vec<Vec3>,
    meta: Vec<Meta>,
    /// The history holds more than one surface (the jitter crossed an edge).
    mixed: Vec<bool>,
}

impl ColorHistory {
    fn new(n: usize) -> ColorHistory {
        ColorHistory {
            factor: vec![Vec3::ZERO; n],
            color: vec![Vec3::ZERO; n],
            meta: vec![Meta::default(); n],
            mixed: vec![false; n],
        }
    }
}

/// One resolved pixel: both signals, how many frames, and whether they
/// came from more than one surface.
#[derive(Clone, Copy)]
struct Resolved {
    factor: Vec3,
    color: Vec3,
    len: f32,
    mixed: bool,
}

/// Resolve state: the previous resolved frame and the one being written.
pub struct Resolve {
    width: u32,
    height: u32,
    prev: ColorHistory,
    cur: ColorHistory,
    /// `prev` holds a resolved frame (not only empty records).
    has_history: bool,
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
            has_history: false,
        }
    }

    /// Forgets the history: the next frame stands alone.
    pub fn reset(&mut self) {
        for h in [&mut self.prev, &mut self.cur] {
            h.meta.fill(Meta::default());
            h.mixed.fill(false);
        }
        self.has_history = false;
    }

    /// Frames averaged per pixel after the last call (0 before any).
    pub fn history_len(&self) -> Vec<f32> {
        self.prev.meta.iter().map(|m| m.len).collect()
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
    /// are dropped at the same places. `taps`: the denoiser's reprojection
    /// of this frame (`Denoiser::taps`), given only where its history and
    /// this one hold the same previous frame: a moving camera then takes
    /// each pixel's taps from it rather than testing them again, with the
    /// same result. A size change drops the history.
    pub fn resolve(
        &mut self,
        guide: &GuideBuffers,
        (factor, color): (&mut [Vec3], &mut [Vec3]),
        motion: CameraMotion,
        settings: &ResolveSettings,
        surface: &DenoiseSettings,
        taps: Option<&[Taps]>,
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
        let taps = taps.filter(|t| t.len() == n);
        if n == 0 {
            return;
        }
        let prev = &self.prev;
        let cap = match motion {
            CameraMotion::Still => settings.max_history_still,
            CameraMotion::Moved => settings.max_history_moving,
        }
        .max(1) as f32;
        let cur = &mut self.cur;
        // Without a resolved frame every tap would fail its test.
        let motion = if self.has_history { Some(motion) } else { None };
        let rows = (
            cur.factor.par_chunks_mut(w),
            cur.color.par_chunks_mut(w),
            cur.meta.par_chunks_mut(w),
            cur.mixed.par_chunks_mut(w),
        )
            .into_par_iter()
            .map(|(factor, color, meta, mixed)| RowOut {
                factor,
                color,
                meta,
                mixed,
                cap,
            });
        match motion {
            // A pixel that reads only its own input writes its result over
            // it, while the row is in cache: copying the resolved frame out
            // afterwards would move both signals through memory once more.
            None | Some(CameraMotion::Still) => {
                rows.zip(factor.par_chunks_mut(w))
                    .zip(color.par_chunks_mut(w))
                    .enumerate()
                    .for_each(|(y, ((mut out, now_f), now_c))| {
                        let row = y * w;
                        for x in 0..w {
                            let here = Pixel::of(guide, row + x);
                            let hist =
                                motion.and_then(|_| still_history(prev, row + x, &here, surface));
                            let now = (sanitize(now_f[x]), sanitize(now_c[x]));
                            out.put(x, &here, now, hist);
                            (now_f[x], now_c[x]) = (out.factor[x], out.color[x]);
                        }
                    });
            }
            Some(CameraMotion::Moved) => {
                let (now_f, now_c): (&[Vec3], &[Vec3]) = (factor, color);
                rows.enumerate().for_each(|(y, mut out)| {
                    let row = y * w;
                    // The clamp's 3x3 ranges, slid along the row: each
                    // column's range over three rows is taken once and
                    // serves three pixels.
                    let mut ranges = settings.clamp.then(|| {
                        (
                            RowRanges::new(now_f, w, h, y),
                            RowRanges::new(now_c, w, h, y),
                        )
                    });
                    for x in 0..w {
                        let i = row + x;
                        let here = Pixel::of(guide, i);
                        let hist = (here.meta.depth > 0.0 && guide.prev_valid[i])
                            .then(|| match taps {
                                Some(taps) => retraced(guide, prev, x, y, taps[i]),
                                None => reprojected(guide, prev, x, y, &here, surface),
                            })
                            .flatten()
                            .map(|mut r| {
                                if let Some((rf, rc)) = &ranges {
                                    r.factor = rf.clamp(r.factor);
                                    r.color = rc.clamp(r.color);
                                }
                                r
                            });
                        if let Some((rf, rc)) = &mut ranges {
                            rf.advance();
                            rc.advance();
                        }
                        let now = (sanitize(now_f[i]), sanitize(now_c[i]));
                        out.put(x, &here, now, hist);
                    }
                });
                factor.copy_from_slice(&self.cur.factor);
                color.copy_from_slice(&self.cur.color);
            }
        }
        std::mem::swap(&mut self.prev, &mut self.cur);
        self.has_history = true;
    }
}

/// One row of the resolve's output: the resolved signals and the record
/// the next frame validates them with.
struct RowOut<'a> {
    factor: &'a mut [Vec3],
    color: &'a mut [Vec3],
    meta: &'a mut [Meta],
    mixed: &'a mut [bool],
    /// History length cap.
    cap: f32,
}

impl RowOut<'_> {
    /// Blends this frame's `(factor, color)` of pixel `x` into its history
    /// (if any) and writes the result.
    #[inline(always)]
    fn put(&mut self, x: usize, here: &Pixel, (f, c): (Vec3, Vec3), hist: Option<Resolved>) {
        let r = match hist {
            Some(r) => {
                let len = (r.len + 1.0).min(self.cap);
                let a = 1.0 / len;
                Resolved {
                    factor: r.factor + (f - r.factor) * a,
                    color: r.color + (c - r.color) * a,
                    len,
                    mixed: r.mixed,
                }
            }
            None => Resolved {
                factor: f,
                color: c,
                len: 1.0,
                mixed: false,
            },
        };
        self.factor[x] = r.factor;
        self.color[x] = r.color;
        self.mixed[x] = r.mixed;
        self.meta[x] = Meta {
            len: r.len,
            ..here.meta
        };
    }
}

/// What the resolve knows of the current pixel, in the history's record.
pub(super) struct Pixel {
    pub meta: Meta,
    pub normal: Vec3,
}

impl Pixel {
    #[inline(always)]
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
    here: &Pixel,
    s: &DenoiseSettings,
) -> Option<Resolved> {
    let m = &prev.meta[i];
    if m.len <= 0.0 {
        return None;
    }
    let d = here.meta.depth;
    let same = if d > 0.0 {
        same_surface(m, d, here.meta.pos, here.normal, s)
    } else {
        m.depth <= 0.0
    };
    Some(Resolved {
        factor: prev.factor[i],
        color: prev.color[i],
        len: m.len,
        mixed: prev.mixed[i] || !same,
    })
}

/// Bilinear fetch of the previous resolve at the unjittered motion vector's
/// end, each tap validated like the denoiser's; `None` where disoccluded or
/// the light changed.
#[inline]
fn reprojected(
    guide: &GuideBuffers,
    prev: &ColorHistory,
    x: usize,
    y: usize,
    here: &Pixel,
    s: &DenoiseSettings,
) -> Option<Resolved> {
    let taps = bilinear_footprint(guide, x, y)?;
    let (d, pos) = (here.meta.depth, here.meta.pos);
    let mut passed: Taps = 0;
    for (k, tap) in taps.iter().enumerate() {
        if let Some((j, _)) = *tap
            && same_surface(&prev.meta[j], d, pos, here.normal, s)
        {
            passed |= 1 << k;
        }
    }
    let (resolved, inv) = summed(prev, &taps, passed)?;
    if s.light_test {
        let (mut lu, mut lu_diffuse) = (0.0f32, 0.0f32);
        for (j, wt) in passed_taps(&taps, passed) {
            lu += prev.meta[j].lu * wt;
            lu_diffuse += prev.meta[j].lu_diffuse * wt;
        }
        if light_changed(
            (here.meta.lu, here.meta.lu_diffuse),
            (lu * inv, lu_diffuse * inv),
            s.u_change,
        ) {
            return None;
        }
    }
    Some(resolved)
}

/// `reprojected` with the taps the denoiser's reprojection passed
/// (`Taps`): the same taps, sums and order, without the tests.
#[inline(always)]
fn retraced(
    guide: &GuideBuffers,
    prev: &ColorHistory,
    x: usize,
    y: usize,
    passed: Taps,
) -> Option<Resolved> {
    if passed == 0 {
        return None;
    }
    let taps = bilinear_footprint(guide, x, y)?;
    summed(prev, &taps, passed).map(|(r, _)| r)
}

/// The bilinear `taps` whose bit is set in `passed`, in their order.
#[inline(always)]
fn passed_taps(
    taps: &[Option<(usize, f32)>; 4],
    passed: Taps,
) -> impl Iterator<Item = (usize, f32)> + '_ {
    (0..4).filter_map(move |k| taps[k].filter(|_| passed & (1 << k) != 0))
}

/// The history's weighted mean over the taps that `passed`, and the
/// reciprocal of their weight; `None` below a sliver of valid footprint.
#[inline(always)]
fn summed(
    prev: &ColorHistory,
    taps: &[Option<(usize, f32)>; 4],
    passed: Taps,
) -> Option<(Resolved, f32)> {
    let mut acc = Resolved {
        factor: Vec3::ZERO,
        color: Vec3::ZERO,
        len: 0.0,
        mixed: false,
    };
    let mut wsum = 0.0f32;
    for (j, wt) in passed_taps(taps, passed) {
        wsum += wt;
        acc.factor += prev.factor[j] * wt;
        acc.color += prev.color[j] * wt;
        acc.len += prev.meta[j].len * wt;
        acc.mixed |= prev.mixed[j];
    }
    if wsum < 1e-3 {
        return None;
    }
    let inv = 1.0 / wsum;
    let resolved = Resolved {
        factor: acc.factor * inv,
        color: acc.color * inv,
        len: acc.len * inv,
        mixed: acc.mixed,
    };
    Some((resolved, inv))
}

/// The range, per channel, of the current frame's sanitized values in the
/// 3x3 neighbourhood of each pixel of one row, for clamping its history:
/// history the current frame cannot explain (a surface that was not there,
/// light that left) is cut back. The row is walked left to right; each
/// column's range over its three rows is computed once and kept for the
/// two pixels after it.
struct RowRanges<'a> {
    now: &'a [Vec3],
    w: usize,
    /// The rows above and below within the frame, as offsets of the row.
    rows: [Option<usize>; 2],
    row: usize,
    /// The pixel the walk is at.
    x: usize,
    /// The ranges of the columns left of, at and right of the pixel.
    left: Option<Range>,
    here: Range,
    right: Option<Range>,
}

#[derive(Clone, Copy, Default)]
struct Range {
    lo: Vec3,
    hi: Vec3,
}

impl<'a> RowRanges<'a> {
    fn new(now: &'a [Vec3], w: usize, h: usize, y: usize) -> RowRanges<'a> {
        let row = y * w;
        let mut r = RowRanges {
            now,
            w,
            rows: [(y > 0).then(|| row - w), (y + 1 < h).then_some(row + w)],
            row,
            x: 0,
            left: None,
            here: Range::default(),
            right: None,
        };
        if w > 0 {
            r.here = r.column(0);
            r.right = (w > 1).then(|| r.column(1));
        }
        r
    }

    #[inline(always)]
    fn column(&self, x: usize) -> Range {
        let centre = sanitize(self.now[self.row + x]);
        let (mut lo, mut hi) = (centre, centre);
        for r in self.rows.into_iter().flatten() {
            let v = sanitize(self.now[r + x]);
            lo = lo.min(v);
            hi = hi.max(v);
        }
        Range { lo, hi }
    }

    /// `c` clamped to the range of the 3x3 neighbourhood of the pixel the
    /// walk is at.
    #[inline(always)]
    fn clamp(&self, c: Vec3) -> Vec3 {
        let (mut lo, mut hi) = (self.here.lo, self.here.hi);
        for r in [self.left, self.right].into_iter().flatten() {
            lo = lo.min(r.lo);
            hi = hi.max(r.hi);
        }
        c.clamp(lo, hi)
    }

    /// Moves the walk one pixel right.
    #[inline(always)]
    fn advance(&mut self) {
        self.x += 1;
        if let Some(r) = self.right {
            self.left = Some(self.here);
            self.here = r;
            self.right = (self.x + 1 < self.w).then(|| self.column(self.x + 1));
        }
    }
}

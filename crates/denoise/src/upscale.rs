//! Temporal upscaling: a resolve whose history has the output's size while
//! the frames are rendered smaller (the viewer's dynamic resolution,
//! `render --render-scale`).
//!
//! Each frame's camera rays go through one jittered point per render pixel
//! (`sampling::sequence::frame_jitter`, a (0,m,2)-net over the render pixel
//! in its first 2^m frames), so over frames the render pixels' samples
//! cover every output pixel. Each output pixel takes the current samples
//! that fall inside it (at most one while the render is no larger than the
//! output) and averages them into its history with equal weights: the
//! history length counts samples, not frames, so a pixel no sample fell in
//! this frame keeps its history unchanged. For a still camera the result is
//! the mean of the jittered samples inside the output pixel, the box filter
//! `reference` computes; at half the size a side, the first 4 frames put
//! one sample in each output pixel and the first 16 put 4, stratified. A
//! pixel with no sample yet shows the bilinear interpolation of the current
//! frame, which counts for nothing once a sample arrives.
//!
//! A moving camera reprojects the output history along the render pixel's
//! motion vector (bilinear, each tap checked with the denoiser's
//! disocclusion test against the render pixel whose sample lies nearest the
//! output pixel's centre), clamps it to the range of that pixel's 3x3
//! render neighbours on its surface (no ghost trails), drops it where the
//! analytic `U` changed, and caps it short, as [`super::resolve`] does at
//! the frame's own size. The bilinear fallback
//! too takes only taps on that surface, so it carries no light across a
//! depth or normal edge.
//!
//! The history belongs to the output grid, so a change of render size (a
//! dynamic-resolution step) keeps it; a change of output size drops it. The
//! caller drops it when the lights change.

use super::history::Meta;
use super::resolve::{CameraMotion, Pixel, ResolveSettings};
use super::temporal::{bilinear_taps, light_changed, same_surface, sanitize};
use super::{DenoiseSettings, GuideBuffers};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// One frame of the upscaled colour and what the next frame needs to
/// validate it.
struct OutputHistory {
    color: Vec<Vec3>,
    /// `len` counts the samples averaged (capped; fractional after
    /// reprojection; 0: none yet).
    meta: Vec<Meta>,
}

impl OutputHistory {
    fn new(n: usize) -> OutputHistory {
        OutputHistory {
            color: vec![Vec3::ZERO; n],
            meta: vec![Meta::default(); n],
        }
    }
}

/// Upscale state at the output's size: the previous output and the one
/// being written.
pub struct Upscale {
    width: u32,
    height: u32,
    prev: OutputHistory,
    cur: OutputHistory,
}

/// What the current frame gives one output pixel.
struct Current {
    /// Sum of the samples inside the output pixel, and their number.
    sum: Vec3,
    weight: f32,
    /// Range of the 3x3 render neighbourhood, for the clamp.
    lo: Vec3,
    hi: Vec3,
}

impl Upscale {
    pub fn new(width: u32, height: u32) -> Upscale {
        let n = width as usize * height as usize;
        Upscale {
            width,
            height,
            prev: OutputHistory::new(n),
            cur: OutputHistory::new(n),
        }
    }

    /// The output size.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// Forgets the history: the next frame stands alone.
    pub fn reset(&mut self) {
        self.prev.meta.fill(Meta::default());
        self.cur.meta.fill(Meta::default());
    }

    /// Samples averaged per output pixel after the last call.
    pub fn history_len(&self) -> Vec<f32> {
        self.prev.meta.iter().map(|m| m.len).collect()
    }

    /// Writes the output-size colour into `out` from one rendered frame:
    /// `color` and `guide` at the render size, `jitter` the sub-pixel offset
    /// its camera rays went through ((0.5, 0.5): pixel centres). `motion`
    /// `None`: the frames are not to be averaged (unjittered, or already
    /// accumulated by the renderer), so the history is dropped and `out` is
    /// the frame interpolated. `surface` holds the denoiser's disocclusion
    /// tolerances.
    #[allow(clippy::too_many_arguments)]
    pub fn resolve(
        &mut self,
        guide: &GuideBuffers,
        color: &[Vec3],
        jitter: Vec2,
        motion: Option<CameraMotion>,
        settings: &ResolveSettings,
        surface: &DenoiseSettings,
        out: &mut [Vec3],
    ) {
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
        assert_eq!(out.len(), ow * oh, "upscale: out holds the output size");
        if rn == 0 || out.is_empty() {
            return;
        }
        if motion.is_none() {
            self.reset();
        }
        let jitter = if jitter.is_finite() {
            jitter.clamp(Vec2::ZERO, Vec2::ONE)
        } else {
            Vec2::splat(0.5)
        };
        // Render pixels per output pixel, and the inverse.
        let scale = Vec2::new(rw as f32 / ow as f32, rh as f32 / oh as f32);
        let inv = Vec2::ONE / scale;
        // Samples per output pixel per frame, to count the caps in frames.
        let per_frame = scale.x * scale.y;
        let cap = match motion {
            Some(CameraMotion::Moved) => settings.max_history_moving,
            _ => settings.max_history_still,
        }
        .max(1) as f32
            * per_frame;
        let clamp = settings.clamp && motion == Some(CameraMotion::Moved);
        let prev = &self.prev;
        let cur = &mut self.cur;
        (
            cur.color.par_chunks_mut(ow),
            cur.meta.par_chunks_mut(ow),
            out.par_chunks_mut(ow),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(oy, (out_c, out_m, shown))| {
                for ox in 0..ow {
                    let o = oy * ow + ox;
                    let centre = Vec2::new(ox as f32 + 0.5, oy as f32 + 0.5);
                    // The output centre in render pixels, and the render
                    // pixel whose sample lies nearest it: the best witness
                    // of the surface there (the pixel under the centre may
                    // have sampled another surface up to a pixel away).
                    let r = centre * scale;
                    let nearest =
                        |r: f32, j: f32, n: usize| ((r - j + 0.5).max(0.0) as usize).min(n - 1);
                    let (ix, iy) = (nearest(r.x, jitter.x, rw), nearest(r.y, jitter.y, rh));
                    let i = iy * rw + ix;
                    let here = Pixel::of(guide, i);
                    let same = |j: usize| on_surface(guide, j, &here, surface);
                    let now = current(
                        color,
                        (rw, rh),
                        (ix, iy),
                        r,
                        jitter,
                        inv,
                        clamp.then_some(&same as &dyn Fn(usize) -> bool),
                    );
                    let hist = match motion {
                        None => None,
                        Some(CameraMotion::Still) => {
                            let m = &prev.meta[o];
                            (m.len > 0.0).then(|| (prev.color[o], m.len))
                        }
                        Some(CameraMotion::Moved)
                            if here.meta.depth > 0.0 && guide.prev_valid[i] =>
                        {
                            let motion =
                                guide.prev_pixel[i] - Vec2::new(ix as f32 + 0.5, iy as f32 + 0.5);
                            reprojected(prev, centre + motion * inv, (ow, oh), &here, surface).map(
                                |(c, len)| {
                                    let c = if clamp { c.clamp(now.lo, now.hi) } else { c };
                                    (c, len)
                                },
                            )
                        }
                        Some(CameraMotion::Moved) => None,
                    };
                    let (c, len) = match hist {
                        Some((h, len)) if now.weight > 0.0 => {
                            let len = (len + now.weight).min(cap).max(now.weight);
                            let a = (now.weight / len).min(1.0);
                            (h + (now.sum / now.weight - h) * a, len)
                        }
                        // No sample this frame: the history as it is (its
                        // length within this frame's cap).
                        Some((h, len)) => (h, len.min(cap)),
                        None if now.weight > 0.0 => (now.sum / now.weight, now.weight),
                        None => (
                            interpolated(color, (rw, rh), r - jitter + 0.5, i, &same),
                            0.0,
                        ),
                    };
                    out_c[ox] = c;
                    shown[ox] = c;
                    out_m[ox] = Meta { len, ..here.meta };
                }
            });
        std::mem::swap(&mut self.prev, &mut self.cur);
    }
}

/// The current frame's samples inside the output pixel centred at `r` (in
/// render pixels): render pixel `k`'s sample lies at `k + jitter`. The
/// pixel is half-open, `[-0.5, 0.5)` output pixels about its centre, so a
/// sample on a boundary belongs to exactly one pixel. `range`: also the
/// range of the 3x3 neighbours it accepts (only the clamp needs it; the
/// centre `(ix, iy)` always counts), so that a history cut back to it keeps
/// nothing of another surface (a light's edge, a silhouette).
#[inline]
fn current(
    color: &[Vec3],
    (rw, rh): (usize, usize),
    (ix, iy): (usize, usize),
    r: Vec2,
    jitter: Vec2,
    inv: Vec2,
    range: Option<&dyn Fn(usize) -> bool>,
) -> Current {
    let mut now = Current {
        sum: Vec3::ZERO,
        weight: 0.0,
        lo: Vec3::ZERO,
        hi: Vec3::ZERO,
    };
    let inside = |k: usize, j: f32, r: f32, inv: f32| {
        let d = (k as f32 + j - r) * inv;
        (-0.5..0.5).contains(&d)
    };
    let (rows, cols) = (
        iy.saturating_sub(1)..(iy + 2).min(rh),
        ix.saturating_sub(1)..(ix + 2).min(rw),
    );
    for ny in rows.clone().filter(|&y| inside(y, jitter.y, r.y, inv.y)) {
        for nx in cols.clone().filter(|&x| inside(x, jitter.x, r.x, inv.x)) {
            now.sum += sanitize(color[ny * rw + nx]);
            now.weight += 1.0;
        }
    }
    if let Some(accepts) = range {
        let centre = sanitize(color[iy * rw + ix]);
        (now.lo, now.hi) = (centre, centre);
        for ny in rows {
            for nx in cols.clone() {
                let j = ny * rw + nx;
                if accepts(j) {
                    let c = sanitize(color[j]);
                    now.lo = now.lo.min(c);
                    now.hi = now.hi.max(c);
                }
            }
        }
    }
    now
}

/// Bilinear interpolation of the frame at `at` (continuous render pixel
/// coordinates with the samples at +0.5) over the taps on the output
/// pixel's surface (`accepts`), so no light or colour is carried across a
/// depth or normal edge; taps off the frame are left out, and pixel
/// `fallback` (the nearest sample's pixel) stands in where none is left.
#[inline]
fn interpolated(
    color: &[Vec3],
    (rw, rh): (usize, usize),
    at: Vec2,
    fallback: usize,
    accepts: &dyn Fn(usize) -> bool,
) -> Vec3 {
    let Some(taps) = bilinear_taps(at, rw as u32, rh as u32) else {
        return sanitize(color[fallback]);
    };
    let (mut sum, mut wsum) = (Vec3::ZERO, 0.0f32);
    for (j, wt) in taps.into_iter().flatten().filter(|&(j, _)| accepts(j)) {
        sum += sanitize(color[j]) * wt;
        wsum += wt;
    }
    if wsum > 1e-6 {
        sum / wsum
    } else {
        sanitize(color[fallback])
    }
}

/// Whether render pixel `j` shows the surface of `here` (the render pixel
/// whose sample lies nearest an output pixel's centre): both no surface (a light, the
/// background), or both a surface within the denoiser's depth, tangent
/// plane and normal tolerances.
#[inline]
fn on_surface(guide: &GuideBuffers, j: usize, here: &Pixel, s: &DenoiseSettings) -> bool {
    let (d, dj) = (here.meta.depth, guide.depth[j]);
    let surface = dj > 0.0 && dj.is_finite();
    if d <= 0.0 {
        return !surface;
    }
    surface
        && (dj - d).abs() <= s.depth_tolerance * d
        && here.normal.dot(guide.position[j] - here.meta.pos).abs() <= s.plane_tolerance * d
        && guide.normal[j].dot(here.normal) >= s.min_normal_dot
}

/// Bilinear fetch of the previous output at `at` (output pixels), each tap
/// validated like the denoiser's; `None` where disoccluded or where the
/// analytic `U` changed (a glossy reflection that moved with the view, as
/// the full-size resolve tests it).
#[inline]
fn reprojected(
    prev: &OutputHistory,
    at: Vec2,
    (ow, oh): (usize, usize),
    here: &Pixel,
    s: &DenoiseSettings,
) -> Option<(Vec3, f32)> {
    let taps = bilinear_taps(at, ow as u32, oh as u32)?;
    let (d, pos) = (here.meta.depth, here.meta.pos);
    let (mut wsum, mut c, mut len) = (0.0f32, Vec3::ZERO, 0.0f32);
    let (mut lu, mut lu_diffuse) = (0.0f32, 0.0f32);
    for (j, wt) in taps.into_iter().flatten() {
        let m = &prev.meta[j];
        if same_surface(m, d, pos, here.normal, s) {
            wsum += wt;
            c += prev.color[j] * wt;
            len += m.len * wt;
            lu += m.lu * wt;
            lu_diffuse += m.lu_diffuse * wt;
        }
    }
    if wsum < 1e-3 {
        return None;
    }
    let inv = 1.0 / wsum;
    let changed = light_changed(
        (here.meta.lu, here.meta.lu_diffuse),
        (lu * inv, lu_diffuse * inv),
        s.u_change,
    );
    (!(s.light_test && changed)).then(|| (c * inv, len * inv))
}

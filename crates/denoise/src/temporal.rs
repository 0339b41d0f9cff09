//! Temporal accumulation: reproject last frame's accumulated `U_N`/`S_N` and
//! blend the new frame in with ONE factor per pixel for both signals.
//!
//! A per-signal or per-channel factor would make `S_N` and `U_N` averages of
//! different sample sets and silently break the ratio, so the factor depends
//! only on the history length, never on the signal values.

use super::history::{History, Meta, decode_normal, encode_normal};
use super::spatial::{self, Planes, guide};
use super::tiles::{self, TILE};
use super::{DenoiseSettings, GuideBuffers, luminance, luminance_ratio};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// History reprojected to one pixel.
struct Reprojected {
    un: Vec3,
    sn: Vec3,
    m1: f32,
    m2: f32,
    len: f32,
}

/// Weighted sums over the valid reprojection taps.
#[derive(Default)]
struct Acc {
    wsum: f32,
    un: Vec3,
    sn: Vec3,
    m1: f32,
    m2: f32,
    len: f32,
    lu: f32,
    lu_diffuse: f32,
}

/// Non-finite or negative input would poison the history (the denoiser's
/// or the resolve's) for many frames; treat it as no light.
#[inline]
pub(crate) fn sanitize(c: Vec3) -> Vec3 {
    if c.is_finite() {
        c.max(Vec3::ZERO)
    } else {
        Vec3::ZERO
    }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn accumulate(
    guide: &GuideBuffers,
    prev: &History,
    cur: &mut History,
    guides: &mut Planes,
    acc: &mut Planes,
    raw_ratio: &mut [f32],
    row_class: &mut [u8],
    un: &mut [Vec3],
    sn: &mut [Vec3],
    unsampled: &[u8],
    settings: &DenoiseSettings,
) {
    let w = guide.width as usize;
    let cap = settings.max_history.max(1) as f32;
    let tw = w.div_ceil(TILE);
    let (gs, gp) = (guides.stride, guides.pad);
    let (ss, sp) = (acc.stride, acc.pad);
    (
        cur.un.par_chunks_mut(w),
        cur.sn.par_chunks_mut(w),
        cur.meta.par_chunks_mut(w),
        (guides.par_rows_mut(), acc.par_rows_mut()),
        raw_ratio.par_chunks_mut(w),
        row_class.par_chunks_mut(tw),
        un.par_chunks_mut(w),
        sn.par_chunks_mut(w),
    )
        .into_par_iter()
        .enumerate()
        .for_each(|(y, (h_un, h_sn, h_meta, (gd, ar), raw, class, un, sn))| {
            // One pixel's guides and accumulated signals into the planes.
            let mut put_guide = |x: usize, v: [f32; guide::COUNT]| {
                for (k, v) in v.into_iter().enumerate() {
                    gd[k * gs + gp + x] = v;
                }
            };
            let mut put_signal = |x: usize, u: Vec3, s: Vec3, r: f32| {
                let v = [u.x, u.y, u.z, s.x, s.y, s.z, r];
                for (k, v) in v.into_iter().enumerate() {
                    ar[k * ss + sp + x] = v;
                }
            };
            // Tile classification rides along: this pass reads every pixel
            // anyway, a separate pass would read them all again.
            class.fill(tiles::UNIFORM);
            for x in 0..w {
                let i = y * w + x;
                let d = guide.depth[i];
                if !(d > 0.0 && d.is_finite()) {
                    // No surface: pass through untouched, keep no history. The
                    // copy in `h_un/h_sn` is what the spatial filter reads.
                    h_un[x] = un[x];
                    h_sn[x] = sn[x];
                    h_meta[x] = Meta::default();
                    // No surface: every tap gives it weight 0, and the filter
                    // never writes it; its planes only need to be finite.
                    put_guide(x, spatial::GUIDE_BORDER);
                    put_signal(x, Vec3::ZERO, Vec3::ZERO, 1.0);
                    raw[x] = 1.0;
                    continue;
                }
                // A pixel of a tile that drew no samples this frame keeps its
                // history; lacking one (its surface just changed under the
                // jitter) it takes its tile's class, exact 1 or exact 0.
                let skipped = unsampled
                    .get((y / TILE) * tw + x / TILE)
                    .copied()
                    .unwrap_or(0);
                let (u_in, s_in) = match skipped {
                    0 => (sanitize(un[x]), sanitize(sn[x])),
                    tiles::DARK => (sanitize(guide.u[i]), Vec3::ZERO),
                    _ => (sanitize(guide.u[i]), sanitize(guide.u[i])),
                };
                let r = luminance_ratio(s_in, u_in);
                let lu = luminance(guide.u[i]);
                let lu = if lu.is_finite() { lu.max(0.0) } else { 0.0 };
                let share = guide.lobe.get(i).map_or(0.0, |l| l.share);
                let lu_diffuse = lu * (1.0 - share);
                let pos = guide.position[i];
                let normal = guide.normal[i];

                let hist = if settings.temporal && guide.prev_valid[i] {
                    reproject(
                        guide,
                        prev,
                        x,
                        y,
                        d,
                        pos,
                        normal,
                        (lu, lu_diffuse),
                        settings,
                    )
                } else {
                    None
                };
                let (acc_u, acc_s, m1, m2, len) = match hist {
                    Some(h) if skipped != 0 => (h.un, h.sn, h.m1, h.m2, h.len),
                    Some(h) => {
                        let len = (h.len + 1.0).min(cap);
                        // alpha = max(1 / (len_prev + 1), 1 / cap), the same for
                        // both signals and all channels.
                        let a = 1.0 / len;
                        (
                            h.un + (u_in - h.un) * a,
                            h.sn + (s_in - h.sn) * a,
                            h.m1 + (r - h.m1) * a,
                            h.m2 + (r * r - h.m2) * a,
                            len,
                        )
                    }
                    None => (u_in, s_in, r, r * r, 1.0),
                };
                un[x] = acc_u;
                sn[x] = acc_s;
                h_un[x] = acc_u;
                h_sn[x] = acc_s;
                h_meta[x] = Meta {
                    pos,
                    normal: encode_normal(normal),
                    depth: d,
                    lu,
                    lu_diffuse,
                    m1,
                    m2,
                    len,
                };
                let lobe = guide.lobe.get(i).copied().unwrap_or_default();
                let lobe_k = spatial::lobe_weight(
                    &lobe,
                    settings.lobe_scale,
                    spatial::confidence(luminance(acc_u), lu),
                );
                // Taps compare their own direction with this one whatever
                // this pixel's weight; keep it finite.
                let dir = if lobe.dir.is_finite() {
                    lobe.dir
                } else {
                    Vec3::ZERO
                };
                put_guide(
                    x,
                    [
                        pos.x, pos.y, pos.z, normal.x, normal.y, normal.z, lu, dir.x, dir.y, dir.z,
                        lobe_k,
                    ],
                );
                put_signal(x, acc_u, acc_s, luminance_ratio(acc_s, acc_u));
                raw[x] = r;
                class[x / TILE] &= tiles::pixel_class(acc_u, acc_s);
            }
        });
}

/// Bilinear fetch of the previous accumulation at `prev_pixel`, each of the
/// 2x2 taps validated on its own (a tap across a silhouette is dropped and the
/// rest renormalised). `None`: disoccluded, or the light changed.
#[allow(clippy::too_many_arguments)]
#[inline]
fn reproject(
    guide: &GuideBuffers,
    prev: &History,
    x: usize,
    y: usize,
    depth: f32,
    pos: Vec3,
    normal: Vec3,
    (lu, lu_diffuse): (f32, f32),
    s: &DenoiseSettings,
) -> Option<Reprojected> {
    let mut acc = Acc::default();
    for (j, wt) in bilinear_footprint(guide, x, y)?.into_iter().flatten() {
        let m = &prev.meta[j];
        if same_surface(m, depth, pos, normal, s) {
            acc.wsum += wt;
            acc.un += prev.un[j] * wt;
            acc.sn += prev.sn[j] * wt;
            acc.m1 += m.m1 * wt;
            acc.m2 += m.m2 * wt;
            acc.len += m.len * wt;
            acc.lu += m.lu * wt;
            acc.lu_diffuse += m.lu_diffuse * wt;
        }
    }
    let Acc {
        wsum,
        un,
        sn,
        m1,
        m2,
        len,
        lu: lu_prev,
        lu_diffuse: lu_diffuse_prev,
    } = acc;
    // A sliver of valid footprint is too little to trust.
    if wsum < 1e-3 {
        return None;
    }
    let inv = 1.0 / wsum;
    if s.light_test
        && light_changed(
            (lu, lu_diffuse),
            (lu_prev * inv, lu_diffuse_prev * inv),
            s.u_change,
        )
    {
        return None;
    }
    Some(Reprojected {
        un: un * inv,
        sn: sn * inv,
        m1: m1 * inv,
        m2: m2 * inv,
        len: len * inv,
    })
}

/// The 2x2 bilinear footprint, in the previous frame, of the end of pixel
/// (x, y)'s motion vector: each tap's (index, weight), in a fixed order,
/// `None` for a tap off-screen or of zero weight (so a whole-pixel shift
/// reads one tap). `None` overall when the end is not finite or far
/// off-screen (no history, and no overflow in the casts). Shared by the
/// denoiser's history and the colour resolve.
#[inline]
pub(super) fn bilinear_footprint(
    guide: &GuideBuffers,
    x: usize,
    y: usize,
) -> Option<[Option<(usize, f32)>; 4]> {
    bilinear_taps(
        guide.prev_pixel[y * guide.width as usize + x],
        guide.width,
        guide.height,
    )
}

/// The four bilinear taps of continuous pixel position `at` (pixel centres
/// at +0.5) on a `width` x `height` grid, as in [`bilinear_footprint`].
#[inline]
pub(super) fn bilinear_taps(
    at: Vec2,
    width: u32,
    height: u32,
) -> Option<[Option<(usize, f32)>; 4]> {
    let (w, h) = (width as i64, height as i64);
    let p = at - 0.5;
    if !p.is_finite() || p.x.abs() > 1e9 || p.y.abs() > 1e9 {
        return None;
    }
    let (x0, y0) = (floor(p.x), floor(p.y));
    let (fx, fy) = (p.x - x0 as f32, p.y - y0 as f32);
    let tap = |tx: i64, ty: i64, wt: f32| {
        (wt > 0.0 && tx >= 0 && ty >= 0 && tx < w && ty < h).then(|| ((ty * w + tx) as usize, wt))
    };
    Some([
        tap(x0, y0, (1.0 - fx) * (1.0 - fy)),
        tap(x0 + 1, y0, fx * (1.0 - fy)),
        tap(x0, y0 + 1, (1.0 - fx) * fy),
        tap(x0 + 1, y0 + 1, fx * fy),
    ])
}

/// The disocclusion test of one reprojection tap: the history record `m`
/// holds the same surface as the current pixel (depth, tangent plane and
/// normal agree) and has something accumulated. Shared with the colour
/// resolve, so both histories are dropped at the same places.
#[inline]
pub(super) fn same_surface(
    m: &Meta,
    depth: f32,
    pos: Vec3,
    normal: Vec3,
    s: &DenoiseSettings,
) -> bool {
    m.depth > 0.0
        && (m.depth - depth).abs() <= s.depth_tolerance * depth
        && normal.dot(m.pos - pos).abs() <= s.plane_tolerance * depth
        && m.len > 0.0
        && normal_close(decode_normal(m.normal), normal, s.min_normal_dot)
}

/// Below this diffuse share of `U` (in either frame) the diffuse part is too
/// small a witness, and the whole `U` is compared.
const MIN_DIFFUSE_SHARE: f32 = 0.02;

/// Whether the light at a surface point changed between two frames (moved,
/// edited, toggled), so the old visibility no longer applies; `U` is
/// noise-free, so any sizeable change is real. Arguments: luminance of `U`
/// and of its diffuse part, now and in the previous frame. The specular part
/// of `U` also changes when only the camera moves (a glossy highlight
/// slides over the floor), which must not cost the history; the diffuse
/// part depends on the light alone, so it is the witness wherever it
/// carries a fair share of `U`.
#[inline]
pub(super) fn light_changed(now: (f32, f32), before: (f32, f32), tolerance: f32) -> bool {
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
#[inline]
pub(super) fn floor(v: f32) -> i64 {
    let t = v as i64;
    if (t as f32) > v { t - 1 } else { t }
}

/// dot(a / |a|, b) >= min_dot for unit `b`, without normalising `a`.
/// Forced inline: left as a call it showed up on its own in profiles of the
/// per-tap reprojection test.
#[inline(always)]
fn normal_close(a: Vec3, b: Vec3, min_dot: f32) -> bool {
    let d = a.dot(b);
    if min_dot >= 0.0 {
        d >= 0.0 && d * d >= min_dot * min_dot * a.length_squared()
    } else {
        d >= min_dot * a.length()
    }
}

//! Temporal accumulation: reproject last frame's accumulated `U_N`/`S_N` and
//! blend the new frame in with ONE factor per pixel for both signals.
//!
//! A per-signal or per-channel factor would make `S_N` and `U_N` averages of
//! different sample sets and silently break the ratio, so the factor depends
//! only on the history length, never on the signal values.

use super::history::{History, Meta, Record, decode_normal, encode_normal};
use super::noise;
use super::spatial::lanes::{M, V, each};
use super::spatial::{self, LANES, Planes};
use super::tiles::{self, TILE};
use super::{DenoiseSettings, GuideBuffers, luminance, luminance_ratio};
use glam::{Vec2, Vec3};
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// One pixel's inputs to the reprojection and the blend.
#[derive(Clone, Copy, Default)]
struct Pixel {
    surface: bool,
    /// Reprojection asked for (temporal on, motion vector valid).
    want: bool,
    skipped: u8,
    depth: f32,
    u_in: Vec3,
    s_in: Vec3,
    /// Raw ratio of this frame.
    r: f32,
    lu: f32,
    lu_diffuse: f32,
    pos: Vec3,
    normal: Vec3,
    /// Motion vector's end in the previous frame.
    at: Vec2,
}

/// History reprojected to one pixel.
struct History1 {
    un: Vec3,
    sn: Vec3,
    m1: f32,
    m2: f32,
    len: f32,
}

/// History reprojected to a lane group: per lane whether there is one, and
/// its values.
#[derive(Default)]
struct Reprojected {
    ok: [bool; LANES],
    un: [V; 3],
    sn: [V; 3],
    m1: V,
    m2: V,
    len: V,
    /// Per lane, which of the four taps passed the tests (`Taps`).
    passed: [u8; LANES],
}

/// Which of a pixel's four bilinear taps (in `bilinear_taps`' order: bit
/// `k` for tap `k`) the reprojection took its history from; 0 where it kept
/// none (no surface, no motion vector, too little valid footprint, or the
/// light changed). The colour resolve reads these instead of testing its
/// own history again: its records hold the same surfaces, so its taps
/// would pass and fail alike.
pub type Taps = u8;

impl Reprojected {
    #[inline(always)]
    fn pixel(&self, l: usize) -> Option<History1> {
        self.ok[l].then(|| History1 {
            un: Vec3::new(self.un[0].0[l], self.un[1].0[l], self.un[2].0[l]),
            sn: Vec3::new(self.sn[0].0[l], self.sn[1].0[l], self.sn[2].0[l]),
            m1: self.m1.0[l],
            m2: self.m2.0[l],
            len: self.len.0[l],
        })
    }
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
    moments: &mut Planes,
    row_class: &mut [u8],
    un: &mut [Vec3],
    sn: &mut [Vec3],
    unsampled: &[u8],
    (taps, keep_taps): (&mut [Taps], bool),
    settings: &DenoiseSettings,
) {
    let w = guide.width as usize;
    let tw = w.div_ceil(TILE);
    let (gs, gp) = (guides.stride, guides.pad);
    let (ss, sp) = (acc.stride, acc.pad);
    let (ms, mp) = (moments.stride, moments.pad);
    (
        cur.rec.par_chunks_mut(w),
        (guides.par_rows_mut(), acc.par_rows_mut()),
        moments.par_rows_mut(),
        row_class.par_chunks_mut(tw),
        (un.par_chunks_mut(w), sn.par_chunks_mut(w)),
        taps.par_chunks_mut(w),
    )
        .into_par_iter()
        .enumerate()
        .for_each(|(y, (h, (gd, ar), raw, class, (un, sn), taps))| {
            isa::run(Row {
                guide,
                prev,
                unsampled,
                settings,
                y,
                h,
                gd,
                ar,
                raw,
                class,
                un,
                sn,
                taps: keep_taps.then_some(taps),
                planes: (gs, gp, ss, sp),
                moment_planes: (ms, mp),
            })
        });
}

/// One row of the temporal pass: its hot loop, compiled per instruction-set
/// level.
struct Row<'a, 'g> {
    guide: &'a GuideBuffers<'g>,
    prev: &'a History,
    unsampled: &'a [u8],
    settings: &'a DenoiseSettings,
    y: usize,
    /// The row's history records.
    h: &'a mut [Record],
    /// The row's blocks of the guide planes and of the accumulated signal
    /// planes.
    gd: &'a mut [f32],
    ar: &'a mut [f32],
    /// The row's block of the noise estimate's planes (`noise`).
    raw: &'a mut [f32],
    class: &'a mut [u8],
    un: &'a mut [Vec3],
    sn: &'a mut [Vec3],
    /// The row's `Taps`, when they are kept.
    taps: Option<&'a mut [Taps]>,
    /// Stride and border of the guide planes, then of the signal planes.
    planes: (usize, usize, usize, usize),
    moment_planes: (usize, usize),
}

impl Kernel for Row<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let Row {
            guide,
            prev,
            unsampled,
            settings,
            y,
            h,
            gd,
            ar,
            raw,
            class,
            un,
            sn,
            mut taps,
            planes: (gs, gp, ss, sp),
            moment_planes: (ms, mp),
        } = self;
        let w = guide.width as usize;
        let cap = settings.max_history.max(1) as f32;
        let tw = w.div_ceil(TILE);
        // Tile classification rides along: this pass reads every pixel
        // anyway, a separate pass would read them all again.
        class.fill(tiles::UNIFORM);
        for x0 in (0..w).step_by(LANES) {
            let n = LANES.min(w - x0);
            let mut px = [Pixel::default(); LANES];
            // This group's guides and accumulated signals, stored to the
            // planes at once; a pixel without a surface keeps the border
            // values (every tap gives it weight 0, the filter never
            // writes it).
            let mut gv = [[0.0f32; LANES]; spatial::guide::COUNT];
            for (v, &b) in gv.iter_mut().zip(&spatial::GUIDE_BORDER) {
                *v = [b; LANES];
            }
            let mut sv = [[0.0f32; LANES]; spatial::signal::COUNT];
            for (v, &b) in sv.iter_mut().zip(&spatial::SIGNAL_BORDER) {
                *v = [b; LANES];
            }
            let mut nv = [[0.0f32; LANES]; noise::COUNT];
            for (l, p) in px.iter_mut().enumerate().take(n) {
                let x = x0 + l;
                let i = y * w + x;
                let d = guide.depth[i];
                if !(d > 0.0 && d.is_finite()) {
                    // No surface: pass through untouched, keep no history
                    // (a finite one: reprojection reads it unmasked).
                    h[x] = Record::default();
                    continue;
                }
                // A pixel of a tile that drew no samples this frame keeps
                // its history; lacking one (its surface just changed under
                // the jitter) it takes its tile's class, exact 1 or exact 0.
                let skipped = unsampled
                    .get((y / TILE) * tw + x / TILE)
                    .copied()
                    .unwrap_or(0);
                let (u_in, s_in) = match skipped {
                    0 => (sanitize(un[x]), sanitize(sn[x])),
                    tiles::DARK => (sanitize(guide.u[i]), Vec3::ZERO),
                    _ => (sanitize(guide.u[i]), sanitize(guide.u[i])),
                };
                let lu = luminance(guide.u[i]);
                let lu = if lu.is_finite() { lu.max(0.0) } else { 0.0 };
                let share = guide.lobe.get(i).map_or(0.0, |l| l.share);
                *p = Pixel {
                    surface: true,
                    want: settings.temporal && guide.prev_valid[i],
                    skipped,
                    depth: d,
                    u_in,
                    s_in,
                    r: luminance_ratio(s_in, u_in),
                    lu,
                    lu_diffuse: lu * (1.0 - share),
                    pos: guide.position[i],
                    normal: guide.normal[i],
                    at: guide.prev_pixel[i],
                };
            }
            let hist = if px.iter().any(|p| p.want) {
                reproject_lanes(prev, guide.width, guide.height, &px, settings)
            } else {
                Reprojected::default()
            };
            if let Some(taps) = taps.as_deref_mut() {
                taps[x0..x0 + n].copy_from_slice(&hist.passed[..n]);
            }
            for (l, p) in px.iter().enumerate().take(n) {
                if !p.surface {
                    continue;
                }
                let x = x0 + l;
                let i = y * w + x;
                let Pixel {
                    skipped,
                    depth: d,
                    u_in,
                    s_in,
                    r,
                    lu,
                    lu_diffuse,
                    pos,
                    normal,
                    ..
                } = *p;
                let (acc_u, acc_s, m1, m2, len) = match hist.pixel(l) {
                    Some(h) if skipped != 0 => (h.un, h.sn, h.m1, h.m2, h.len),
                    Some(h) => {
                        let len = (h.len + 1.0).min(cap);
                        // alpha = max(1 / (len_prev + 1), 1 / cap), the
                        // same for both signals and all channels.
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
                h[x] = Record {
                    meta: Meta {
                        pos,
                        normal: encode_normal(normal),
                        depth: d,
                        lu,
                        lu_diffuse,
                        m1,
                        m2,
                        len,
                    },
                    un: acc_u,
                    sn: acc_s,
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
                let g = [
                    pos.x, pos.y, pos.z, normal.x, normal.y, normal.z, lu, dir.x, dir.y, dir.z,
                    lobe_k,
                ];
                for (k, v) in g.into_iter().enumerate() {
                    gv[k][l] = v;
                }
                let r_acc = luminance_ratio(acc_s, acc_u);
                let sg = [acc_u.x, acc_u.y, acc_u.z, acc_s.x, acc_s.y, acc_s.z, r_acc];
                for (k, v) in sg.into_iter().enumerate() {
                    sv[k][l] = v;
                }
                // Per `noise`'s planes; `len` is positive here (1 or more
                // up to rounding), which marks the pixel as a surface there.
                let v = [r, (m2 - m1 * m1).max(0.0), len];
                for (k, v) in v.into_iter().enumerate() {
                    nv[k][l] = v;
                }
                class[x / TILE] &= tiles::pixel_class(acc_u, acc_s);
            }
            for (k, v) in gv.iter().enumerate() {
                let at = k * gs + gp + x0;
                put(gd, at, v, n);
            }
            for (k, v) in sv.iter().enumerate() {
                let at = k * ss + sp + x0;
                put(ar, at, v, n);
            }
            for (k, v) in nv.iter().enumerate() {
                let at = k * ms + mp + x0;
                put(raw, at, v, n);
            }
        }
    }
}

/// Stores the first `n` lanes of `v` at `at`: a whole group as one fixed
/// copy (a copy of variable length is a library call).
#[inline(always)]
fn put(dst: &mut [f32], at: usize, v: &[f32; LANES], n: usize) {
    if n == LANES {
        dst[at..at + LANES].copy_from_slice(v);
    } else {
        dst[at..at + n].copy_from_slice(&v[..n]);
    }
}

/// Bilinear fetch of the previous accumulation at each lane's motion
/// vector end, each of the 2x2 taps validated on its own (a tap across a
/// silhouette is dropped and the rest renormalised); no history where
/// disoccluded or where the light changed. Lane for lane the arithmetic of
/// [`bilinear_taps`], [`same_surface`] and [`light_changed`]; only the
/// fetches of the history records are per lane.
#[inline(always)]
fn reproject_lanes(
    prev: &History,
    width: u32,
    height: u32,
    px: &[Pixel; LANES],
    s: &DenoiseSettings,
) -> Reprojected {
    // One field of every lane's pixel.
    macro_rules! lane {
        ($p:ident => $e:expr) => {
            V(each(|l| {
                let $p = &px[l];
                $e
            }))
        };
    }
    let (ax, ay) = (lane!(p => p.at.x - 0.5), lane!(p => p.at.y - 0.5));
    let depth = lane!(p => p.depth);
    let (pos_x, pos_y, pos_z) = (
        lane!(p => p.pos.x),
        lane!(p => p.pos.y),
        lane!(p => p.pos.z),
    );
    let (nx, ny, nz) = (
        lane!(p => p.normal.x),
        lane!(p => p.normal.y),
        lane!(p => p.normal.z),
    );
    // Finite and not far off-screen (no overflow in the casts).
    let lim = V::splat(1e9);
    let ok0: [bool; LANES] =
        each(|l| px[l].want && ax.0[l].abs() <= lim.0[l] && ay.0[l].abs() <= lim.0[l]);
    let ax = M::from_fn(|l| ok0[l]).select(ax, V::splat(0.0));
    let ay = M::from_fn(|l| ok0[l]).select(ay, V::splat(0.0));
    let (x0, y0) = (floor_lanes(ax), floor_lanes(ay));
    let fx = ax - V(each(|l| x0[l] as f32));
    let fy = ay - V(each(|l| y0[l] as f32));
    let one = V::splat(1.0);
    let taps = [
        (0, 0, (one - fx) * (one - fy)),
        (1, 0, fx * (one - fy)),
        (0, 1, (one - fx) * fy),
        (1, 1, fx * fy),
    ];
    // Within i32: the taps lie within 1e9 + 1 of the frame.
    let (w, h) = (
        width.min(i32::MAX as u32) as i32,
        height.min(i32::MAX as u32) as i32,
    );
    let zero = V::splat(0.0);
    let mut wsum = zero;
    let mut un = [zero; 3];
    let mut sn = [zero; 3];
    let (mut m1, mut m2, mut len, mut lu_prev, mut lud_prev) = (zero, zero, zero, zero, zero);
    let mut passed = [0u8; LANES];
    for (k, (dx, dy, wt)) in taps.into_iter().enumerate() {
        let mut j = [0usize; LANES];
        let mut inside = [false; LANES];
        for l in 0..LANES {
            let (tx, ty) = (x0[l] + dx, y0[l] + dy);
            // `&`, not `&&`: no branch per lane.
            inside[l] = ok0[l] & (wt.0[l] > 0.0) & (tx >= 0) & (ty >= 0) & (tx < w) & (ty < h);
            let (cx, cy) = if inside[l] { (tx, ty) } else { (0, 0) };
            j[l] = cy as usize * w as usize + cx as usize;
        }
        // A tap no lane reads (a still camera reprojects onto whole
        // pixels: one tap of four) would add only zeros.
        if !inside.iter().any(|&b| b) {
            continue;
        }
        // The records of the taps, per lane.
        let mut f = [[0.0f32; LANES]; 17];
        for l in 0..LANES {
            let r = &prev.rec[j[l]];
            let (m, u, sg) = (&r.meta, r.un, r.sn);
            let v = [
                m.depth,
                m.pos.x,
                m.pos.y,
                m.pos.z,
                m.normal[0] as f32,
                m.normal[1] as f32,
                m.len,
                m.m1,
                m.m2,
                m.lu,
                m.lu_diffuse,
                u.x,
                u.y,
                u.z,
                sg.x,
                sg.y,
                sg.z,
            ];
            for (k, v) in v.into_iter().enumerate() {
                f[k][l] = v;
            }
        }
        let [
            md,
            mx,
            my,
            mz,
            e0,
            e1,
            mlen,
            mm1,
            mm2,
            mlu,
            mlud,
            ur,
            ug,
            ub,
            sr,
            sg,
            sz,
        ] = [
            V(f[0]),
            V(f[1]),
            V(f[2]),
            V(f[3]),
            V(f[4]),
            V(f[5]),
            V(f[6]),
            V(f[7]),
            V(f[8]),
            V(f[9]),
            V(f[10]),
            V(f[11]),
            V(f[12]),
            V(f[13]),
            V(f[14]),
            V(f[15]),
            V(f[16]),
        ];
        // `same_surface`, lane for lane.
        let plane = nx * (mx - pos_x) + ny * (my - pos_y) + nz * (mz - pos_z);
        let a = decode_normal_lanes(e0, e1);
        let close = normal_close_lanes(a, (nx, ny, nz), s.min_normal_dot);
        let near_depth = (md - depth).abs().le(depth * s.depth_tolerance);
        let near_plane = plane.abs().le(depth * s.plane_tolerance);
        let valid = M::from_fn(|l| inside[l])
            .and(md.gt(zero))
            .and(near_depth)
            .and(near_plane)
            .and(mlen.gt(zero))
            .and(close);
        for (p, l) in passed.iter_mut().zip(0..LANES) {
            *p |= u8::from(valid.lane(l)) << k;
        }
        let wt = valid.select(wt, zero);
        wsum = wsum + wt;
        let add = |acc: V, v: V| acc + valid.select(v * wt, zero);
        un = [add(un[0], ur), add(un[1], ug), add(un[2], ub)];
        sn = [add(sn[0], sr), add(sn[1], sg), add(sn[2], sz)];
        m1 = add(m1, mm1);
        m2 = add(m2, mm2);
        len = add(len, mlen);
        lu_prev = add(lu_prev, mlu);
        lud_prev = add(lud_prev, mlud);
    }
    // A sliver of valid footprint is too little to trust.
    let enough = wsum.ge(V::splat(1e-3));
    let inv = one / enough.select(wsum, one);
    let mut ok: [bool; LANES] = each(|l| ok0[l] && wsum.0[l] >= 1e-3);
    if s.light_test {
        let now = (lane!(p => p.lu), lane!(p => p.lu_diffuse));
        let changed = light_changed_lanes(now, (lu_prev * inv, lud_prev * inv), s.u_change);
        for l in 0..LANES {
            ok[l] &= !changed[l];
        }
    }
    Reprojected {
        ok,
        un: [un[0] * inv, un[1] * inv, un[2] * inv],
        sn: [sn[0] * inv, sn[1] * inv, sn[2] * inv],
        m1: m1 * inv,
        m2: m2 * inv,
        len: len * inv,
        passed: each(|l| if ok[l] { passed[l] } else { 0 }),
    }
}

/// [`floor`] per lane, for values within 1e9.
#[inline(always)]
fn floor_lanes(v: V) -> [i32; LANES] {
    each(|l| {
        let t = v.0[l] as i32;
        if (t as f32) > v.0[l] { t - 1 } else { t }
    })
}

/// `decode_normal` per lane, from the two encoded components as `f32`.
#[inline(always)]
fn decode_normal_lanes(e0: V, e1: V) -> (V, V, V) {
    let (px, py) = (e0 * (1.0 / 32767.0), e1 * (1.0 / 32767.0));
    let z = V::splat(1.0) - px.abs() - py.abs();
    let wrap = z.lt(V::splat(0.0));
    let sign = |v: V| v.ge(V::splat(0.0)).select(V::splat(1.0), V::splat(-1.0));
    let wx = (V::splat(1.0) - py.abs()) * sign(px);
    let wy = (V::splat(1.0) - px.abs()) * sign(py);
    (wrap.select(wx, px), wrap.select(wy, py), z)
}

/// `normal_close` per lane.
#[inline(always)]
fn normal_close_lanes(a: (V, V, V), b: (V, V, V), min_dot: f32) -> M {
    let d = a.0 * b.0 + a.1 * b.1 + a.2 * b.2;
    let len2 = a.0 * a.0 + a.1 * a.1 + a.2 * a.2;
    if min_dot >= 0.0 {
        d.ge(V::splat(0.0))
            .and((d * d).ge(len2 * (min_dot * min_dot)))
    } else {
        d.ge(len2.sqrt() * min_dot)
    }
}

/// `light_changed` per lane.
#[inline(always)]
fn light_changed_lanes(now: (V, V), before: (V, V), tolerance: f32) -> [bool; LANES] {
    each(|l| {
        light_changed(
            (now.0.0[l], now.1.0[l]),
            (before.0.0[l], before.1.0[l]),
            tolerance,
        )
    })
}

/// The 2x2 bilinear footprint, in the previous frame, of the end of pixel
/// (x, y)'s motion vector, as [`bilinear_taps`] gives it: the colour
/// resolve's history taps.
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
/// at +0.5) on a `width` x `height` grid: each tap's (index, weight), in a
/// fixed order, `None` for a tap off-screen or of zero weight (so a
/// whole-pixel shift reads one tap). `None` overall when `at` is not finite
/// or far off-screen (no history, and no overflow in the casts).
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

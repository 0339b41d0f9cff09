//! Temporal accumulation: reproject last frame's accumulated `U_N`/`S_N` and
//! blend the new frame in with ONE factor per pixel for both signals.
//!
//! A per-signal or per-channel factor would make `S_N` and `U_N` averages of
//! different sample sets and silently break the ratio, so the factor depends
//! only on the history length, never on the signal values.

use super::history::{self, History, field};
use super::noise;
use super::spatial::lanes::{self, M, V, each};
use super::spatial::{self, LANES, Planes};
use super::tiles::{self, TILE};
use super::{DenoiseSettings, GuideBuffers, luminance};
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// A lane group's inputs to the reprojection and the blend, a lane per
/// pixel; zeros in a lane without a surface.
#[derive(Default)]
struct Group {
    surface: [bool; LANES],
    /// Reprojection asked for (temporal on, motion vector valid).
    want: [bool; LANES],
    skipped: [u8; LANES],
    depth: V,
    u_in: [V; 3],
    s_in: [V; 3],
    lu: V,
    lu_diffuse: V,
    pos: [V; 3],
    normal: [V; 3],
    /// Motion vector's end in the previous frame.
    at: [V; 2],
    /// The specular lobe's mirror direction (zero where not finite) and
    /// sharpness.
    dir: [V; 3],
    sharpness: V,
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

/// Which of a pixel's four bilinear taps (bit `k` for tap `k`, in the
/// order `(x0, y0)`, `(x0 + 1, y0)`, `(x0, y0 + 1)`, `(x0 + 1, y0 + 1)` from
/// the footprint's top left pixel) the reprojection took its history from; 0 where it kept
/// none (no surface, no motion vector, too little valid footprint, or the
/// light changed). The colour resolve reads these instead of testing its
/// own history again: its records hold the same surfaces, so its taps
/// would pass and fail alike.
pub type Taps = u8;

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
    let hrow = cur.row_len();
    (
        cur.data.par_chunks_mut(hrow),
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
    /// The row's block of the history's fields (`History`).
    h: &'a mut [f32],
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
        let zero = V::splat(0.0);
        for x0 in (0..w).step_by(LANES) {
            let n = LANES.min(w - x0);
            let mut px = Group::default();
            for l in 0..n {
                let x = x0 + l;
                let i = y * w + x;
                let d = guide.depth[i];
                if !(d > 0.0 && d.is_finite()) {
                    // No surface: pass through untouched, keep no history
                    // (zeros: reprojection reads them unmasked).
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
                let lobe = guide.lobe.get(i).copied().unwrap_or_default();
                // Taps compare their own direction with this one whatever
                // this pixel's weight; keep it finite.
                let dir = if lobe.dir.is_finite() {
                    lobe.dir
                } else {
                    Vec3::ZERO
                };
                let (pos, normal, at) = (guide.position[i], guide.normal[i], guide.prev_pixel[i]);
                px.surface[l] = true;
                px.want[l] = settings.temporal && guide.prev_valid[i];
                px.skipped[l] = skipped;
                px.depth.0[l] = d;
                px.lu.0[l] = lu;
                px.lu_diffuse.0[l] = lu * (1.0 - lobe.share);
                px.sharpness.0[l] = lobe.sharpness;
                for c in 0..3 {
                    px.u_in[c].0[l] = u_in[c];
                    px.s_in[c].0[l] = s_in[c];
                    px.pos[c].0[l] = pos[c];
                    px.normal[c].0[l] = normal[c];
                    px.dir[c].0[l] = dir[c];
                }
                px.at[0].0[l] = at.x;
                px.at[1].0[l] = at.y;
            }
            if !px.surface.iter().any(|&s| s) {
                // A group without a surface (sky) blends nothing: its
                // history, guides, signals and moments take their empty
                // values, as its lanes would one by one.
                let g = x0 / LANES * history::GROUP;
                h[g..g + history::GROUP].fill(0.0);
                for (k, &b) in spatial::GUIDE_BORDER.iter().enumerate() {
                    put(gd, k * gs + gp + x0, &[b; LANES], n);
                }
                for (k, &b) in spatial::SIGNAL_BORDER.iter().enumerate() {
                    put(ar, k * ss + sp + x0, &[b; LANES], n);
                }
                for k in 0..noise::COUNT {
                    put(raw, k * ms + mp + x0, &[0.0; LANES], n);
                }
                if let Some(taps) = taps.as_deref_mut() {
                    taps[x0..x0 + n].fill(0);
                }
                continue;
            }
            let hist = if px.want.iter().any(|&b| b) {
                reproject_lanes(prev, guide.width, guide.height, (x0, y), &px, settings)
            } else {
                Reprojected::default()
            };
            if let Some(taps) = taps.as_deref_mut() {
                taps[x0..x0 + n].copy_from_slice(&hist.passed[..n]);
            }
            let surface = M::from_fn(|l| px.surface[l]);
            let r = ratio_lanes(&px.s_in, &px.u_in);
            // The blend: alpha = max(1 / (len_prev + 1), 1 / cap), the
            // same for both signals and all channels; a skipped pixel
            // keeps its history as it is, a pixel without one starts it.
            let held = M::from_fn(|l| hist.ok[l]);
            let keep = held.and(M::from_fn(|l| px.skipped[l] != 0));
            let len_b = (hist.len + 1.0).min(V::splat(cap));
            let a = V::splat(1.0) / held.select(len_b, V::splat(1.0));
            let mix = Mix { held, keep, a };
            let acc_u: [V; 3] = [
                mix.of(hist.un[0], px.u_in[0]),
                mix.of(hist.un[1], px.u_in[1]),
                mix.of(hist.un[2], px.u_in[2]),
            ];
            let acc_s: [V; 3] = [
                mix.of(hist.sn[0], px.s_in[0]),
                mix.of(hist.sn[1], px.s_in[1]),
                mix.of(hist.sn[2], px.s_in[2]),
            ];
            let m1 = mix.of(hist.m1, r);
            let m2 = mix.of(hist.m2, r * r);
            let len = keep.select(hist.len, held.select(len_b, V::splat(1.0)));
            for l in 0..n {
                if px.surface[l] {
                    un[x0 + l] = Vec3::new(acc_u[0].0[l], acc_u[1].0[l], acc_u[2].0[l]);
                    sn[x0 + l] = Vec3::new(acc_s[0].0[l], acc_s[1].0[l], acc_s[2].0[l]);
                }
            }
            // Every plane the pass writes, one store per group and plane; a
            // lane without a surface takes the plane's empty value. Written
            // out plane by plane: an array of lanes to loop over is copied
            // through memory first.
            macro_rules! store {
                ($dst:expr, ($stride:expr, $pad:expr), $empty:expr; $($k:expr => $v:expr),* $(,)?) => {
                    $({
                        let v = surface.select($v, V::splat($empty[$k]));
                        put($dst, $k * $stride + $pad + x0, &v.0, n);
                    })*
                };
            }
            let (e0, e1) = encode_normal_lanes(&px.normal);
            // The group's record, every lane (a lane past the row's end
            // holds the empty values).
            let g = x0 / LANES * history::GROUP;
            macro_rules! record {
                ($($k:expr => $v:expr),* $(,)?) => {
                    $(surface.select($v, V::splat(0.0)).store(h, g + $k * LANES);)*
                };
            }
            record!(
                field::DEPTH => px.depth,
                field::PX => px.pos[0],
                field::PY => px.pos[1],
                field::PZ => px.pos[2],
                field::E0 => e0,
                field::E1 => e1,
                field::LEN => len,
                field::M1 => m1,
                field::M2 => m2,
                field::LU => px.lu,
                field::LU_DIFFUSE => px.lu_diffuse,
                field::UR => acc_u[0],
                field::UR + 1 => acc_u[1],
                field::UR + 2 => acc_u[2],
                field::SR => acc_s[0],
                field::SR + 1 => acc_s[1],
                field::SR + 2 => acc_s[2],
            );
            // The spatial filter's guides and accumulated signals (every
            // tap gives an empty pixel weight 0, the filter never writes
            // it).
            let lobe_k = spatial::lobe_weight(
                px.sharpness,
                settings.lobe_scale,
                spatial::confidence(spatial::luma(&acc_u), px.lu),
            );
            {
                use spatial::guide::*;
                store!(gd, (gs, gp), spatial::GUIDE_BORDER;
                    PX => px.pos[0],
                    PY => px.pos[1],
                    PZ => px.pos[2],
                    NX => px.normal[0],
                    NY => px.normal[1],
                    NZ => px.normal[2],
                    LU => px.lu,
                    DX => px.dir[0],
                    DY => px.dir[1],
                    DZ => px.dir[2],
                    LOBE_K => lobe_k,
                );
            }
            let r_acc = ratio_lanes(&acc_s, &acc_u);
            {
                use spatial::signal::*;
                store!(ar, (ss, sp), spatial::SIGNAL_BORDER;
                    UR => acc_u[0],
                    UR + 1 => acc_u[1],
                    UR + 2 => acc_u[2],
                    SR => acc_s[0],
                    SR + 1 => acc_s[1],
                    SR + 2 => acc_s[2],
                    RATIO => r_acc,
                );
            }
            // Per `noise`'s planes; `len` is positive on a surface (1 or
            // more up to rounding), which marks the pixel as one there.
            store!(raw, (ms, mp), [0.0; noise::COUNT];
                noise::RAW => r,
                noise::VAR_T => (m2 - m1 * m1).max(zero),
                noise::LEN => len,
            );
            // One tile row: the group's pixels share a tile.
            class[x0 / TILE] &= tiles::group_class(&px.surface[..n], &acc_u, &acc_s);
        }
    }
}

/// The temporal blend of a lane group, one factor per lane for every
/// signal: `h + (v - h) a` where the lane holds a history, `v` where it
/// starts one, `h` itself where its tile was skipped (`keep`).
struct Mix {
    held: M,
    keep: M,
    a: V,
}

impl Mix {
    #[inline(always)]
    fn of(&self, h: V, v: V) -> V {
        let b = self.held.select(h + (v - h) * self.a, v);
        self.keep.select(h, b)
    }
}

/// `luminance_ratio` per lane.
#[inline(always)]
fn ratio_lanes(s: &[V; 3], u: &[V; 3]) -> V {
    let lu = spatial::luma(u);
    let ok = lu
        .gt(V::splat(1e-30))
        .and(lu.abs().lt(V::splat(f32::INFINITY)));
    let q = spatial::luma(s) / ok.select(lu, V::splat(1.0));
    ok.select(lanes::clamp01(q), V::splat(1.0))
}

/// `encode_normal` per lane, the two components as the integers they are.
#[inline(always)]
pub(super) fn encode_normal_lanes(n: &[V; 3]) -> (V, V) {
    let zero = V::splat(0.0);
    let one = V::splat(1.0);
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    let ok = l1.gt(zero).and(l1.abs().lt(V::splat(f32::INFINITY)));
    let (px, py) = (n[0] / l1, n[1] / l1);
    let sign = |v: V| v.ge(zero).select(one, V::splat(-1.0));
    let wrap = n[2].lt(zero);
    let wx = (one - py.abs()) * sign(px);
    let wy = (one - px.abs()) * sign(py);
    let (px, py) = (wrap.select(wx, px), wrap.select(wy, py));
    (ok.select(quantize(px), zero), ok.select(quantize(py), zero))
}

/// `(v * 32767 + copysign(0.5, v)) as i16` per lane for `v` in [-1, 1], as
/// an `f32`: the magnitude truncated exactly (below 2^23, adding and
/// taking away 2^23 rounds to an integer; a rounding up is taken back).
#[inline(always)]
fn quantize(v: V) -> V {
    let zero = V::splat(0.0);
    let m = (v * 32767.0).abs() + 0.5;
    let big = V::splat(8_388_608.0);
    let r = (m + big) - big;
    let t = r.gt(m).select(r - 1.0, r);
    // `0 - t`: a zero stays +0, as the integer's conversion gives it.
    v.lt(zero).select(zero - t, t)
}

/// Stores the first `n` lanes of `v` at `at`: a whole group as one fixed
/// copy (a copy of variable length is a library call).
#[inline(always)]
pub(super) fn put(dst: &mut [f32], at: usize, v: &[f32; LANES], n: usize) {
    if n == LANES {
        dst[at..at + LANES].copy_from_slice(v);
    } else {
        dst[at..at + n].copy_from_slice(&v[..n]);
    }
}

/// Bilinear fetch of the previous accumulation at each lane's motion
/// vector end, each of the 2x2 taps validated on its own (a tap across a
/// silhouette is dropped and the rest renormalised); no history where
/// disoccluded or where the light changed ([`same_surface_lanes`],
/// [`light_changed`]). A tap off-screen or of zero weight is not read, and
/// a motion vector's end that is not finite or lies far off-screen gives no
/// history. `(gx, gy)`: the group's first pixel.
#[inline(always)]
fn reproject_lanes(
    prev: &History,
    width: u32,
    height: u32,
    (gx, gy): (usize, usize),
    px: &Group,
    s: &DenoiseSettings,
) -> Reprojected {
    let (ax, ay) = (px.at[0] - 0.5, px.at[1] - 0.5);
    let depth = px.depth;
    // Finite and not far off-screen (no overflow in the casts).
    let lim = V::splat(1e9);
    let ok0: [bool; LANES] =
        each(|l| px.want[l] && ax.0[l].abs() <= lim.0[l] && ay.0[l].abs() <= lim.0[l]);
    let ax = M::from_fn(|l| ok0[l]).select(ax, V::splat(0.0));
    let ay = M::from_fn(|l| ok0[l]).select(ay, V::splat(0.0));
    // Every lane at its own pixel's centre (a still camera's exact
    // motion): the taps are the group's own pixels, the first at weight 1,
    // the others at 0, as the integer arithmetic below would find them.
    // (Columns and rows below 2^24 are exact in `f32`.)
    let own = gx + LANES <= 1 << 24
        && gy < 1 << 24
        && ok0.iter().all(|&b| b)
        && ax.eq(V(each(|l| (gx + l) as f32))).all()
        && ay.eq(V::splat(gy as f32)).all();
    let (x0, y0) = if own {
        (each(|l| (gx + l) as i32), [gy as i32; LANES])
    } else {
        (floor_lanes(ax), floor_lanes(ay))
    };
    let taps = bilinear_weights((ax, ay), (&x0, &y0));
    let (w, h) = frame_i32(width, height);
    // A row of every group's record (`History`'s layout).
    let row = prev.row_len();
    let zero = V::splat(0.0);
    let mut wsum = zero;
    let mut un = [zero; 3];
    let mut sn = [zero; 3];
    let (mut m1, mut m2, mut len, mut lu_prev, mut lud_prev) = (zero, zero, zero, zero, zero);
    let mut passed = [0u8; LANES];
    for (k, (dx, dy, wt)) in taps.into_iter().enumerate() {
        // Per lane, its tap's pixel and where that pixel's record starts
        // (`History::at`): field `k` at `j + k * LANES`.
        let mut c = [(0usize, 0usize); LANES];
        let mut inside = [false; LANES];
        if own {
            if k > 0 {
                continue;
            }
            c = each(|l| (gx + l, gy));
            inside = [true; LANES];
        } else {
            for l in 0..LANES {
                let (tx, ty) = (x0[l] + dx, y0[l] + dy);
                // `&`, not `&&`: no branch per lane.
                inside[l] = ok0[l] & (wt.0[l] > 0.0) & (tx >= 0) & (ty >= 0) & (tx < w) & (ty < h);
                c[l] = if inside[l] {
                    (tx as usize, ty as usize)
                } else {
                    (0, 0)
                };
            }
        }
        // A tap no lane reads (a still camera reprojects onto whole
        // pixels: one tap of four) would add only zeros.
        if !inside.iter().any(|&b| b) {
            continue;
        }
        let j: [usize; LANES] =
            each(|l| c[l].1 * row + c[l].0 / LANES * history::GROUP + c[l].0 % LANES);
        // The records of the taps: where the lanes' taps are consecutive
        // pixels of a row, one load per field (a group's own pixels) or two
        // (pixels straddling two groups: the first `LANES - r` lanes from
        // the end of one group's field, the rest from the start of the
        // next one's), else a value per lane.
        let consecutive =
            (0..LANES).all(|l| inside[l] & (c[l].1 == c[0].1) & (c[l].0 == c[0].0 + l));
        // Plain loops: `array::from_fn` is compiled out of line, at
        // baseline whatever level its caller runs (`isa`).
        let mut f = [V::default(); field::COUNT];
        if consecutive {
            let r = c[0].0 % LANES;
            if r == 0 {
                for (k, f) in f.iter_mut().enumerate() {
                    *f = V::load(&prev.data, j[0] + k * LANES);
                }
            } else {
                let first = lanes::below(LANES - r);
                for (k, f) in f.iter_mut().enumerate() {
                    let at = j[0] + k * LANES;
                    let next = V::load(&prev.data, at + history::GROUP - LANES);
                    *f = first.select(V::load(&prev.data, at), next);
                }
            }
        } else {
            for (k, f) in f.iter_mut().enumerate() {
                for (v, &j) in f.0.iter_mut().zip(&j) {
                    *v = prev.data[j + k * LANES];
                }
            }
        }
        let (md, mlen, mm1, mm2) = (f[field::DEPTH], f[field::LEN], f[field::M1], f[field::M2]);
        let (mx, my, mz) = (f[field::PX], f[field::PY], f[field::PZ]);
        let (e0, e1) = (f[field::E0], f[field::E1]);
        let (mlu, mlud) = (f[field::LU], f[field::LU_DIFFUSE]);
        let (ur, ug, ub) = (f[field::UR], f[field::UR + 1], f[field::UR + 2]);
        let (sr, sg, sz) = (f[field::SR], f[field::SR + 1], f[field::SR + 2]);
        let valid = M::from_fn(|l| inside[l]).and(same_surface_lanes(
            (depth, &px.pos, &px.normal),
            (md, [mx, my, mz], (e0, e1), mlen),
            s,
        ));
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
    let light = s
        .light_test
        .then_some(((px.lu, px.lu_diffuse), (lu_prev, lud_prev)));
    let (ok, inv) = kept(&ok0, wsum, light, s.u_change);
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

/// Per lane whether a reprojection keeps its history, and the reciprocal
/// of its taps' summed weight `wsum`: the lane had a motion vector's end to
/// fetch at (`ok0`), a sliver of valid footprint is too little to trust,
/// and where `light` gives this frame's luminances of `U` and of its
/// diffuse part beside the taps' weighted sums of them, the light did not
/// change ([`light_changed`], within `tolerance`).
#[inline(always)]
pub(super) fn kept(
    ok0: &[bool; LANES],
    wsum: V,
    light: Option<((V, V), (V, V))>,
    tolerance: f32,
) -> ([bool; LANES], V) {
    let one = V::splat(1.0);
    let enough = wsum.ge(V::splat(1e-3));
    let inv = one / enough.select(wsum, one);
    let mut ok: [bool; LANES] = each(|l| ok0[l] && wsum.0[l] >= 1e-3);
    if let Some((now, (lu, lu_diffuse))) = light {
        let changed = light_changed_lanes(now, (lu * inv, lu_diffuse * inv), tolerance);
        for l in 0..LANES {
            ok[l] &= !changed[l];
        }
    }
    (ok, inv)
}

/// The four bilinear taps of each lane's position `(ax, ay)` (pixel
/// centres at whole numbers) whose floors are `(x0, y0)`: each tap's
/// offset from the floors and its weight per lane, in the taps' fixed
/// order (`Taps`).
#[inline(always)]
pub(super) fn bilinear_weights(
    (ax, ay): (V, V),
    (x0, y0): (&[i32; LANES], &[i32; LANES]),
) -> [(i32, i32, V); 4] {
    let fx = ax - V(each(|l| x0[l] as f32));
    let fy = ay - V(each(|l| y0[l] as f32));
    let one = V::splat(1.0);
    [
        (0, 0, (one - fx) * (one - fy)),
        (1, 0, fx * (one - fy)),
        (0, 1, (one - fx) * fy),
        (1, 1, fx * fy),
    ]
}

/// The frame's size as `i32`, for tap coordinates (the taps lie within
/// 1e9 + 1 of the frame).
#[inline(always)]
pub(super) fn frame_i32(width: u32, height: u32) -> (i32, i32) {
    (
        width.min(i32::MAX as u32) as i32,
        height.min(i32::MAX as u32) as i32,
    )
}

/// The floor of each lane as an integer, for values within 1e9, without a
/// libm call (baseline x86-64 has no `roundss`).
#[inline(always)]
pub(super) fn floor_lanes(v: V) -> [i32; LANES] {
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

/// The disocclusion test of one reprojection tap per lane: the history
/// record holds the same surface as the lane's pixel (depth, tangent plane
/// and normal agree) and has something accumulated. `(depth, pos, normal)`
/// is the lane group's surface, the record's `(depth, pos, (e0, e1), len)`
/// its depth, position, encoded normal and length. Shared with the colour
/// resolve, so both histories are dropped at the same places.
#[inline(always)]
pub(super) fn same_surface_lanes(
    (depth, pos, normal): (V, &[V; 3], &[V; 3]),
    (md, mpos, (e0, e1), mlen): (V, [V; 3], (V, V), V),
    s: &DenoiseSettings,
) -> M {
    let zero = V::splat(0.0);
    let [nx, ny, nz] = *normal;
    let plane = nx * (mpos[0] - pos[0]) + ny * (mpos[1] - pos[1]) + nz * (mpos[2] - pos[2]);
    let close = normal_close_lanes(decode_normal_lanes(e0, e1), (nx, ny, nz), s.min_normal_dot);
    let near_depth = (md - depth).abs().le(depth * s.depth_tolerance);
    let near_plane = plane.abs().le(depth * s.plane_tolerance);
    md.gt(zero)
        .and(near_depth)
        .and(near_plane)
        .and(mlen.gt(zero))
        .and(close)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::history::encode_normal;

    /// Normals that reach every branch of the encoding: the axes, the
    /// octants' edges, the lower hemisphere's wrap, signed zeros, values
    /// that land on a quantisation step's half, and no normal at all.
    fn hard_normals() -> Vec<Vec3> {
        let mut v = vec![
            Vec3::X,
            -Vec3::X,
            Vec3::Y,
            -Vec3::Y,
            Vec3::Z,
            -Vec3::Z,
            Vec3::new(-0.0, 0.0, 1.0),
            Vec3::new(0.0, -0.0, -1.0),
            Vec3::new(0.5 / 32767.0, 1.0, 0.0),
            Vec3::new(1.5 / 32767.0, -1.0, -0.0),
            Vec3::ZERO,
            Vec3::new(f32::NAN, 0.0, 1.0),
            Vec3::new(f32::INFINITY, 0.0, 1.0),
            Vec3::new(1e-30, -1e-30, 1e-30),
        ];
        // A spiral over the sphere, both hemispheres.
        for i in 0..4000 {
            let t = (i as f32 + 0.5) / 4000.0;
            let z = 1.0 - 2.0 * t;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let a = i as f32 * 2.399_963;
            v.push(Vec3::new(r * a.cos(), r * a.sin(), z));
        }
        v
    }

    #[test]
    fn the_lane_encoding_of_a_normal_is_the_scalar_one_bit_for_bit() {
        for group in hard_normals().chunks(LANES) {
            let mut n = [V::splat(0.0); 3];
            for (l, p) in group.iter().enumerate() {
                for c in 0..3 {
                    n[c].0[l] = p[c];
                }
            }
            let (e0, e1) = encode_normal_lanes(&n);
            for (l, p) in group.iter().enumerate() {
                let [s0, s1] = encode_normal(*p);
                let lanes = (e0.0[l].to_bits(), e1.0[l].to_bits());
                let scalar = (f32::from(s0).to_bits(), f32::from(s1).to_bits());
                assert_eq!(lanes, scalar, "normal {p}");
            }
        }
    }
}

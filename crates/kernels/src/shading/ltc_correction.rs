//! Shape correction of the LTC lobes of U with the exact BRDF.
//!
//! A linearly transformed cosine matches a lobe's integral over the whole
//! hemisphere (the fitted magnitude) but not its shape: over a light holding
//! part of a mid-rough lobe at an oblique view, `∫_P ltc` misses
//! `∫_P f cos` by several percent (up to tens of percent). Writing
//! `∫_P f cos = ∫_P ltc · (Q[f cos] / Q[ltc])`, where `Q` is a small fixed
//! cubature over the light polygon, keeps the exact LTC integral for the
//! bulk and lets the cubature supply only the *ratio* of the true lobe to the
//! model over this light, which varies slowly where the LTC is a good fit.
//! The ratio is exact for a small light and is trusted only as far as the
//! cubature is: the same cubature applied to the LTC itself, `Q[ltc]`, is
//! checked against the analytic LTC integral, and the correction fades out
//! (to the plain LTC) as they disagree by `TRUST_FULL` to `TRUST_NONE` — a light that
//! resolves the lobe's structure, where four nodes cannot follow `f` either.
//! It also fades with the light's share `s` of the lobe (factor `1 - s`):
//! over the whole lobe the LTC integral is already the fitted magnitude.
//! Not so for a view below the shading normal's horizon (a bent normal
//! seen from its back): `U` looks up the table's grazing entry there, a
//! lobe of another shape and mass than the true view's (which peaks along
//! the view ray's continuation and is cut off, just under that, where the
//! half vector goes under the surface). There the nodes, still placed by
//! the grazing lobe, integrate the exact lobe at the true view, and that
//! cubature replaces the LTC integral.
//!
//! Nodes: a fan of spherical triangles over the light's image in lobe A's
//! LTC space, from its centroid direction, one node per triangle at its
//! centroid, weighted by its solid angle taken back to the shading frame
//! (3 nodes for a triangle light, 4 for a quad); split into 4 or 16 pieces
//! per triangle where the nodes miss the analytic LTC integral
//! (`lobe_factors_lanes`). Deterministic and noise-free; the factor is
//! finite, in `[0, MAX_RATIO]`, and 1 for any degenerate input.
//!
//! Cost: this runs for every pixel and light, so it is written for speed
//! rather than reuse: `f32` in the batch's own eight lanes, one pixel per
//! lane (the factor needs ~1e-3; each triangle's triple product is taken
//! from its edge vectors, so a small light keeps its relative precision),
//! the exact lobe evaluated with the view's terms hoisted and its
//! divisions merged (a unit test checks it against `brdf::spec_local`),
//! and a rational `atan` for the solid angles (max error 0.005 rad).

use super::lanes::{Mask, Wide, Wide3, add3, cross, dot, scale3, sub3};
use super::ltc::{CellLanes, LtcCell};
use super::polygon::MAX_VERTICES;
use super::u_batch::ltc_map;
use glam::{DVec3, Vec3, Vec4};
use penumbra_isa::{self as isa, Kernel};
use std::f32::consts::{FRAC_PI_2, PI};

/// Largest correction factor (the ratio only runs away where the model has
/// almost no mass). At 88-89 degree views the exact lobe holds up to 23x
/// the LTC's mass over a far light (`ltc::image_accuracy`, side-wall), so
/// the bound sits well above that.
const MAX_RATIO: f32 = 32.0;
/// The cubature's relative miss on the analytic LTC integral up to which
/// the correction is applied in full, and at which it is dropped entirely
/// (linear fade between). With nodes in LTC space the ratio stays right
/// where the nodes still miss the model by 10-30 % (slivers seen at grazing
/// views, `ltc::image_accuracy`); a fade from 0 to 10 % dropped it there.
const TRUST_FULL: f32 = 0.05;
const TRUST_NONE: f32 = 0.5;
/// `brdf::MIN_COS`, squared where Smith's Lambda divides by cos².
const MIN_COS: f32 = super::brdf::MIN_COS;

/// The exact lobes at unit directions of the upper hemisphere, for one view:
/// `A = f_spec(F = 1) cos` and `B = A (1 - wo.h)^5`, as `brdf::spec_local`
/// computes them, with the view's terms computed once. The scalar reference
/// of `exact_lanes` (whose constants `CorrectionLanes::new` computes across
/// lanes).
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
struct ExactLobes {
    wo: Vec3,
    a2: f32,
    /// `2 (1 + Lambda(wo)) - 1`.
    lo2: f32,
    /// `2 π max(wo.z, MIN_COS)`.
    k: f32,
}

#[cfg(test)]
impl ExactLobes {
    fn new(wo: Vec3, alpha: f32) -> ExactLobes {
        ExactLobes {
            wo,
            a2: alpha * alpha,
            lo2: 1.0 + 2.0 * super::brdf::smith_lambda(alpha, wo),
            k: 2.0 * PI * wo.z.abs().max(MIN_COS),
        }
    }

    /// `(A, B)` at a unit `w` (w.z >= 0), with one division. With
    /// `h = w + wo` unnormalised, `D = a² |h|^4 / (π q²)`,
    /// `q = hx² + hy² + a² hz²`; with `c = max(wz, MIN_COS)` (as `brdf`
    /// clamps it) and `t = sqrt(c² + a² (wx² + wy²))`, `1 + Lambda(w) =
    /// (c + t) / (2 c)`, so `A = D G2 wz / (4 c cos_o) =
    /// a² |h|^4 wz / (2 π cos_o q² (c lo2 + t))`; `B = A (1 - wo.h/|h|)^5`.
    fn eval(&self, w: Vec3) -> (f32, f32) {
        let h = w + self.wo;
        if h.z <= 0.0 {
            return (0.0, 0.0);
        }
        let l2 = h.length_squared().max(1e-30);
        let q = h.x * h.x + h.y * h.y + self.a2 * h.z * h.z;
        let c = w.z.max(MIN_COS);
        let t = (c * c + self.a2 * (w.x * w.x + w.y * w.y)).sqrt();
        let num = self.a2 * l2 * l2 * w.z;
        // h = 0 only with w and wo both grazing, where num = 0 too.
        let den = (self.k * q * q * (c * self.lo2 + t)).max(1e-30);
        let len = l2.sqrt();
        let inv = 1.0 / (den * len);
        let a = num * len * inv;
        let cos_oh = (self.wo.dot(w) + 1.0) * den * inv;
        let m = 1.0 - cos_oh.clamp(0.0, 1.0);
        let m2 = m * m;
        (a, a * m2 * m2 * m)
    }
}

/// How much each part of this light's U weighs in one pixel: lobe A's value
/// (`ks mag share_a`), lobe B's (`(1 - ks) fres share_b`) and the diffuse
/// part (`kd ff`), each averaged over the channels, and what the lights
/// shaded before it give the pixel. The refinement spends nodes on a pixel
/// only where the cubature's miss would show in it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stakes {
    pub a: Wide,
    pub b: Wide,
    pub diffuse: Wide,
    /// What the lights shaded before this one give the pixel, in this
    /// light's units (radiance divided out).
    pub others: Wide,
}

/// The factors to multiply the two lobes' LTC integrals by, `(A, B)`.
///
/// - `poly`: the light polygon in the shading frame (z = normal, view in
///   the xz plane), clipped to the upper hemisphere — what the Lambert
///   term integrates;
/// - `cell`: the table cell U looked up;
/// - `share_a`, `share_b`: each lobe's LTC integral over its magnitude (the
///   light's share of the modelled lobe, in [0, 1]);
/// - `wo`: the view as the table was looked up, `(sin θv, 0, cos θv)`;
///   `alpha`: GGX alpha;
/// - `stakes`: `Stakes` (a, b, diffuse, others) of this pixel and light.
///
/// One pixel in every lane of the batch's correction (lane 0 read back),
/// so the scalar and batched paths compute the factor with the same
/// arithmetic. Only the light's image in LTC space is made in `f64` here:
/// the scalar path takes the pixels whose LTC map is too ill-conditioned
/// for `f32` (`u_batch::MAX_CONDITION`); the image's unit vectors are
/// well conditioned whatever the map.
pub fn lobe_factors(
    poly: &[DVec3],
    cell: &LtcCell,
    share_a: f32,
    share_b: f32,
    wo: Vec3,
    alpha: f32,
    stakes: [f32; 4],
) -> (f32, f32) {
    let n = poly.len().min(MAX_VERTICES);
    let p = Pixel {
        cell,
        wo,
        alpha,
        share_a,
        share_b,
        stakes: Stakes {
            a: Wide::splat(stakes[0]),
            b: Wide::splat(stakes[1]),
            diffuse: Wide::splat(stakes[2]),
            others: Wide::splat(stakes[3]),
        },
    };
    if n < 3 {
        return (1.0, 1.0);
    }
    isa::run_at_most_avx2(OnePixel {
        poly: &poly[..n],
        p,
    })
}

/// One pixel's inputs to `lobe_factors` beyond its polygon.
struct Pixel<'a> {
    cell: &'a LtcCell,
    wo: Vec3,
    alpha: f32,
    share_a: f32,
    share_b: f32,
    stakes: Stakes,
}

/// `lobe_factors` of one polygon, in every lane, as a `Kernel` (`isa`).
struct OnePixel<'a> {
    poly: &'a [DVec3],
    p: Pixel<'a>,
}

impl Kernel for OnePixel<'_> {
    type Out = (f32, f32);
    #[inline(always)]
    fn run(self) -> (f32, f32) {
        one_pixel(self.poly, &self.p)
    }
}

#[inline(always)]
fn one_pixel(poly: &[DVec3], p: &Pixel) -> (f32, f32) {
    let cells = CellLanes::splat(p.cell);
    let view = [Vec4::splat(p.wo.x), Vec4::splat(p.wo.z)];
    let alpha = Vec4::splat(p.alpha);
    let k = CorrectionLanes::new([(&cells, view, alpha), (&cells, view, alpha)]);
    let m = k.ma.map(|m| f64::from(m.0[0]));
    let mut o = [[Wide::ZERO; 3]; MAX_VERTICES];
    for (o, v) in o.iter_mut().zip(poly) {
        // As the batch's `inv_len`: a vertex at the point stays zero.
        let v = *v / v.length_squared().max(f64::MIN_POSITIVE).sqrt();
        let img = DVec3::new(
            m[0].mul_add(v.x, m[1] * v.z),
            v.y,
            m[2].mul_add(v.x, m[3] * v.z),
        );
        let img = img / img.length_squared().max(f64::MIN_POSITIVE).sqrt();
        *o = [Wide::splat(img.x), Wide::splat(img.y), Wide::splat(img.z)];
    }
    let (a, b) = factors(
        &o[..poly.len()],
        None,
        &k,
        Wide::splat(p.share_a),
        Wide::splat(p.share_b),
        &p.stakes,
    );
    (a.0[0], b.0[0])
}

/// The correction's per-lane constants for a batch of pixels
/// (`lobe_factors_lanes`): each lane's two lobe models and exact lobes, as
/// `lobe_factors` builds them for one pixel.
#[derive(Clone, Copy, Debug, Default)]
pub struct CorrectionLanes {
    /// Lobe A's `M^-1` (m00, m02, m20, m22): it takes the light into the
    /// space where the nodes are placed.
    ma: [Wide; 4],
    kda: Wide,
    kca: Wide,
    mb: [Wide; 4],
    kdb: Wide,
    kcb: Wide,
    /// Lobe A's `M` (the inverse of `ma`) and `|det M|`: a node's
    /// direction and solid angle back in the shading frame.
    inv: [Wide; 4],
    det: Wide,
    wox: Wide,
    woz: Wide,
    a2: Wide,
    lo2: Wide,
    k: Wide,
    /// The lobes' magnitudes, for the factors.
    maga: Wide,
    magb: Wide,
    /// 1 where the view is below the horizon, 0 above it (`factor_lanes`).
    below: Wide,
}

/// How many constants `CorrectionLanes` holds per lane.
const CONSTANTS: usize = 25;

impl CorrectionLanes {
    /// Each half batch (lanes 0-3, 4-7) from its table cells, views
    /// `(sin θv, 0, cos θv)` (`wo` = their x and z) and GGX alphas. In
    /// `f32`, four lanes per `Vec4`, in the order of operations of the
    /// scalar formulas (so the same values bit for bit as one pixel at a
    /// time).
    #[inline(always)]
    pub fn new(halves: [(&CellLanes, [Vec4; 2], Vec4); 2]) -> Self {
        // Plain code: `[T; N]::map` and `array::from_fn` are compiled out
        // of line, at baseline whatever level the caller runs (`isa`).
        let [(c0, v0, a0), (c1, v1, a1)] = halves;
        let (lo, hi) = (half_constants(c0, v0, a0), half_constants(c1, v1, a1));
        let mut c = [Wide::ZERO; CONSTANTS];
        for (i, c) in c.iter_mut().enumerate() {
            *c = Wide::from_halves(lo[i], hi[i]);
        }
        CorrectionLanes {
            ma: [c[0], c[1], c[2], c[3]],
            kda: c[4],
            kca: c[5],
            mb: [c[6], c[7], c[8], c[9]],
            kdb: c[10],
            kcb: c[11],
            inv: [c[12], c[13], c[14], c[15]],
            det: c[16],
            wox: c[17],
            woz: c[18],
            a2: c[19],
            lo2: c[20],
            k: c[21],
            maga: c[22],
            magb: c[23],
            below: c[24],
        }
    }
}

/// `CorrectionLanes`' constants of four lanes, in its field order.
#[inline(always)]
fn half_constants(cells: &CellLanes, [wox, woz]: [Vec4; 2], alpha: Vec4) -> [Vec4; CONSTANTS] {
    // One division for both lobes' `1 / hmass`.
    let inv = Vec4::ONE / (Vec4::splat(PI) * cells.hmass() * cells.fhmass());
    let (ma, kda, kca) = lobe_model(cells.ma(), cells.mag(), cells.mix(), inv * cells.fhmass());
    let (mb, kdb, kcb) = lobe_model(cells.mb(), cells.fres(), cells.fmix(), inv * cells.hmass());
    // `M` from `M^-1`: the 2x2 inverse on (x, z); y is kept.
    let r = Vec4::ONE / (ma[0] * ma[3] - ma[1] * ma[2]);
    let m = [ma[3] * r, -ma[1] * r, -ma[2] * r, ma[0] * r];
    // `ExactLobes::new`: `brdf::smith_lambda(alpha, wo)` with wo.y = 0
    // (sin² = wo.x² + 0 is wo.x² exactly).
    let a2 = alpha * alpha;
    let cos2 = (woz * woz).max(Vec4::splat(MIN_COS * MIN_COS));
    let a = a2 * (wox * wox) / cos2;
    let lambda = a / (Vec4::splat(2.0) * ((Vec4::ONE + a).sqrt() + Vec4::ONE));
    let lo2 = Vec4::ONE + Vec4::splat(2.0) * lambda;
    let k = Vec4::splat(2.0 * PI) * woz.abs().max(Vec4::splat(MIN_COS));
    [
        ma[0],
        ma[1],
        ma[2],
        ma[3],
        kda,
        kca,
        mb[0],
        mb[1],
        mb[2],
        mb[3],
        kdb,
        kcb,
        m[0],
        m[1],
        m[2],
        m[3],
        r.abs(),
        wox,
        woz,
        a2,
        lo2,
        k,
        cells.mag(),
        cells.fres(),
        Vec4::select(woz.cmplt(Vec4::ZERO), Vec4::ONE, Vec4::ZERO),
    ]
}

/// One lobe's LTC model `mag ((1 - mix) D / hmass + mix cos / π)` with its
/// constants folded: `D` of a unit `w` is `det o.z / (π |o|^4)` for
/// `o = M^-1 w`, so the model is `kd o.z / |o|^4 + kc w.z` (o.z > 0).
/// Returns `(M^-1, kd, kc)` per lane; `inv_hmass` is `1 / (π hmass)`.
#[inline(always)]
fn lobe_model(m: [Vec4; 4], mag: Vec4, mix: Vec4, inv_hmass: Vec4) -> ([Vec4; 4], Vec4, Vec4) {
    let det = (m[0] * m[3] - m[1] * m[2]).abs();
    let kd = mag * (Vec4::ONE - mix) * det * inv_hmass;
    let kc = mag * mix * Vec4::splat(1.0 / PI);
    (m, kd, kc)
}

/// A lobe's LTC model (`lobe_model`'s constants) at unit `w`, per lane:
/// lobe B's at a node (lobe A's is taken in its own LTC space, `node`).
#[inline(always)]
fn model_lanes(m: &[Wide; 4], kd: Wide, kc: Wide, w: &Wide3) -> Wide {
    let ox = m[0].mul_add(w[0], m[1] * w[2]);
    let oz = m[2].mul_add(w[0], m[3] * w[2]);
    let l2 = ox.mul_add(ox, w[1].mul_add(w[1], oz * oz));
    kc.mul_add(
        w[2],
        kd * oz.max(Wide::ZERO) / (l2 * l2).max(Wide::splat(1e-30)),
    )
}

/// `ExactLobes::eval` per lane.
#[inline(always)]
fn exact_lanes(k: &CorrectionLanes, w: &Wide3) -> (Wide, Wide) {
    let h = [w[0] + k.wox, w[1], w[2] + k.woz];
    let l2 = dot(&h, &h).max(Wide::splat(1e-30));
    let hxy = h[0].mul_add(h[0], h[1] * h[1]);
    let q = (k.a2 * h[2]).mul_add(h[2], hxy);
    let c = w[2].max(Wide::splat(MIN_COS));
    let wxy = w[0].mul_add(w[0], w[1] * w[1]);
    // Square roots as `x / sqrt(x)` with the approximate `1 / sqrt`: the
    // factor needs ~1e-3, and the divider was the bottleneck here.
    let t2 = c.mul_add(c, k.a2 * wxy);
    let t = t2 * t2.rsqrt_approx();
    let num = k.a2 * l2 * l2 * w[2];
    let den = (k.k * q * q * c.mul_add(k.lo2, t)).max(Wide::splat(1e-30));
    // D is 0 where the half vector is under the surface: only a view
    // below the horizon puts it there for a direction above.
    let a = h[2].gt(Wide::ZERO).select(num / den, Wide::ZERO);
    let wo_w = k.wox.mul_add(w[0], k.woz * w[2]);
    let cos_oh = (wo_w + Wide::ONE) * l2.rsqrt_approx();
    let m = Wide::ONE - cos_oh.clamp(0.0, 1.0);
    let m2 = m * m;
    (a, a * m2 * m2 * m)
}

/// `atan2_pos` per lane (the same octant reduction, as selects).
#[inline(always)]
fn atan2_pos_lanes(y: Wide, x: Wide) -> Wide {
    let steep = x.abs().lt(y);
    let num = steep.select(-x, y);
    let den = steep.select(y, x);
    let base = steep.select(
        Wide::splat(FRAC_PI_2),
        x.lt(Wide::ZERO).select(Wide::splat(PI), Wide::ZERO),
    );
    let d = den.mul_add(den, Wide::splat(0.28086) * num * num);
    base + num * den / d.max(Wide::splat(1e-30))
}

/// A spherical triangle of lobe A's LTC space, per lane: three (nearly)
/// unit vectors.
type Tri = [Wide3; 3];

/// `lobe_factors` for the batch's `LANES` (8) pixels at once, across
/// pixels: lane `l` is one pixel's light polygon (clipped to the horizon),
/// given by its `N` unit vertices `u` in the shading frame (zero for a
/// vertex at the shading point). A lane's polygon may repeat a vertex in
/// consecutive slots (the batch pads clipped polygons to one vertex count;
/// `real` says which slots are its own): its repeated slots add
/// zero-area triangles to the fan and are left out of its centre.
///
/// The nodes are placed in lobe A's LTC space, where that lobe is a
/// clamped cosine at every roughness and view: the polygon's image is
/// fanned there from its centroid direction, one node per fan triangle at
/// its centroid, and each node is taken back to the shading frame with its
/// solid angle scaled by `|det M| / |M o|^3`. A fan in the shading frame
/// instead puts four nodes across a glossy highlight that a light resolves,
/// and misses the lobe's shape by tens of percent (docs/accuracy.md).
///
/// Where the nodes are unsure (`refine_weight`) by more than `REFINE_AT`
/// of the pixel's `U` (this light's and the lights' shaded before it), each
/// fan triangle is split into 4 pieces, and where the ratio still moves
/// (`settle_weight`) into 16, blended in continuously; at 16 pieces a
/// ratio that settles geometrically is carried to its limit
/// (`extrapolated`); the trust fade then judges the finest level used. A
/// level is computed for the whole batch when any lane asks for it, and a
/// lane that does not ask keeps exactly its coarser sums (a select), so
/// each lane's answer is its own whatever its neighbours.
///
/// Everything in `f32`, one pixel per lane, one node per fan triangle and
/// lane. What would cancel for a small light is kept relative: each
/// triangle's triple product is taken from its two edge vectors from its
/// first corner (differences of nearby unit vectors, exact in `f32`), so a
/// light 1e-3 rad across keeps its solid angles to ~1e-4.
pub fn lobe_factors_lanes(
    u: &[Wide3],
    real: Option<&[Mask]>,
    k: &CorrectionLanes,
    share_a: Wide,
    share_b: Wide,
    stakes: &Stakes,
) -> (Wide, Wide) {
    isa::run_at_most_avx2(Factors {
        u,
        real,
        k,
        share_a,
        share_b,
        stakes,
    })
}

/// `lobe_factors_lanes` as a `Kernel` (`isa`): out of line, one copy per
/// level whatever the polygon's vertex count (a count known at compile time
/// bought no speed here and cost a copy per count).
struct Factors<'a> {
    u: &'a [Wide3],
    real: Option<&'a [Mask]>,
    k: &'a CorrectionLanes,
    share_a: Wide,
    share_b: Wide,
    stakes: &'a Stakes,
}

impl Kernel for Factors<'_> {
    type Out = (Wide, Wide);
    #[inline(always)]
    fn run(self) -> (Wide, Wide) {
        // Plain loops, no closures: a closure is compiled out of line at
        // baseline, whatever instruction set its caller runs (`isa`).
        let n = self.u.len().min(MAX_VERTICES);
        let mut o = [[Wide::ZERO; 3]; MAX_VERTICES];
        for (o, u) in o.iter_mut().zip(&self.u[..n]) {
            *o = unit(&ltc_map(&self.k.ma, u));
        }
        factors(
            &o[..n],
            self.real,
            self.k,
            self.share_a,
            self.share_b,
            self.stakes,
        )
    }
}

/// The factors from the polygon's image `o` in lobe A's LTC space (unit
/// vectors, zero for a vertex at the point).
#[inline(always)]
fn factors(
    o: &[Wide3],
    real: Option<&[Mask]>,
    k: &CorrectionLanes,
    share_a: Wide,
    share_b: Wide,
    stakes: &Stakes,
) -> (Wide, Wide) {
    let n = o.len().min(MAX_VERTICES);
    let mut centre = [Wide::ZERO; 3];
    for i in 0..n {
        let mut v = o[i];
        if let Some(real) = real {
            for x in &mut v {
                *x = real[i].select(*x, Wide::ZERO);
            }
        }
        centre = add3(&centre, &v);
    }
    let c = scale3(
        &centre,
        dot(&centre, &centre).max(Wide::splat(1e-30)).rsqrt_approx(),
    );
    let fan = Fan { c, o: &o[..n] };
    let mut sums = [Wide::ZERO; 4];
    for i in 0..n {
        node(k, tri_node(&fan.tri(i)), &mut sums);
    }
    let coarse = sums;
    let ltc = (share_a * k.maga, share_b * k.magb);
    let t1 = refine_weight(&coarse, ltc, stakes);
    let sums = if t1.gt(Wide::ZERO).any() {
        let fine = isa::run_at_most_avx2(Refined { k, fan, level: 1 });
        let t2 = settle_weight(&coarse, &fine, ltc, stakes);
        let fine = if t2.gt(Wide::ZERO).any() {
            let finer = isa::run_at_most_avx2(Refined { k, fan, level: 2 });
            let finer = extrapolated(&coarse, &fine, &finer);
            blend(&fine, &finer, t2)
        } else {
            fine
        };
        blend(&coarse, &fine, t1)
    } else {
        coarse
    };
    let [qfa, qfb, qga, qgb] = sums;
    (
        factor_lanes(qfa, qga, share_a, k.maga, k.below),
        factor_lanes(qfb, qgb, share_b, k.magb, k.below),
    )
}

/// What the nodes are unsure of (`refine_weight`), as a share of the
/// pixel's stakes (`Stakes`), at which the fan triangles are split (and at
/// twice which the split pieces replace them entirely). Chosen on
/// `ltc::image_accuracy` among 0.005 / 0.02 / 0.05: 0.05 misses the goal on
/// two scenes; 0.005 costs 1.4x the U time of 0.02 for the same errors
/// (docs/accuracy.md).
const REFINE_AT: f32 = 0.02;

/// How far to trust the next level over `sums` (`[Q[fA], Q[fB], Q[ltcA],
/// Q[ltcB]]`), by `trust_next`.
/// Per lobe, the nodes are unsure of their miss on the analytic LTC
/// integral, and of the correction they ask for (`Q[f] / Q[ltc] - 1`): a
/// lobe sharper than its model is undersampled by the same nodes that
/// integrate the model well, so a correction that would change the pixel
/// is checked at the finer level before it is applied.
#[inline(always)]
fn refine_weight(sums: &[Wide; 4], (ltc_a, ltc_b): (Wide, Wide), s: &Stakes) -> Wide {
    trust_next(
        unsure_coarse(sums[0], sums[2], ltc_a),
        unsure_coarse(sums[1], sums[3], ltc_b),
        s,
    )
}

/// One lobe's doubt for `refine_weight`.
#[inline(always)]
fn unsure_coarse(qf: Wide, qg: Wide, ltc: Wide) -> Wide {
    let m = (qg / ltc - Wide::ONE).abs() + (qf / qg - Wide::ONE).abs();
    ltc.gt(Wide::ZERO).and(m.finite()).select(m, Wide::ZERO)
}

/// 0 while the lobes' doubts `unsure_a`, `unsure_b` weigh under `REFINE_AT`
/// of the pixel's stakes, rising linearly to 1 at twice that.
#[inline(always)]
fn trust_next(unsure_a: Wide, unsure_b: Wide, s: &Stakes) -> Wide {
    let total = (s.a + s.b + s.diffuse + s.others).max(Wide::splat(1e-30));
    let weighed = unsure_a.mul_add(s.a, unsure_b * s.b) / total;
    let t = (weighed * Wide::splat(1.0 / REFINE_AT) - Wide::ONE).clamp(0.0, 1.0);
    t.finite().select(t, Wide::ZERO)
}

/// How far to trust the finest level over the split sums `fine`: as
/// `refine_weight`, but what the split nodes are unsure of is their own miss
/// on the analytic LTC integral and how far the ratio `Q[f] / Q[ltc]` moved
/// from the coarse nodes to them (the size of the correction no longer
/// counts: its check is this change).
#[inline(always)]
fn settle_weight(
    coarse: &[Wide; 4],
    fine: &[Wide; 4],
    (ltc_a, ltc_b): (Wide, Wide),
    s: &Stakes,
) -> Wide {
    trust_next(
        unsure_settled(coarse, fine, 0, ltc_a),
        unsure_settled(coarse, fine, 1, ltc_b),
        s,
    )
}

/// One lobe's doubt for `settle_weight`.
#[inline(always)]
fn unsure_settled(coarse: &[Wide; 4], fine: &[Wide; 4], lobe: usize, ltc: Wide) -> Wide {
    let m =
        (fine[lobe + 2] / ltc - Wide::ONE).abs() + (ratio(fine, lobe) - ratio(coarse, lobe)).abs();
    ltc.gt(Wide::ZERO).and(m.finite()).select(m, Wide::ZERO)
}

/// `Q[f] / Q[ltc]` of `lobe` in `sums`.
#[inline(always)]
fn ratio(sums: &[Wide; 4], lobe: usize) -> Wide {
    sums[lobe] / sums[lobe + 2]
}

/// Largest ratio of successive changes of `Q[f] / Q[ltc]` over the levels
/// (1, 4, 16 pieces) that is taken for a geometric convergence.
const SETTLING: f32 = 0.6;

/// The finest sums with each lobe's ratio `Q[f] / Q[ltc]` carried to its
/// limit where the three levels' ratios settle geometrically (the changes
/// keep their sign and shrink by at most `SETTLING`): at grazing views the
/// exact lobe is sharper than its model where the pieces are largest, and
/// the ratio approaches its limit slowly (docs/accuracy.md).
#[inline(always)]
fn extrapolated(coarse: &[Wide; 4], fine: &[Wide; 4], finer: &[Wide; 4]) -> [Wide; 4] {
    let mut out = *finer;
    for lobe in 0..2 {
        let (r0, r1, r2) = (ratio(coarse, lobe), ratio(fine, lobe), ratio(finer, lobe));
        let (d1, d2) = (r1 - r0, r2 - r1);
        let q = d2 / d1;
        let settles = q.gt(Wide::ZERO).and(q.lt(Wide::splat(SETTLING)));
        let limit = r2 + d2 * q / (Wide::ONE - q);
        let qf = limit * finer[lobe + 2];
        out[lobe] = settles
            .and(qf.finite())
            .and(qf.ge(Wide::ZERO))
            .select(qf, finer[lobe]);
    }
    out
}

/// `a + t (b - a)`, per sum; exactly `a` where `t` is 0 (whatever `b`
/// holds in a lane that did not ask for the finer level).
#[inline(always)]
fn blend(a: &[Wide; 4], b: &[Wide; 4], t: Wide) -> [Wide; 4] {
    let mut out = [Wide::ZERO; 4];
    let some = t.gt(Wide::ZERO);
    for i in 0..4 {
        out[i] = some.select(t.mul_add(b[i] - a[i], a[i]), a[i]);
    }
    out
}

/// The cubature sums with every fan triangle split into `4^level` pieces
/// (`level` 1 or 2; midpoints of the edges, on the sphere), a node per
/// piece. Kept out of line, as a `Kernel` of its own (`isa`), with one
/// node evaluation in its loop: one copy per instruction set, whatever the
/// polygon and the level.
struct Refined<'a> {
    k: &'a CorrectionLanes,
    fan: Fan<'a>,
    level: u32,
}

/// The fan over a polygon's image: triangle `i` joins the centroid
/// direction `c` to vertices `i` and `i + 1` of `o` (made where it is read,
/// not stored).
#[derive(Clone, Copy)]
struct Fan<'a> {
    c: Wide3,
    o: &'a [Wide3],
}

impl Fan<'_> {
    #[inline(always)]
    fn tri(&self, i: usize) -> Tri {
        let n = self.o.len();
        [
            self.c,
            self.o[i],
            self.o[if i + 1 == n { 0 } else { i + 1 }],
        ]
    }
}

impl Kernel for Refined<'_> {
    type Out = [Wide; 4];
    #[inline(always)]
    fn run(self) -> [Wide; 4] {
        refined_sums(self.k, self.fan, self.level)
    }
}

#[inline(always)]
fn refined_sums(k: &CorrectionLanes, fan: Fan, level: u32) -> [Wide; 4] {
    let mut sums = [Wide::ZERO; 4];
    // Level 1 takes each fan triangle's four pieces as one group; level 2
    // splits each piece again, four groups of four, in the same order.
    let groups = if level == 1 { 1 } else { 4 };
    for i in 0..fan.o.len() {
        let t = fan.tri(i);
        // A fan triangle degenerate in every lane (a padding slot) adds 0.
        if !tri_node(&t).0.gt(Wide::ZERO).any() {
            continue;
        }
        let pieces = split(&t);
        for g in 0..groups {
            let finer;
            let group = if level == 1 {
                &pieces
            } else {
                finer = split(&pieces[g]);
                &finer
            };
            for piece in group {
                node(k, tri_node(piece), &mut sums);
            }
        }
    }
    sums
}

/// A spherical triangle's four pieces: its corners' and its centre's, cut
/// at the edges' midpoints.
#[inline(always)]
fn split(t: &Tri) -> [Tri; 4] {
    let ab = unit(&add3(&t[0], &t[1]));
    let bc = unit(&add3(&t[1], &t[2]));
    let ca = unit(&add3(&t[2], &t[0]));
    [[t[0], ab, ca], [ab, t[1], bc], [ca, bc, t[2]], [ab, bc, ca]]
}

/// `v / |v|` per lane (to the approximate `1 / sqrt`'s 5e-6: a triangle's
/// triple product only scales with its corners' lengths); zero stays zero.
#[inline(always)]
fn unit(v: &Wide3) -> Wide3 {
    scale3(
        v,
        dot(v, v).max(Wide::splat(f32::MIN_POSITIVE)).rsqrt_approx(),
    )
}

/// A triangle's triple product (from its edge vectors `b - a`, `c - a`,
/// which keep a small triangle's precision: `a . (b x c) = a . ((b - a) x
/// (c - a))`), its Van Oosterom-Strackee denominator (`tan(Ω / 2) = num /
/// den`) and its (unnormalised) centroid direction.
#[inline(always)]
fn tri_node(t: &Tri) -> (Wide, Wide, Wide3) {
    let [a, b, c] = t;
    let num = dot(a, &cross(&sub3(b, a), &sub3(c, a))).abs();
    let den = Wide::ONE + dot(a, b) + dot(b, c) + dot(c, a);
    (num, den, add3(&add3(a, b), c))
}

/// One node per lane (a triangle's `tri_node`) into `sums`: its direction
/// and solid angle taken back to the shading frame, where the exact lobes
/// and lobe B's model are evaluated; lobe A's model is read off the node's
/// direction in lobe A's LTC space, where the nodes are placed.
#[inline(always)]
fn node(k: &CorrectionLanes, (num, den, m): (Wide, Wide, Wide3), sums: &mut [Wide; 4]) {
    let omega = Wide::splat(2.0) * atan2_pos_lanes(num, den);
    let o = scale3(&m, dot(&m, &m).max(Wide::splat(1e-30)).rsqrt_approx());
    let wm = [
        k.inv[0].mul_add(o[0], k.inv[1] * o[2]),
        o[1],
        k.inv[2].mul_add(o[0], k.inv[3] * o[2]),
    ];
    let r = dot(&wm, &wm).max(Wide::splat(1e-30)).rsqrt_approx();
    let w = scale3(&wm, r);
    // The node's solid angle in the shading frame, `omega |det M| / |M o|^3`.
    let cone = w[2].gt(Wide::ZERO).select(omega * k.det, Wide::ZERO);
    let wt = cone * r * r * r;
    let (ea, eb) = exact_lanes(k, &w);
    sums[0] = wt.mul_add(ea, sums[0]);
    sums[1] = wt.mul_add(eb, sums[1]);
    // Lobe A's model where the nodes are placed: `M^-1 w` is `o r`, so
    // its cosine part `kd (M^-1 w).z / |M^-1 w|^4` times the weight is
    // `omega |det M| kd o.z` (`o` is unit to 5e-6), with no division.
    sums[2] = wt.mul_add(
        k.kca * w[2],
        cone.mul_add(k.kda * o[2].max(Wide::ZERO), sums[2]),
    );
    sums[3] = wt.mul_add(model_lanes(&k.mb, k.kdb, k.kcb, &w), sums[3]);
}

/// `factor` per lane.
#[inline(always)]
fn factor_lanes(qf: Wide, qg: Wide, share: Wide, mag: Wide, below: Wide) -> Wide {
    let s = share.clamp(0.0, 1.0);
    let ltc = s * mag;
    let r = (qf / qg).min(Wide::splat(MAX_RATIO));
    let miss = (qg / ltc - Wide::ONE).abs();
    let trust = ((Wide::splat(TRUST_NONE) - miss) * Wide::splat(1.0 / (TRUST_NONE - TRUST_FULL)))
        .clamp(0.0, 1.0);
    let k = Wide::ONE + (r - Wide::ONE) * trust * (Wide::ONE - s);
    let ok = qg
        .gt(Wide::ZERO)
        .and(ltc.gt(Wide::ZERO))
        .and(qf.ge(Wide::ZERO))
        .and(miss.finite())
        .and(k.finite());
    let k = ok.select(k.clamp(0.0, MAX_RATIO), Wide::ONE);
    // Below the horizon the model is the grazing view's lobe, not this
    // one's: the nodes' integral of the exact lobe stands alone, and may
    // be any multiple of the model's where the model has little mass.
    let direct = qf / ltc;
    let direct_ok = ltc
        .gt(Wide::ZERO)
        .and(qf.ge(Wide::ZERO))
        .and(direct.finite());
    below.gt(Wide::ZERO).and(direct_ok).select(direct, k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shading::brdf;

    /// The constants of one pixel in all eight lanes.
    fn one(cell: &LtcCell, wo: Vec3, alpha: f32) -> CorrectionLanes {
        let cells = CellLanes::splat(cell);
        let view = [Vec4::splat(wo.x), Vec4::splat(wo.z)];
        let alpha = Vec4::splat(alpha);
        CorrectionLanes::new([(&cells, view, alpha), (&cells, view, alpha)])
    }

    #[test]
    fn exact_lobes_equal_the_brdf() {
        for &r in &[0.05f32, 0.2, 0.5, 1.0] {
            let alpha = brdf::alpha_from_roughness(r);
            for &tv in &[0.0f32, 0.7, 1.5, 1.5607, 1.62, 1.9] {
                let wo = Vec3::new(tv.sin(), 0.0, tv.cos());
                let e = ExactLobes::new(wo, alpha);
                // The lane version the correction runs.
                let cell = LtcCell {
                    hmass: 1.0,
                    fhmass: 1.0,
                    ..Default::default()
                };
                let k = one(&cell, wo, alpha);
                for k_ in 0..200 {
                    let (t, p) = (1.55 * (k_ % 20) as f32 / 19.0, 0.3 * k_ as f32);
                    let w = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
                    let (f, cos_oh) = brdf::spec_local(alpha, w, wo);
                    let (a, b) = (f * w.z, f * w.z * brdf::schlick_weight(cos_oh));
                    let (ea, eb) = e.eval(w);
                    let wl = [Wide::splat(w.x), Wide::splat(w.y), Wide::splat(w.z)];
                    let (la, lb) = exact_lanes(&k, &wl);
                    assert!(
                        (la.0[0] - a).abs() <= 1e-4 * a + 1e-9,
                        "lanes A {la:?} vs {a}"
                    );
                    assert!(
                        (lb.0[0] - b).abs() <= 1e-3 * b + 1e-9,
                        "lanes B {lb:?} vs {b}"
                    );
                    assert!(
                        (ea - a).abs() <= 1e-4 * a + 1e-9,
                        "A {ea} vs {a} at {w}, {wo}, r {r}"
                    );
                    assert!(
                        (eb - b).abs() <= 1e-3 * b + 1e-9,
                        "B {eb} vs {b} at {w}, {wo}, r {r}"
                    );
                }
            }
        }
    }

    /// Every constant of lane `l`, in a fixed order.
    fn constants(k: &CorrectionLanes, l: usize) -> Vec<f32> {
        let mut all = k.ma.to_vec();
        all.extend(k.mb);
        all.extend(k.inv);
        all.extend([
            k.kda, k.kca, k.kdb, k.kcb, k.det, k.wox, k.woz, k.a2, k.lo2, k.k, k.maga, k.magb,
        ]);
        all.iter().map(|w| w.0[l]).collect()
    }

    #[test]
    fn lane_constants_are_each_pixels_constants_bit_for_bit() {
        // What the batch builds for eight different pixels, against what
        // the scalar path (`lobe_factors`) builds for each alone.
        let p = crate::shading::ltc::packed_table();
        let at: [(f32, f32); 8] = [
            (0.05, 0.99),
            (0.5, 0.3),
            (0.9, 0.01),
            (0.27, 0.7),
            (0.15, 0.05),
            (0.7, 0.85),
            (1.0, 1.0),
            (0.33, 0.42),
        ];
        let view = at.map(|(_, c)| Vec3::new((1.0 - c * c).sqrt(), 0.0, c));
        let alpha = at.map(|(r, _)| brdf::alpha_from_roughness(r));
        let half = |h: usize| {
            let q: [(f32, f32); 4] = std::array::from_fn(|l| at[4 * h + l]);
            let cells = CellLanes::from_packed(&q.map(|(r, c)| p.lookup_packed(r, c)));
            let v: [Vec3; 4] = std::array::from_fn(|l| view[4 * h + l]);
            let a: [f32; 4] = std::array::from_fn(|l| alpha[4 * h + l]);
            (
                cells,
                [v.map(|v| v.x), v.map(|v| v.z)].map(Vec4::from_array),
                Vec4::from_array(a),
            )
        };
        let (h0, h1) = (half(0), half(1));
        let lanes = CorrectionLanes::new([(&h0.0, h0.1, h0.2), (&h1.0, h1.1, h1.2)]);
        for (l, &(r, c)) in at.iter().enumerate() {
            let single = one(&p.lookup(r, c), view[l], alpha[l]);
            let (a, b) = (constants(&lanes, l), constants(&single, 0));
            for (i, (a, b)) in a.iter().zip(&b).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "constant {i}, lane {l}");
            }
        }
    }

    #[test]
    fn fast_atan2_is_within_its_stated_error() {
        for k in 0..=2000 {
            let t = PI * k as f32 / 2000.0;
            let (y, x) = (t.sin(), t.cos());
            let got = atan2_pos_lanes(Wide::splat(y), Wide::splat(x)).0[6];
            assert!((got - t).abs() < 0.005, "{t}");
        }
    }

    #[test]
    fn small_triangles_keep_their_solid_angle() {
        // A spherical triangle `s` rad across near the pole: `f32`
        // vertices, its solid angle against the planar estimate `s² / 2`
        // (exact to O(s²) relative).
        for s in [1e-1f32, 1e-2, 1e-3] {
            let v = |x: f32, y: f32| {
                let p = Vec3::new(0.3 + x, 0.2 + y, 1.0);
                let p = p / p.length();
                [Wide::splat(p.x), Wide::splat(p.y), Wide::splat(p.z)]
            };
            let t = [v(0.0, 0.0), v(s, 0.0), v(0.0, s)];
            let (num, den, _) = tri_node(&t);
            let omega = 2.0 * f64::from(num.0[0]).atan2(f64::from(den.0[0]));
            // The triangle's area on the plane z = 1, taken to the sphere
            // at its (near-constant) direction: cos^3 / distance^2.
            let d = Vec3::new(0.3, 0.2, 1.0);
            let want = 0.5 * f64::from(s * s) * f64::from(d.z / d.length()).powi(3);
            let rel = (omega / want - 1.0).abs();
            assert!(rel < 2.0 * f64::from(s) + 1e-3, "s {s}: {omega} vs {want}");
        }
    }

    #[test]
    fn degenerate_polygons_are_left_uncorrected() {
        let cell = crate::shading::ltc::table().lookup(0.5, 0.5);
        let wo = Vec3::new(0.866, 0.0, 0.5);
        let line = [DVec3::Z, DVec3::new(0.0, 1.0, 1.0)];
        assert_eq!(
            lobe_factors(&line, &cell, 0.1, 0.1, wo, 0.25, [1.0; 4]),
            (1.0, 1.0)
        );
        let zero = [DVec3::ZERO; 4];
        let (a, b) = lobe_factors(&zero, &cell, 0.0, 0.0, wo, 0.25, [1.0; 4]);
        assert!(a == 1.0 && b == 1.0, "{a} {b}");
    }
}

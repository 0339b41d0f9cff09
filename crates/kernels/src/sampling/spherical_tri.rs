//! Spherical triangles: a robust solid angle and uniform solid-angle sampling
//! (Arvo 1995, "Stratified Sampling of Spherical Triangles").

use super::lanes8::{
    D, D3, F, F3, add3, clampd, cross, deq, dfinite, dmax, dot, ds, narrow3, scale3, select3d,
    sub3, widen, widen3,
};
use super::trig;
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::PI;

/// Solid angle subtended at the origin by the triangle with corners `a`, `b`,
/// `c` (positions relative to the viewpoint, any length), by Van Oosterom &
/// Strackee 1983: tan(Ω/2) = |a·(b×c)| / (|a||b||c| + (a·b)|c| + (a·c)|b| + (b·c)|a|).
/// The triple product is formed from the edges, a·((b−a)×(c−a)), which is the
/// same number without the cancellation of crossing two nearly parallel long
/// vectors: that keeps tiny, distant triangles accurate. The denominator
/// cancels to ~0 for triangles of ~π sr (a huge light seen from just off its
/// plane); f32 loses several percent there, so the arithmetic is f64 (as fast
/// as f32 for a handful of scalar operations).
pub fn solid_angle(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    solid_angle_with_lengths([a, b, c], [a.length(), b.length(), c.length()])
}

/// `solid_angle` with the corners already in f64 and their lengths known: a
/// fan shares each vertex (and its square root) between up to three triangles.
pub(crate) fn solid_angle_with_lengths([a, b, c]: [DVec3; 3], [la, lb, lc]: [f64; 3]) -> f32 {
    let triple = a.dot((b - a).cross(c - a)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    let omega = (2.0 * trig::atan2(triple, den)) as f32;
    if omega.is_finite() { omega } else { 0.0 }
}

/// Unit component of `v` orthogonal to unit `axis`; any orthogonal unit
/// vector when `v` is parallel to it (only reached by degenerate triangles).
#[inline]
fn orthogonal_unit(v: DVec3, axis: DVec3) -> DVec3 {
    (v - axis * v.dot(axis))
        .try_normalize()
        .unwrap_or_else(|| axis.any_orthonormal_vector())
}

/// A direction uniformly distributed in solid angle over the spherical
/// triangle with unit corners `a`, `b`, `c`, whose solid angle is `omega`
/// (pass `solid_angle` of the same triangle). `u` in [0,1)²: `u.x` sweeps the
/// area from edge `ab` (as a sub-triangle a-b-c'), `u.y` moves along the arc
/// from `b` to the sub-triangle's new corner c', so strata in `u` stay strata
/// on the sphere.
///
/// The arithmetic is `f64`: for a triangle a few degrees across, step 1
/// subtracts nearly equal products, and in `f32` the sample could land
/// ~1 % of an edge outside the triangle (a light sample that misses its light).
pub fn sample(a: Vec3, b: Vec3, c: Vec3, omega: f32, u: Vec2) -> Vec3 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let (ux, uy) = (u.x as f64, u.y as f64);
    // Interior angle α at a: between the great circles a–b and a–c, whose
    // normals are x = a×b and y = a×c. Only its sine and cosine are needed:
    // cos α = x·y / (|x||y|), and since x×y = (a·(b×c)) a for unit a,
    // sin α = |a·(b×c)| / (|x||y|). No inverse trigonometry, and
    // sin/cos(u.x·Ω − α) then follow from sin/cos(u.x·Ω) by the addition
    // theorem: one sin_cos per sample instead of an atan2 and two sin_cos.
    let (x, y) = (a.cross(b), a.cross(c));
    let inv = (x.length_squared() * y.length_squared()).sqrt().recip();
    let (sin_alpha, cos_alpha) = if inv.is_finite() {
        (
            (a.dot(b.cross(c)).abs() * inv).min(1.0),
            (x.dot(y) * inv).clamp(-1.0, 1.0),
        )
    } else {
        // A degenerate triangle (two corners on one line): α = 0.
        (0.0, 1.0)
    };
    let cos_c = a.dot(b); // cosine of the arc length a–b

    // Step 1: the corner c' on arc a–c such that triangle a-b-c' has area u.x·Ω.
    let area = ux * omega as f64;
    let (sin_area, cos_area) = trig::sin_cos(area);
    let s = sin_area * cos_alpha - cos_area * sin_alpha;
    let t = cos_area * cos_alpha + sin_area * sin_alpha;
    let uu = t - cos_alpha;
    let vv = s + sin_alpha * cos_c;
    let den = (vv * s + uu * t) * sin_alpha;
    let q = if den != 0.0 {
        (((vv * t - uu * s) * cos_alpha - vv) / den).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    let c_new = q * a + (1.0 - q * q).max(0.0).sqrt() * orthogonal_unit(c, a);

    // Step 2: a point on arc b–c' with cos(angle from b) uniform in the cap sense.
    let z = (1.0 - uy * (1.0 - c_new.dot(b))).clamp(-1.0, 1.0);
    let dir = z * b + (1.0 - z * z).max(0.0).sqrt() * orthogonal_unit(c_new, b);
    dir.normalize().as_vec3()
}

/// `orthogonal_unit` per lane.
#[inline(always)]
fn orthogonal_unit_lanes(v: &D3, axis: &D3) -> D3 {
    let w = sub3(v, &scale3(axis, dot(v, axis)));
    let rcp = ds(1.0) / dot(&w, &w).sqrt();
    let ok = dfinite(rcp).and(rcp.gt(ds(0.0)));
    // glam's `any_orthonormal_vector`.
    let sign = axis[2].map(f64::signum);
    let a = ds(-1.0) / (sign + axis[2]);
    let b = axis[0] * axis[1] * a;
    let any = [b, sign + axis[1] * axis[1] * a, -axis[1]];
    select3d(ok, &scale3(&w, rcp), &any)
}

/// `sample` for eight triangles at once, one per lane: unit corners `a`,
/// `b`, `c`, solid angle `omega`, `u = (ux, uy)`. Each lane's operations
/// are `sample`'s in the same order (branches as selects), so a lane gives
/// the bits `sample` gives for it.
#[inline(always)]
pub fn sample_lanes(a: &F3, b: &F3, c: &F3, omega: F, ux: F, uy: F) -> F3 {
    let (a, b, c) = (widen3(a), widen3(b), widen3(c));
    let (ux, uy) = (widen(ux), widen(uy));
    let (x, y) = (cross(&a, &b), cross(&a, &c));
    let inv = ds(1.0) / (dot(&x, &x) * dot(&y, &y)).sqrt();
    let ok = dfinite(inv);
    let sin_alpha = ok.select(
        (dot(&a, &cross(&b, &c)).abs() * inv).zip(ds(1.0), f64::min),
        ds(0.0),
    );
    let cos_alpha = ok.select(clampd(dot(&x, &y) * inv, -1.0, 1.0), ds(1.0));
    let cos_c = dot(&a, &b);
    let area: D = ux * widen(omega);
    let (sin_area, cos_area) = trig::sin_cos_lanes(area);
    let s = sin_area * cos_alpha - cos_area * sin_alpha;
    let t = cos_area * cos_alpha + sin_area * sin_alpha;
    let uu = t - cos_alpha;
    let vv = s + sin_alpha * cos_c;
    let den = (vv * s + uu * t) * sin_alpha;
    let q = clampd(((vv * t - uu * s) * cos_alpha - vv) / den, -1.0, 1.0);
    let q = deq(den, ds(0.0)).select(ds(1.0), q);
    let c_new = add3(
        &scale3(&a, q),
        &scale3(
            &orthogonal_unit_lanes(&c, &a),
            dmax(ds(1.0) - q * q, ds(0.0)).sqrt(),
        ),
    );
    let z = clampd(ds(1.0) - uy * (ds(1.0) - dot(&c_new, &b)), -1.0, 1.0);
    let dir = add3(
        &scale3(&b, z),
        &scale3(
            &orthogonal_unit_lanes(&c_new, &b),
            dmax(ds(1.0) - z * z, ds(0.0)).sqrt(),
        ),
    );
    narrow3(&scale3(&dir, ds(1.0) / dot(&dir, &dir).sqrt()))
}

/// Solid angle of the full sphere, the upper bound for any light.
pub const FULL_SPHERE: f32 = 4.0 * PI;

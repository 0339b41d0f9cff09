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
//! (to the plain LTC) as they disagree by up to `TRUST` — a light that
//! resolves the lobe's structure, where four nodes cannot follow `f` either.
//! It also fades with the light's share `s` of the lobe (factor `1 - s`):
//! over the whole lobe the LTC integral is already the fitted magnitude.
//!
//! Nodes: a fan of spherical triangles from the polygon's centroid
//! direction, one node per triangle at its centroid, weighted by its solid
//! angle (3 nodes for a triangle light, 4 for a quad). Deterministic and
//! noise-free; the factor is finite, in `[0, MAX_RATIO]`, and 1 for any
//! degenerate input.

use super::brdf;
use super::ltc::LtcCell;
use super::polygon::MAX_VERTICES;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// Largest correction factor (the ratio only runs away where the model has
/// almost no mass).
const MAX_RATIO: f64 = 4.0;
/// The cubature's relative error on the LTC integral at which the
/// correction is dropped entirely (linear fade from 0). Chosen on
/// tests/ltc_accuracy.rs's grid among 0.05 / 0.1 / 0.2 / 0.4 (larger values
/// lower the median but let badly resolved lights through: max error 0.9+
/// at 0.2), and checked on the independent set of tests/ltc_validation.rs.
const TRUST: f64 = 0.1;

/// One lobe's LTC as U uses it: the normalised `M^-1` entries
/// `(m00, m02, m20, m22)`, its magnitude, the horizon mass of its `D` and its
/// mix with the clamped cosine (see `ltc`).
#[derive(Clone, Copy, Debug)]
struct LobeLtc {
    pub minv: [f32; 4],
    pub mag: f32,
    pub hmass: f32,
    pub mix: f32,
}

impl LobeLtc {
    /// The F0 lobe `A` of a table cell.
    fn a(c: &LtcCell) -> LobeLtc {
        LobeLtc {
            minv: [c.m00, c.m02, c.m20, c.m22],
            mag: c.mag,
            hmass: c.hmass,
            mix: c.mix,
        }
    }

    /// The Schlick lobe `B` of a table cell.
    fn b(c: &LtcCell) -> LobeLtc {
        LobeLtc {
            minv: [c.f00, c.f02, c.f20, c.f22],
            mag: c.fres,
            hmass: c.fhmass,
            mix: c.fmix,
        }
    }

    /// The lobe's model value `mag ((1 - mix) D / hmass + mix cos / π)` at a
    /// unit direction `w` of the upper hemisphere.
    fn value(&self, w: DVec3) -> f64 {
        let [m00, m02, m20, m22] = self.minv.map(f64::from);
        let o = DVec3::new(m00 * w.x + m02 * w.z, w.y, m20 * w.x + m22 * w.z);
        let det = (m00 * m22 - m02 * m20).abs();
        let l2 = o.length_squared();
        let d = if l2 > 0.0 && o.z > 0.0 {
            o.z * det / (PI * l2 * l2)
        } else {
            0.0
        };
        let mix = f64::from(self.mix);
        f64::from(self.mag) * ((1.0 - mix) * d / f64::from(self.hmass) + mix * w.z / PI)
    }
}

/// The cubature nodes of a polygon in the shading frame (already clipped to
/// the upper hemisphere): `(unit direction, solid angle weight)`, into
/// `out`; returns how many.
fn nodes(poly: &[DVec3], out: &mut [(DVec3, f64); MAX_VERTICES]) -> usize {
    let n = poly.len().min(MAX_VERTICES);
    let mut u = [DVec3::ZERO; MAX_VERTICES];
    let mut c = DVec3::ZERO;
    for (dst, v) in u.iter_mut().zip(&poly[..n]) {
        let l2 = v.length_squared();
        if l2 > 1e-280 {
            *dst = *v / l2.sqrt();
        }
        c += *dst;
    }
    let cl = c.length();
    if cl.is_nan() || cl <= 1e-300 {
        return 0;
    }
    let c = c / cl;
    let mut k = 0;
    for i in 0..n {
        let (a, b) = (u[i], u[if i + 1 == n { 0 } else { i + 1 }]);
        // Solid angle of the spherical triangle (c, a, b) (Van Oosterom and
        // Strackee's formula).
        let num = c.dot(a.cross(b)).abs();
        let den = 1.0 + c.dot(a) + a.dot(b) + b.dot(c);
        let omega = 2.0 * num.atan2(den);
        let m = c + a + b;
        let ml = m.length();
        if omega > 0.0 && ml > 1e-300 {
            out[k] = (m / ml, omega);
            k += 1;
        }
    }
    k
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
///   `alpha`: GGX alpha.
pub fn lobe_factors(
    poly: &[DVec3],
    cell: &LtcCell,
    share_a: f64,
    share_b: f64,
    wo: Vec3,
    alpha: f32,
) -> (f64, f64) {
    let (la, lb) = (LobeLtc::a(cell), LobeLtc::b(cell));
    let mut nd = [(DVec3::ZERO, 0.0); MAX_VERTICES];
    let k = nodes(poly, &mut nd);
    // Cubatures of the exact lobes and of their models.
    let (mut fa, mut fb, mut ga, mut gb) = (0.0, 0.0, 0.0, 0.0);
    for &(w, wt) in &nd[..k] {
        if w.z <= 0.0 {
            continue;
        }
        let (f, cos_oh) = brdf::spec_local(alpha, w.as_vec3(), wo);
        let a = wt * f64::from(f) * w.z;
        fa += a;
        fb += a * f64::from(brdf::schlick_weight(cos_oh));
        ga += wt * la.value(w);
        gb += wt * lb.value(w);
    }
    (
        factor(fa, ga, share_a, f64::from(la.mag)),
        factor(fb, gb, share_b, f64::from(lb.mag)),
    )
}

/// `Q[f] / Q[ltc]`, faded toward 1 by the cubature's trust and the share.
fn factor(qf: f64, qg: f64, share: f64, mag: f64) -> f64 {
    let s = share.clamp(0.0, 1.0);
    let ltc = s * mag;
    if !(qg > 0.0 && ltc > 0.0 && qf >= 0.0) {
        return 1.0;
    }
    let r = (qf / qg).min(MAX_RATIO);
    let trust = (1.0 - (qg / ltc - 1.0).abs() / TRUST).max(0.0);
    let k = 1.0 + (r - 1.0) * trust * (1.0 - s);
    if k.is_finite() {
        k.clamp(0.0, MAX_RATIO)
    } else {
        1.0
    }
}

//! The analytic unshadowed direct light `U = ∫_light f L cos dω` of one
//! polygonal light at one surface point: the exact polygon form factor for
//! the Lambert lobe, LTC for the GGX lobe.
//!
//! Robustness, in the order the code meets it:
//! - One-sided lights contribute only when the point is strictly on the
//!   emitting side; a point in the light's plane (edge-on, or touching the
//!   light) gets exactly 0 — the limit along the plane.
//! - All geometry is moved into a local frame centred on the point, in `f64`,
//!   so lights 1e4 units from the origin keep their precision.
//! - The polygon is clipped to the upper hemisphere before anything is
//!   integrated (no leak from below the horizon); the LTC lobe is then clipped
//!   again in its own cosine space.
//! - Views below the horizon (a shading normal bent away from the eye) use
//!   the grazing entry of the table, and the shape correction takes that
//!   lobe to the BRDF at the true view (`ltc_correction`); `roughness` is
//!   clamped to [0, 1].

use super::brdf::ShadingBasis;
use super::ltc;
use super::ltc_correction::lobe_factors;
use super::polygon::{
    MAX_LIGHT_VERTICES, MAX_VERTICES, Polygon, clip_upper_into, edge_sum_fixed, edge_sum_triple,
};
use glam::{DVec3, Vec3};
use penumbra_scene::Light;
use penumbra_scene::color::luminance;

/// What `unshadowed` needs to know about a shaded point.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub p: Vec3,
    /// Unit shading normal, already flipped to face the viewer side.
    pub n: Vec3,
    /// Unit direction toward the eye.
    pub wo: Vec3,
    pub diffuse: Vec3,
    pub specular: Vec3,
    pub roughness: f32,
}

/// What `unshadowed` needs of a light, converted once per frame instead of
/// once per pixel: vertices in `f64` in a fixed array (no pointer chase into
/// the scene's `Vec`), the plane, and whether the light can emit at all.
#[derive(Clone, Copy, Debug)]
pub struct ShadingLight {
    v: [DVec3; MAX_VERTICES],
    n: usize,
    normal: DVec3,
    radiance: Vec3,
    two_sided: bool,
}

impl ShadingLight {
    pub fn new(light: &Light) -> ShadingLight {
        let mut v = [DVec3::ZERO; MAX_VERTICES];
        let mut n = light.vertices.len().min(MAX_LIGHT_VERTICES);
        for (dst, src) in v.iter_mut().zip(&light.vertices[..n]) {
            *dst = src.as_dvec3();
        }
        // A degenerate or dark light is marked by n = 0: one early exit.
        if n < 3 || light.radiance == Vec3::ZERO {
            n = 0;
        }
        ShadingLight {
            v,
            n,
            normal: light.normal.as_dvec3(),
            radiance: light.radiance,
            two_sided: light.two_sided,
        }
    }

    /// Vertices U integrates: 0 for a light that cannot emit (dark, or
    /// fewer than 3 vertices).
    pub(crate) fn vertex_count(&self) -> usize {
        self.n
    }
}

/// U for one light: ∫ f L cos over the light polygon. Finite and >= 0 always.
pub fn unshadowed(sp: &SurfacePoint, light: &Light) -> Vec3 {
    unshadowed_prepared(sp, &ShadingLight::new(light))
}

/// Same, split into (diffuse lobe, specular lobe).
pub fn unshadowed_lobes(sp: &SurfacePoint, light: &Light) -> (Vec3, Vec3) {
    unshadowed_lobes_prepared(sp, &ShadingLight::new(light))
}

/// `unshadowed` with the light prepared once (per frame) by `ShadingLight::new`.
#[inline]
pub fn unshadowed_prepared(sp: &SurfacePoint, light: &ShadingLight) -> Vec3 {
    let (d, s) = unshadowed_lobes_prepared(sp, light);
    d + s
}

/// `unshadowed_lobes` with a prepared light.
pub fn unshadowed_lobes_prepared(sp: &SurfacePoint, light: &ShadingLight) -> (Vec3, Vec3) {
    unshadowed_lobes_among(sp, light, 0.0)
}

/// `unshadowed_lobes_prepared` at a point to which other lights give
/// `others` (luminance of their `U`): the shape correction weighs its doubt
/// against the pixel's whole `U`, as the batched path does.
pub fn unshadowed_lobes_among(
    sp: &SurfacePoint,
    light: &ShadingLight,
    others: f32,
) -> (Vec3, Vec3) {
    let zero = (Vec3::ZERO, Vec3::ZERO);
    let nv = light.n;
    if nv < 3 {
        return zero;
    }
    let p = sp.p.as_dvec3();
    // Which side of the light's plane the point is on (> 0: emitting side).
    let side = light.normal.dot(p - light.v[0]);
    let lit = side > 0.0 || (light.two_sided && side < 0.0);
    if !lit {
        return zero;
    }

    let frame = ShadingBasis::from_normal_view(sp.n, sp.wo);
    let (fx, fy, fz) = (frame.x.as_dvec3(), frame.y.as_dvec3(), frame.z.as_dvec3());
    let mut poly = Polygon {
        v: [DVec3::ZERO; MAX_VERTICES],
        n: nv,
    };
    let mut below = false;
    for (dst, v) in poly.v.iter_mut().zip(&light.v[..nv]) {
        let q = *v - p;
        *dst = DVec3::new(q.dot(fx), q.dot(fy), q.dot(fz));
        below |= dst.z < 0.0;
    }
    if below {
        // Rare (lights straddling or under the horizon): the general clip.
        poly = poly.clip_upper();
        if poly.n < 3 {
            return zero;
        }
    }

    let want_d = sp.diffuse != Vec3::ZERO;
    if !super::brdf::has_specular_lobe(sp.specular) {
        if !want_d {
            return zero;
        }
        let ff = form_factor(edge_sum_fixed(&poly.v, poly.n));
        return nonnegative(sp.diffuse * light.radiance * ff as f32, Vec3::ZERO);
    }
    // The specular integrand is F0 A + (1 - F0) B (see `ltc`), each lobe
    // with its own LTC; a lobe whose weight is zero in every channel is
    // skipped (metals with F0 = 1 need no B).
    let c = ltc::packed_table().lookup(sp.roughness, sp.n.dot(sp.wo));
    let want_a = sp.specular.max_element() > 0.0;
    let want_b = sp.specular.min_element() < 1.0;
    let mut la = Polygon::default();
    let mut lb = Polygon::default();
    if want_a {
        ltc_image(&poly, [c.m00, c.m02, c.m20, c.m22], &mut la);
    }
    if want_b {
        ltc_image(&poly, [c.f00, c.f02, c.f20, c.f22], &mut lb);
    }
    // Lambert integrates `poly`, GGX its LTC images; when their vertex counts
    // agree (no clip in LTC space, the common case) the contour sums run in
    // lockstep (see `edge_sum_triple`).
    let n = poly.n;
    let [ff, ia, ib] = if (!want_a || la.n == n) && (!want_b || lb.n == n) {
        edge_sum_triple(&poly.v, &la.v, &lb.v, n)
    } else {
        [
            edge_sum_fixed(&poly.v, n),
            edge_sum_fixed(&la.v, la.n),
            edge_sum_fixed(&lb.v, lb.n),
        ]
    };
    // (diffuse/π) ∫ cos dω = diffuse * form factor.
    let ff = form_factor(ff) as f32;
    let diffuse = sp.diffuse * light.radiance * ff;
    // Each lobe: LTC mixed with the clamped cosine (whose integral is `ff`),
    // as the light's share of the lobe, then corrected for the LTC's shape
    // error with the exact BRDF (`ltc_correction`).
    let cos_v = sp.n.dot(sp.wo).clamp(-1.0, 1.0);
    let wo = Vec3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
    let alpha = super::brdf::alpha_from_roughness(sp.roughness);
    let share_a = (1.0 - c.mix) * form_factor(ia) as f32 / c.hmass + c.mix * ff;
    let share_b = (1.0 - c.fmix) * form_factor(ib) as f32 / c.fhmass + c.fmix * ff;
    let mean = |v: Vec3| (v.x + v.y + v.z) * (1.0 / 3.0);
    let stakes = [
        if want_a {
            c.mag * share_a * mean(sp.specular)
        } else {
            0.0
        },
        if want_b {
            c.fres * share_b * mean(Vec3::ONE - sp.specular)
        } else {
            0.0
        },
        mean(sp.diffuse) * ff,
        others / luminance(light.radiance).max(1e-30),
    ];
    let (ka, kb) = lobe_factors(poly.vertices(), &c, share_a, share_b, wo, alpha, stakes);
    let a = if want_a { c.mag * share_a * ka } else { 0.0 };
    let b = if want_b { c.fres * share_b * kb } else { 0.0 };
    let specular = light.radiance * (sp.specular * a + (Vec3::ONE - sp.specular) * b);
    nonnegative(diffuse, specular)
}

/// The LTC image of a (horizon-clipped) polygon, clipped again to the upper
/// hemisphere of LTC space, written into `out` (no copy of the whole buffer
/// on the way, see `clip_upper_into`).
/// `M^-1 = [[m00, 0, m02], [0, 1, 0], [m20, 0, m22]]`: apply only the four
/// non-trivial entries instead of a full 3x3 product.
#[inline(always)]
fn ltc_image(poly: &Polygon, m: [f32; 4], out: &mut Polygon) {
    let [m00, m02, m20, m22] = m.map(f64::from);
    let n = poly.n;
    let mut below = false;
    for (dst, v) in out.v.iter_mut().zip(&poly.v[..n]) {
        *dst = DVec3::new(m00 * v.x + m02 * v.z, v.y, m20 * v.x + m22 * v.z);
        below |= dst.z < 0.0;
    }
    out.n = n;
    if below {
        let image = out.v;
        clip_upper_into(&image[..n], out);
    }
}

/// Both lobes clamped to >= 0 (rounding can leave a tiny negative).
#[inline]
fn nonnegative(d: Vec3, s: Vec3) -> (Vec3, Vec3) {
    (d.max(Vec3::ZERO), s.max(Vec3::ZERO))
}

/// `cosine_integral` from a contour sum: in [0, 1] for either winding.
#[inline]
fn form_factor(edge_sum: f64) -> f64 {
    (edge_sum.abs() / (2.0 * std::f64::consts::PI)).min(1.0)
}

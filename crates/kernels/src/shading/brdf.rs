//! The project's BRDF, exactly as docs/scene-format.md defines it: Lambert plus
//! GGX microfacets with Smith height-correlated masking-shadowing and Schlick
//! Fresnel, no energy compensation.
//!
//! Everything here works in a *local* frame where the shading normal is +Z;
//! callers rotate into it once per shading point. Working locally lets us write
//! `1 - cos^2` as `x^2 + y^2`, which keeps the GGX peak exact in `f32` even for
//! the tiny alphas of near-mirror surfaces (where `1 - cos^2` would cancel).
//!
//! Used by the LTC fit (`ltc_fit`), by the brute-force accuracy tests and by
//! the Monte Carlo estimators (`sample_vndf` / `vndf_pdf`).

use glam::Vec3;
use std::f32::consts::PI;

/// Smallest GGX alpha. `roughness = 0` would make D a Dirac delta (0/0 at the
/// peak, NaN); clamping alpha to 1e-4 keeps D finite (peak 1/(pi alpha^2) ~ 3e7)
/// while still looking like a mirror at any practical resolution.
pub const MIN_ALPHA: f32 = 1e-4;

/// Smallest |cos| used in divisions by `n . w`. Below it the view or light is
/// treated as grazing at this angle (no infinities, no NaN).
pub const MIN_COS: f32 = 1e-4;

/// GGX alpha for a perceptual roughness in [0, 1] (`alpha = roughness^2`,
/// clamped to `MIN_ALPHA`).
#[inline]
pub fn alpha_from_roughness(roughness: f32) -> f32 {
    let r = roughness.clamp(0.0, 1.0);
    (r * r).max(MIN_ALPHA)
}

/// GGX normal distribution D(h) for a unit half vector `h` in the local frame.
/// Written with `sin^2 = x^2 + y^2` so the peak does not cancel in f32.
#[inline]
pub fn ggx_d(alpha: f32, h: Vec3) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = h.x * h.x + h.y * h.y + a2 * h.z * h.z;
    a2 / (PI * t * t)
}

/// Smith Lambda for GGX of a unit direction `w` in the local frame.
/// `(sqrt(1 + a) - 1) / 2` is rewritten as `a / (2 (sqrt(1 + a) + 1))` to avoid
/// cancellation when `a = alpha^2 tan^2` is small.
#[inline]
pub fn smith_lambda(alpha: f32, w: Vec3) -> f32 {
    let cos2 = (w.z * w.z).max(MIN_COS * MIN_COS);
    let sin2 = w.x * w.x + w.y * w.y;
    let a = alpha * alpha * sin2 / cos2;
    a / (2.0 * ((1.0 + a).sqrt() + 1.0))
}

/// Smith height-correlated masking-shadowing G2 = 1 / (1 + Lambda(wi) + Lambda(wo)).
#[inline]
pub fn smith_g2(alpha: f32, wi: Vec3, wo: Vec3) -> f32 {
    1.0 / (1.0 + smith_lambda(alpha, wi) + smith_lambda(alpha, wo))
}

/// Smith masking G1 = 1 / (1 + Lambda(w)).
#[inline]
pub fn smith_g1(alpha: f32, w: Vec3) -> f32 {
    1.0 / (1.0 + smith_lambda(alpha, w))
}

/// The Schlick weight `(1 - cos)^5` with `cos = wo . h` clamped to [0, 1], so
/// that F = F0 + (1 - F0) * weight.
#[inline]
pub fn schlick_weight(cos_oh: f32) -> f32 {
    let m = 1.0 - cos_oh.clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick Fresnel per channel.
#[inline]
pub fn schlick(f0: Vec3, cos_oh: f32) -> Vec3 {
    f0 + (Vec3::ONE - f0) * schlick_weight(cos_oh)
}

/// Half vector of `wi` and `wo` (unit), or `None` when they are opposite.
#[inline]
fn half_vector(wi: Vec3, wo: Vec3) -> Option<Vec3> {
    let h = wi + wo;
    let l2 = h.length_squared();
    (l2 > 1e-20).then(|| h / l2.sqrt())
}

/// Specular lobe with F = 1 in the local frame: `D G2 / (4 |n.wi| |n.wo|)`.
/// Zero when `wi` is below the horizon (the cosine factor of every integral
/// kills it anyway) or when the half vector points below the surface.
#[inline]
pub fn spec_f1_local(alpha: f32, wi: Vec3, wo: Vec3) -> f32 {
    spec_local(alpha, wi, wo).0
}

/// `(D G2 / (4 |n.wi| |n.wo|), wo . h)`: the F = 1 specular lobe and the
/// cosine Fresnel needs; both zero when undefined.
#[inline]
pub fn spec_local(alpha: f32, wi: Vec3, wo: Vec3) -> (f32, f32) {
    if wi.z <= 0.0 {
        return (0.0, 0.0);
    }
    let Some(h) = half_vector(wi, wo) else {
        return (0.0, 0.0);
    };
    let d = ggx_d(alpha, h);
    if d == 0.0 {
        return (0.0, 0.0);
    }
    let g = smith_g2(alpha, wi, wo);
    let ci = wi.z.max(MIN_COS);
    let co = wo.z.abs().max(MIN_COS);
    (d * g / (4.0 * ci * co), wo.dot(h))
}

/// Whether a material has a specular lobe at all: `specular = [0, 0, 0]`
/// means none (docs/scene-format.md), so Schlick's grazing term `(1 - wo.h)^5`
/// must not bring one back. The one test that `U`, the BRDF and the lobe
/// choice of the samplers share, so that the analytic and Monte Carlo
/// answers (stochastic, reference) agree on such surfaces.
#[inline]
pub fn has_specular_lobe(specular: Vec3) -> bool {
    specular.max_element() > 0.0
}

/// Full BRDF value per channel in the local frame (normal = +Z); diffuse
/// only where `has_specular_lobe` is false.
#[inline]
pub fn eval_local(wi: Vec3, wo: Vec3, diffuse: Vec3, specular: Vec3, roughness: f32) -> Vec3 {
    if wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    if !has_specular_lobe(specular) {
        return diffuse * (1.0 / PI);
    }
    let (s, cos_oh) = spec_local(alpha_from_roughness(roughness), wi, wo);
    diffuse * (1.0 / PI) + schlick(specular, cos_oh) * s
}

/// An orthonormal frame with `z = n`; `x` follows `wo`'s tangential part when
/// it has one (so an isotropic lobe's view lies in the xz plane, as the LTC
/// table expects), otherwise any perpendicular.
#[derive(Clone, Copy, Debug)]
pub struct ShadingBasis {
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
}

impl ShadingBasis {
    pub fn from_normal_view(n: Vec3, wo: Vec3) -> ShadingBasis {
        let t = wo - n * n.dot(wo);
        let l2 = t.length_squared();
        let x = if l2 > 1e-12 {
            t / l2.sqrt()
        } else {
            n.any_orthonormal_vector()
        };
        ShadingBasis {
            x,
            y: n.cross(x),
            z: n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }
}

/// Full BRDF in world space for unit `n`, `wi`, `wo`.
pub fn eval(n: Vec3, wi: Vec3, wo: Vec3, diffuse: Vec3, specular: Vec3, roughness: f32) -> Vec3 {
    let f = ShadingBasis::from_normal_view(n, wo);
    eval_local(f.to_local(wi), f.to_local(wo), diffuse, specular, roughness)
}

/// Samples a microfacet normal from the distribution of visible normals for
/// the view `wo` (local frame, `wo.z > 0`), Heitz 2018. `u1, u2` in [0, 1).
pub fn sample_vndf(alpha: f32, wo: Vec3, u1: f32, u2: f32) -> Vec3 {
    // Stretch the view into the alpha = 1 configuration.
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z.max(MIN_COS)).normalize();
    let l2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if l2 > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / l2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    // A point on the projected hemisphere: a disk warped toward the view.
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // Unstretch.
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// Density (solid angle, of `wi`) of sampling `wi` by reflecting `wo` about a
/// VNDF-sampled normal: `G1(wo) D(h) / (4 wo.z)`.
pub fn vndf_pdf(alpha: f32, wi: Vec3, wo: Vec3) -> f32 {
    let Some(h) = half_vector(wi, wo) else {
        return 0.0;
    };
    if wo.dot(h) <= 0.0 {
        return 0.0;
    }
    smith_g1(alpha, wo) * ggx_d(alpha, h) / (4.0 * wo.z.max(MIN_COS))
}

/// Reflects `wo` about `h`.
#[inline]
pub fn reflect(wo: Vec3, h: Vec3) -> Vec3 {
    2.0 * wo.dot(h) * h - wo
}

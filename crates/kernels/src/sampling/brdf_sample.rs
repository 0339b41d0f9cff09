//! BRDF sampling for the BRDF of docs/scene-format.md (Lambert + GGX): GGX visible
//! normals for the specular lobe, cosine-weighted hemisphere for the diffuse
//! lobe, one lobe chosen per sample, and the combined pdf MIS needs.
//!
//! Visible normals are drawn as in Heitz 2018 ("Sampling the GGX Distribution
//! of Visible Normals"): stretch the view to the alpha = 1 configuration,
//! sample the visible hemisphere there, unstretch. The visible hemisphere is
//! sampled with the spherical-cap form of Dupuy & Benyoub 2023 ("Sampling
//! Visible GGX Normals with Spherical Caps"): the same distribution, fewer
//! operations and no special case at normal incidence.

use super::trig;
use crate::shading::brdf;
use glam::{Vec2, Vec3};
use penumbra_scene::color::LUMA;
use std::f32::consts::{FRAC_1_PI, PI};

/// Orthonormal basis (t, b) completing unit `n` to a right-handed frame,
/// branchless and continuous except on n.z = 0's sign flip (Duff et al. 2017,
/// "Building an Orthonormal Basis, Revisited").
#[inline]
pub fn onb(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// World vector to the frame (t, b, n).
#[inline]
fn to_local(v: Vec3, t: Vec3, b: Vec3, n: Vec3) -> Vec3 {
    Vec3::new(v.dot(t), v.dot(b), v.dot(n))
}

#[inline]
fn to_world(v: Vec3, t: Vec3, b: Vec3, n: Vec3) -> Vec3 {
    v.x * t + v.y * b + v.z * n
}

/// Cosine-weighted direction in the local frame (z up): Malley's method on the
/// concentric disk map (Shirley & Chiu 1997), which keeps strata of `u`
/// compact on the hemisphere. pdf = z / π.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let o = 2.0 * u - Vec2::ONE;
    let d = if o.x == 0.0 && o.y == 0.0 {
        Vec2::ZERO
    } else if o.x.abs() > o.y.abs() {
        let (s, c) = trig::sin_cos_f32(PI / 4.0 * (o.y / o.x));
        o.x * Vec2::new(c, s)
    } else {
        let (s, c) = trig::sin_cos_f32(PI / 2.0 - PI / 4.0 * (o.x / o.y));
        o.y * Vec2::new(c, s)
    };
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Clamped GGX alpha (see `brdf::MIN_ALPHA`).
#[inline]
fn clamp_alpha(alpha: f32) -> f32 {
    alpha.max(brdf::MIN_ALPHA)
}

/// A GGX visible normal for local view `wo` (z up, wo.z > 0), `u` in [0,1)².
pub fn vndf_sample(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let alpha = clamp_alpha(alpha);
    // Stretch: the alpha = 1 configuration, where visible normals are uniform
    // over the hemisphere's projection seen from wo.
    let v = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    // A uniform direction on the spherical cap z >= -v.z, offset by v, is a
    // visible normal of the hemisphere (Dupuy & Benyoub 2023).
    let phi = 2.0 * PI * u.x;
    let z = (1.0 - u.y) * (1.0 + v.z) - v.z;
    let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
    let (sp, cp) = trig::sin_cos_f32(phi);
    let h = Vec3::new(sin_theta * cp, sin_theta * sp, z) + v;
    // Unstretch (the inverse transpose of the stretch, for normals).
    Vec3::new(alpha * h.x, alpha * h.y, h.z.max(0.0)).normalize()
}

/// Density of `vndf_sample` reflected about its normal, for local `wo`, `wi`:
/// D_v(h) / (4 wo·h) with D_v(h) = G1(wo) max(0, wo·h) D(h) / (n·wo), which
/// simplifies to G1(wo) D(h) / (4 n·wo). Defined below the horizon too (the
/// sampler does reflect into it); 0 where wo·h <= 0 (never sampled).
pub fn vndf_pdf(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let alpha = clamp_alpha(alpha);
    if wo.z <= 0.0 {
        return 0.0;
    }
    let Some(h) = (wo + wi).try_normalize() else {
        return 0.0;
    };
    if wo.dot(h) <= 0.0 || h.z <= 0.0 {
        return 0.0;
    }
    brdf::smith_g1(alpha, wo) * brdf::ggx_d(alpha, h) / (4.0 * wo.z)
}

/// Probability of choosing the specular lobe, proportional to an estimate of
/// each lobe's reflectance: luminance of the diffuse albedo against luminance
/// of Schlick's Fresnel at the view angle. Exactly 0 (1) when a lobe is absent,
/// so no sample is ever wasted on a black lobe.
pub fn spec_lobe_probability(diffuse: Vec3, specular: Vec3, n_dot_wo: f32) -> f32 {
    let wd = diffuse.dot(LUMA).max(0.0);
    let ws = if crate::shading::brdf::has_specular_lobe(specular) {
        let m = (1.0 - n_dot_wo.clamp(0.0, 1.0)).powi(5);
        (specular + (Vec3::ONE - specular) * m).dot(LUMA).max(0.0)
    } else {
        0.0
    };
    if wd + ws > 0.0 { ws / (wd + ws) } else { 0.0 }
}

/// A BRDF-sampled incident direction and its combined pdf.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BrdfSample {
    /// Unit incident direction (world space), above the shading normal.
    pub wi: Vec3,
    /// `brdf_pdf` of `wi`: density with respect to solid angle, both lobes.
    pub pdf: f32,
}

/// Draws the specular lobe with probability `p_spec` (decided by `u_lobe`),
/// else the diffuse lobe. `n` unit shading normal, `wo` unit direction toward
/// the viewer. `None` if wo is at or below the horizon, or the sampled
/// direction falls below it (where the BRDF is zero anyway, so the estimator
/// simply adds nothing; the pdf still counts those directions).
pub fn sample_brdf(
    n: Vec3,
    wo: Vec3,
    alpha: f32,
    p_spec: f32,
    u_lobe: f32,
    u: Vec2,
) -> Option<BrdfSample> {
    let (t, b) = onb(n);
    let wo_l = to_local(wo, t, b, n);
    if wo_l.z <= 0.0 {
        return None;
    }
    let wi_l = if u_lobe < p_spec {
        let h = vndf_sample(wo_l, alpha, u);
        2.0 * wo_l.dot(h) * h - wo_l
    } else {
        cosine_hemisphere(u)
    };
    if wi_l.z <= 0.0 {
        return None;
    }
    let pdf = pdf_local(wo_l, wi_l, alpha, p_spec);
    (pdf > 0.0 && pdf.is_finite()).then(|| BrdfSample {
        wi: to_world(wi_l, t, b, n).normalize(),
        pdf,
    })
}

fn pdf_local(wo: Vec3, wi: Vec3, alpha: f32, p_spec: f32) -> f32 {
    let spec = if p_spec > 0.0 {
        p_spec * vndf_pdf(wo, wi, alpha)
    } else {
        0.0
    };
    let diff = if p_spec < 1.0 {
        (1.0 - p_spec) * wi.z.max(0.0) * FRAC_1_PI
    } else {
        0.0
    };
    spec + diff
}

/// Combined pdf of `sample_brdf` for world directions:
/// p_spec · pdf_vndf_reflected + (1 − p_spec) · max(0, cos) / π.
pub fn brdf_pdf(n: Vec3, wo: Vec3, wi: Vec3, alpha: f32, p_spec: f32) -> f32 {
    let (t, b) = onb(n);
    pdf_local(to_local(wo, t, b, n), to_local(wi, t, b, n), alpha, p_spec)
}

/// `brdf_pdf` with `wo` and `wi` already in a local frame whose z is the
/// shading normal. The lobes are isotropic, so any such frame gives the same
/// density: the per-pixel estimator reuses the frame it evaluates the BRDF in
/// instead of building a second one per sample.
pub fn brdf_pdf_local(wo_l: Vec3, wi_l: Vec3, alpha: f32, p_spec: f32) -> f32 {
    pdf_local(wo_l, wi_l, alpha, p_spec)
}

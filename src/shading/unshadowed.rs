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
//! - Views below the horizon (shading normals) use the grazing entry of the
//!   table; `roughness` is clamped to [0, 1].

use super::brdf::Frame;
use super::ltc;
use super::polygon::{MAX_LIGHT_VERTICES, Polygon, cosine_integral};
use crate::scene::Light;
use glam::{DVec3, Vec3};

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

/// U for one light: ∫ f L cos over the light polygon. Finite and >= 0 always.
pub fn unshadowed(sp: &SurfacePoint, light: &Light) -> Vec3 {
    let (d, s) = unshadowed_lobes(sp, light);
    d + s
}

/// Same, split into (diffuse lobe, specular lobe).
pub fn unshadowed_lobes(sp: &SurfacePoint, light: &Light) -> (Vec3, Vec3) {
    let zero = (Vec3::ZERO, Vec3::ZERO);
    let nv = light.vertices.len().min(MAX_LIGHT_VERTICES);
    if nv < 3 || light.radiance == Vec3::ZERO {
        return zero;
    }
    let p = sp.p.as_dvec3();
    // Which side of the light's plane the point is on (> 0: emitting side).
    let side = light
        .normal
        .as_dvec3()
        .dot(p - light.vertices[0].as_dvec3());
    let lit = side > 0.0 || (light.two_sided && side < 0.0);
    if !lit {
        return zero;
    }

    let frame = Frame::from_normal_view(sp.n, sp.wo);
    let (fx, fy, fz) = (frame.x.as_dvec3(), frame.y.as_dvec3(), frame.z.as_dvec3());
    let mut poly = Polygon::default();
    for v in &light.vertices[..nv] {
        let q = v.as_dvec3() - p;
        poly.v[poly.n] = DVec3::new(q.dot(fx), q.dot(fy), q.dot(fz));
        poly.n += 1;
    }
    poly.clip_upper_in_place();
    if poly.n < 3 {
        return zero;
    }

    let diffuse = if sp.diffuse != Vec3::ZERO {
        // (diffuse/π) ∫ cos dω = diffuse * form factor.
        let ff = cosine_integral(&poly) as f32;
        sp.diffuse * light.radiance * ff
    } else {
        Vec3::ZERO
    };

    let specular = if sp.specular != Vec3::ZERO {
        let cell = ltc::table().lookup(sp.roughness, sp.n.dot(sp.wo));
        let mut lp = poly.transformed(&cell.inv_matrix());
        lp.clip_upper_in_place();
        let i = cosine_integral(&lp) as f32;
        let scale = sp.specular * cell.mag + (Vec3::ONE - sp.specular) * cell.fres;
        light.radiance * scale * (i / cell.hmass)
    } else {
        Vec3::ZERO
    };
    (diffuse.max(Vec3::ZERO), specular.max(Vec3::ZERO))
}

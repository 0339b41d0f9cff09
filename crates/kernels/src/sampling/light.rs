//! Per-light, per-shading-point sampling: which strategy (spherical rectangle,
//! fan of spherical triangles, or area sampling for tiny solid angles) is a
//! deterministic function of (light, p), so the pdf reproduces exactly the
//! density the sampler draws from. Everything is computed on vertices
//! relative to `p`, so float32 precision follows the light's distance from the
//! shading point, not from the world origin.
//!
//! Cost is split in three: `PreparedLight` (once per light and frame: edges,
//! rectangle frame, area table), `LightSampler` (once per light and shading
//! point: strategy and solid angles), then any number of `sample`/`pdf` calls.
//! `sample_light`/`light_pdf`/`intersect_light` do all three every call.

use super::spherical_rect::{RectFrame, SphericalRect};
use super::spherical_tri;
use super::trig;
use crate::shading::brdf::reflect;
use glam::{DVec3, Vec2, Vec3};
use penumbra_scene::Light;

/// Below this solid angle (steradians) the light is sampled uniformly by area
/// and the pdf converted to solid angle. Measured with
/// `examples/sampling_precision` (worst error of the samplers' u.x CDF over
/// random configurations, f32): it grows like ~6e-7/Ω for rectangles and
/// ~2e-6/Ω for triangles; at 1e-3 sr it is 6e-4 and 2e-3, at 1e-4 sr
/// already 6e-3 and 2e-2, and below 1e-5 sr the samplers are useless.
/// Area sampling costs little there: over a light of 1e-3 sr (~0.03 rad
/// across) cos/d² varies by a few percent unless the light is grazing.
pub const SOLID_ANGLE_AREA_FALLBACK: f32 = 1e-3;

/// Lights have at most 8 vertices (docs/scene-format.md), so a fan has at most 6 triangles.
const MAX_VERTS: usize = 8;
pub(crate) const MAX_TRIS: usize = MAX_VERTS - 2;

/// A direction toward a light from a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// Unit vector from p toward the sampled point on the light.
    pub wi: Vec3,
    /// Distance from p to the sampled point.
    pub dist: f32,
    /// Density of `wi` with respect to solid angle at p.
    pub pdf: f32,
}

/// The parts of a light that do not depend on the shading point, in fixed
/// arrays (no allocation): build once per light per frame and share it
/// between all pixels.
#[derive(Debug, Clone, Copy)]
pub struct PreparedLight {
    pub(crate) verts: [Vec3; MAX_VERTS],
    pub(crate) n: usize,
    pub(crate) normal: Vec3,
    pub(crate) two_sided: bool,
    area: f32,
    /// Per edge i (vertex i to i+1): normal × edge, pointing into the polygon,
    /// and the edge length (for the slack of the inside test).
    pub(crate) inward: [Vec3; MAX_VERTS],
    pub(crate) edge_len: [f32; MAX_VERTS],
    /// Areas of the fan triangles (v0, vi, vi+1) and their sum: the
    /// selection table of area sampling.
    fan_area: [f32; MAX_TRIS],
    fan_area_total: f32,
    /// (v_i − v0) × (v_i+1 − v0) per fan triangle, f64: the triple product
    /// of a triangle seen from any p is (v0 − p) · this, so the per-point
    /// setup takes one dot product where it took two edges and a cross.
    pub(crate) fan_cross: [DVec3; MAX_TRIS],
    /// Corner (world space) and frame when the light is a true rectangle.
    pub(crate) rect: Option<(Vec3, RectFrame)>,
    /// The vertices' centroid and the largest distance of a vertex from
    /// it: a sphere holding the light (`lobe_misses`).
    centre: Vec3,
    radius: f32,
}

/// The light as a rectangle `(corner, ex, ey)`, if it is one: a quad whose
/// half-edges are orthogonal, or a 4-gon with orthogonal edges that closes as
/// a parallelogram. Parallelograms that are not rectangles are not, and go to
/// the triangle fan. The closing test works on differences from vertex 0,
/// which are as accurate as the old per-point relative vertices.
fn as_rect(light: &Light, verts: &[Vec3]) -> Option<(Vec3, Vec3, Vec3)> {
    const TOL: f32 = 1e-5;
    if let Some((c, u, v)) = light.quad {
        if u.dot(v).abs() <= TOL * u.length() * v.length() {
            return Some((c - u - v, 2.0 * u, 2.0 * v));
        }
        return None;
    }
    if let [a, b, c, d] = *verts {
        let (ex, ey) = (b - a, d - a);
        let size = ex.length() + ey.length();
        let closes = (ex + ey - (c - a)).length() <= TOL * size;
        if closes && ex.dot(ey).abs() <= TOL * ex.length() * ey.length() {
            return Some((a, ex, ey));
        }
    }
    None
}

impl PreparedLight {
    pub fn new(light: &Light) -> PreparedLight {
        let n = light.vertices.len().min(MAX_VERTS);
        let mut verts = [Vec3::ZERO; MAX_VERTS];
        verts[..n].copy_from_slice(&light.vertices[..n]);
        let normal = light.normal;
        let mut inward = [Vec3::ZERO; MAX_VERTS];
        let mut edge_len = [0.0; MAX_VERTS];
        for i in 0..n {
            let e = verts[(i + 1) % n] - verts[i];
            inward[i] = normal.cross(e);
            edge_len[i] = e.length();
        }
        let mut fan_area = [0.0; MAX_TRIS];
        let mut fan_area_total = 0.0;
        let mut fan_cross = [DVec3::ZERO; MAX_TRIS];
        for i in 1..n.saturating_sub(1) {
            fan_area[i - 1] = (verts[i] - verts[0])
                .cross(verts[i + 1] - verts[0])
                .length();
            fan_area_total += fan_area[i - 1];
            let v0 = verts[0].as_dvec3();
            fan_cross[i - 1] = (verts[i].as_dvec3() - v0).cross(verts[i + 1].as_dvec3() - v0);
        }
        let rect = as_rect(light, &verts[..n])
            .and_then(|(corner, ex, ey)| Some((corner, RectFrame::new(ex, ey)?)));
        let centre = verts[..n].iter().copied().sum::<Vec3>() / n.max(1) as f32;
        let radius = verts[..n]
            .iter()
            .map(|v| (*v - centre).length())
            .fold(0.0, f32::max);
        PreparedLight {
            centre,
            radius,
            verts,
            n,
            normal,
            two_sided: light.two_sided,
            area: light.area,
            inward,
            edge_len,
            fan_area,
            fan_area_total,
            fan_cross,
            rect,
        }
    }

    /// Whether the lane draw (`draw_lanes`) takes this light's samples:
    /// any polygon `LightSampler` can set up (a rectangle or a fan).
    #[inline]
    pub fn in_lanes(&self) -> bool {
        self.n >= 3
    }

    /// Whether `LightSampler` samples the light as a rectangle.
    #[inline]
    pub fn is_rect(&self) -> bool {
        self.rect.is_some()
    }

    /// Whether the specular lobe of GGX `alpha` for the view `wo` about the
    /// shading normal `n` at `p` points away from the light: its mirror
    /// direction lies more than `LOBE_WIDTHS_OFF` lobe widths (`2 alpha`,
    /// the spread of the mirror directions) outside the cone of the
    /// light's bounding sphere. Then the light sits in the lobe's tail and
    /// BRDF samples mostly miss it (`LOBE_OFF_LIGHT_SHARE`). Conservative:
    /// a point inside the sphere, or a degenerate view, is never off.
    pub fn lobe_misses(&self, p: Vec3, n: Vec3, wo: Vec3, alpha: f32) -> bool {
        // The margin in radians; a lobe this wide is sampled from the light
        // anyway (`light_strategy_probability`'s solid angles), so wider
        // ones are left as they are and the margin's cosine and sine are
        // short series (to 3e-3 at 1 rad).
        let margin = LOBE_WIDTHS_OFF * 2.0 * alpha;
        let to = self.centre - p;
        let dist2 = to.length_squared();
        let inside = dist2.is_nan() || dist2 <= self.radius * self.radius;
        if self.n < 3 || margin.is_nan() || margin >= 1.0 || inside {
            return false;
        }
        let mirror = reflect(wo, n);
        let len2 = mirror.length_squared();
        if len2.is_nan() || len2 <= 0.0 {
            return false;
        }
        // Off the light's cone by more than the margin: the angle from the
        // mirror direction to the centre exceeds the cone's half angle
        // (under pi / 2) plus the margin (under 1), compared as cosines.
        let cos_off = mirror.dot(to) / (len2 * dist2).sqrt();
        let sin_cone = self.radius / dist2.sqrt();
        let cos_cone = (1.0 - sin_cone * sin_cone).sqrt();
        let m2 = margin * margin;
        let cos_m = 1.0 - m2 * (0.5 - m2 / 24.0);
        let sin_m = margin * (1.0 - m2 * (1.0 / 6.0 - m2 / 120.0));
        cos_off < cos_cone * cos_m - sin_cone * sin_m
    }

    /// Distance from `p` along unit `wi` to the light, if the ray hits its
    /// emitting side (either side when two-sided). For BRDF-sampled directions.
    pub fn intersect(&self, p: Vec3, wi: Vec3) -> Option<f32> {
        if self.n < 3 {
            return None;
        }
        self.intersect_plane(p, (self.verts[0] - p).dot(self.normal), wi)
    }

    /// `intersect` with `plane` = (v0 − p)·n already known.
    fn intersect_plane(&self, p: Vec3, plane: f32, wi: Vec3) -> Option<f32> {
        let cos = wi.dot(self.normal);
        // One-sided lights emit along +n: a ray sees the front only travelling against n.
        if cos == 0.0 || (!self.two_sided && cos > 0.0) {
            return None;
        }
        let t = plane / cos;
        if !(t > 0.0 && t.is_finite()) {
            return None;
        }
        let q = wi * t;
        for i in 0..self.n {
            // (e × (q − a))·n = (n × e)·(q − a): the interior is on the left
            // of every edge seen from +n. The slack covers rounding of a
            // sample placed on an edge; it scales with the edge and with the
            // distance to p, which set the size of that rounding.
            let a = self.verts[i] - p;
            let len = self.edge_len[i];
            let tol = EDGE_SLACK * len * (t + len);
            if self.inward[i].dot(q - a) < -tol {
                return None;
            }
        }
        Some(t)
    }

    /// Uniform point on the polygon by area, relative to `p`: a fan triangle
    /// chosen by area, then uniform barycentrics by the square-root map; `u.x`
    /// is reused after selection so strata survive.
    fn area_point(&self, p: Vec3, u: Vec2) -> Vec3 {
        let (k, ux) = select(&self.fan_area[..self.n - 2], self.fan_area_total, u.x);
        let su = ux.sqrt();
        let (b1, b2) = (su * (1.0 - u.y), su * u.y);
        let v0 = self.verts[0];
        (v0 - p) + b1 * (self.verts[k + 1] - v0) + b2 * (self.verts[k + 2] - v0)
    }
}

/// How far, in lobe widths, a specular lobe's mirror direction must lie
/// outside a light for `PreparedLight::lobe_misses`: GGX sends a share
/// `1 / (1 + k²)` of its mirror directions beyond `k` widths, so at 2 at
/// most a fifth of the BRDF's specular samples, spread around the whole
/// ring, can reach the light.
pub const LOBE_WIDTHS_OFF: f32 = 2.0;

/// The light strategy's share of the specular lobe's samples where the
/// lobe points away from the light (`PreparedLight::lobe_misses`):
/// its BRDF samples would mostly miss the light too, and the few that hit
/// carry weights far above the rest (the ratio's `U_N` and `S_N` then rest
/// on one sample in many). The share the BRDF keeps serves MIS.
pub const LOBE_OFF_LIGHT_SHARE: f32 = 0.9;

/// How the sampler draws for one (light, p).
#[derive(Debug, Clone, Copy)]
enum Strategy {
    /// Rectangle (Ureña), relative to p.
    Rect(SphericalRect),
    /// Fan (v0, vi, vi+1) of spherical triangles chosen by solid angle
    /// (robust Van Oosterom–Strackee values, per triangle).
    Fan([f32; MAX_TRIS]),
    /// Uniform by area, pdf converted to solid angle.
    Area,
}

/// One light as seen from one shading point: strategy and solid angles are
/// set up once, then `sample` and `pdf` are cheap and share them, so the two
/// MIS strategies of a pixel see exactly the same density.
#[derive(Debug, Clone, Copy)]
pub struct LightSampler<'a> {
    light: &'a PreparedLight,
    p: Vec3,
    /// (v0 − p)·n: minus the signed height of p over the light's plane.
    plane: f32,
    omega: f32,
    strategy: Strategy,
}

impl<'a> LightSampler<'a> {
    /// Setup for `light` seen from `p`. `None` if p is behind a one-sided
    /// light, in its plane, or the light subtends nothing representable.
    pub fn new(light: &'a PreparedLight, p: Vec3) -> Option<LightSampler<'a>> {
        let n = light.n;
        if n < 3 {
            return None;
        }
        let v0 = light.verts[0] - p;
        let plane = v0.dot(light.normal);
        if !plane.is_finite() || plane == 0.0 || (!light.two_sided && plane > 0.0) {
            return None;
        }
        let (strategy, omega) = if let Some((corner, frame)) = &light.rect {
            // Ureña's construction yields the solid angle itself.
            let r = SphericalRect::from_frame(*corner - p, frame)?;
            (Strategy::Rect(r), r.solid_angle())
        } else {
            // Each vertex length is shared by up to three fan triangles.
            let mut rel = [DVec3::ZERO; MAX_VERTS];
            let mut len = [0.0f64; MAX_VERTS];
            for i in 0..n {
                rel[i] = (light.verts[i] - p).as_dvec3();
                len[i] = rel[i].length();
            }
            // Van Oosterom–Strackee per fan triangle (v0, vi, vi+1), as
            // `spherical_tri::solid_angle_with_lengths`, with the dot
            // products a fan shares computed once: v0·vi for every i, and
            // vi·vi+1 along the rim.
            let mut d0 = [0.0f64; MAX_VERTS];
            for i in 1..n {
                d0[i] = rel[0].dot(rel[i]);
            }
            let mut tri = [0.0f32; MAX_TRIS];
            let mut omega = 0.0;
            for i in 1..n - 1 {
                let triple = rel[0].dot(light.fan_cross[i - 1]).abs();
                let den = len[0] * len[i] * len[i + 1]
                    + d0[i] * len[i + 1]
                    + d0[i + 1] * len[i]
                    + rel[i].dot(rel[i + 1]) * len[0];
                let t = (2.0 * trig::atan2(triple, den)) as f32;
                tri[i - 1] = if t.is_finite() { t } else { 0.0 };
                omega += tri[i - 1];
            }
            (Strategy::Fan(tri), omega)
        };
        if !(omega > 0.0 && omega.is_finite()) {
            return None;
        }
        let strategy = if omega < SOLID_ANGLE_AREA_FALLBACK {
            Strategy::Area
        } else {
            strategy
        };
        Some(LightSampler {
            light,
            p,
            plane,
            omega,
            strategy,
        })
    }

    /// Solid angle of the light seen from p.
    pub fn solid_angle(&self) -> f32 {
        self.omega
    }

    /// A direction toward the light drawn with `u` in [0,1)², with its
    /// distance and solid-angle pdf; `None` only when rounding leaves no
    /// finite positive pdf.
    pub fn sample(&self, u: Vec2) -> Option<LightSample> {
        let l = self.light;
        let q = match &self.strategy {
            Strategy::Rect(r) => r.sample(u),
            Strategy::Fan(tri) => {
                let (k, ux) = select(&tri[..l.n - 2], self.omega, u.x);
                let a = l.verts[0] - self.p;
                let b = l.verts[k + 1] - self.p;
                let c = l.verts[k + 2] - self.p;
                let dir = spherical_tri::sample(
                    a.normalize(),
                    b.normalize(),
                    c.normalize(),
                    tri[k],
                    Vec2::new(ux, u.y),
                );
                // Place the point on the light's plane: the renderer needs dist.
                dir * (self.plane / dir.dot(l.normal))
            }
            Strategy::Area => l.area_point(self.p, u),
        };
        let dist = q.length();
        let wi = q / dist;
        let pdf = self.pdf_at(wi, dist);
        valid(pdf, dist).then_some(LightSample { wi, dist, pdf })
    }

    /// Solid-angle pdf that `sample` gives to the unit direction `wi`, and the
    /// distance to the light along it; `None` (pdf 0) if `wi` misses the
    /// light or hits its back side.
    pub fn pdf(&self, wi: Vec3) -> Option<(f32, f32)> {
        let dist = self.light.intersect_plane(self.p, self.plane, wi)?;
        let pdf = self.pdf_at(wi, dist);
        valid(pdf, dist).then_some((pdf, dist))
    }

    fn pdf_at(&self, wi: Vec3, dist: f32) -> f32 {
        match self.strategy {
            Strategy::Rect(_) | Strategy::Fan(_) => 1.0 / self.omega,
            // dist² / (area · |cos θ_light|).
            Strategy::Area => dist * dist / (self.light.area * wi.dot(self.light.normal).abs()),
        }
    }
}

/// Picks index k with probability w[k]/total and rescales `x` to [0,1) within
/// the chosen interval (keeps stratification of `x`).
fn select(w: &[f32], total: f32, x: f32) -> (usize, f32) {
    // The last non-empty entry also catches rounding at the top end.
    let Some(last) = w.iter().rposition(|&wk| wk > 0.0 || wk.is_nan()) else {
        return (0, x);
    };
    let target = x * total;
    let mut acc = 0.0;
    for (k, &wk) in w[..=last].iter().enumerate() {
        let next = acc + wk;
        if wk > 0.0 && (target < next || k == last) {
            return (
                k,
                ((target - acc) / wk).clamp(0.0, 1.0 - f32::EPSILON / 2.0),
            );
        }
        acc = next;
    }
    (0, x)
}

/// Uniform point on the light by area, in world space: the "soft-shadow"
/// comparison mode averages visibility over the light this way.
pub fn sample_light_area_uniform(light: &Light, u: Vec2) -> Vec3 {
    if let Some((c, a, b)) = light.quad {
        // A parallelogram: the bilinear map is area-preserving.
        return c + (2.0 * u.x - 1.0) * a + (2.0 * u.y - 1.0) * b;
    }
    let vs = &light.vertices;
    let n = vs.len();
    let mut areas = [0.0f32; MAX_TRIS];
    let mut total = 0.0;
    for i in 1..n - 1 {
        areas[i - 1] = (vs[i] - vs[0]).cross(vs[i + 1] - vs[0]).length();
        total += areas[i - 1];
    }
    let (k, ux) = select(&areas[..n - 2], total, u.x);
    let su = ux.sqrt();
    let (b1, b2) = (su * (1.0 - u.y), su * u.y);
    vs[0] + b1 * (vs[k + 1] - vs[0]) + b2 * (vs[k + 2] - vs[0])
}

/// Finite, positive pdf and distance, else nothing (never NaN downstream).
fn valid(pdf: f32, dist: f32) -> bool {
    pdf.is_finite() && pdf > 0.0 && dist.is_finite() && dist > 0.0
}

/// Samples a direction toward `light` from `p` with `u` in [0,1)². `None` if p
/// is behind a one-sided light, in its plane, or the light subtends nothing
/// representable. Sets everything up per call: per pixel, build a
/// `LightSampler` once instead.
pub fn sample_light(light: &Light, p: Vec3, u: Vec2) -> Option<LightSample> {
    LightSampler::new(&PreparedLight::new(light), p)?.sample(u)
}

/// Solid-angle pdf that `sample_light` gives to the unit direction `wi`, and
/// the distance to the light along it; `None` (pdf 0) if `wi` misses the light,
/// hits its back side, or the light cannot be sampled from `p`.
pub fn light_pdf(light: &Light, p: Vec3, wi: Vec3) -> Option<(f32, f32)> {
    LightSampler::new(&PreparedLight::new(light), p)?.pdf(wi)
}

/// Distance from `p` along unit `wi` to the light, if the ray hits its
/// emitting side (either side when two-sided). For BRDF-sampled directions.
pub fn intersect_light(light: &Light, p: Vec3, wi: Vec3) -> Option<f32> {
    PreparedLight::new(light).intersect(p, wi)
}

/// Relative slack of the point-in-polygon test (a few dozen ulps).
pub(crate) const EDGE_SLACK: f32 = 2e-6;

//! Per-light, per-shading-point sampling: which strategy (spherical rectangle,
//! fan of spherical triangles, or area sampling for tiny solid angles) is a
//! deterministic function of (light, p), so `light_pdf` reproduces exactly the
//! density `sample_light` draws from. Everything is computed on vertices
//! relative to `p`, so float32 precision follows the light's distance from the
//! shading point, not from the world origin.

use super::spherical_rect::SphericalRect;
use super::spherical_tri;
use crate::scene::Light;
use glam::{Vec2, Vec3};

/// Below this solid angle (steradians) the light is sampled uniformly by area
/// and the pdf converted to solid angle. Measured with
/// `examples/sampling_precision` (worst error of the samplers' u.x CDF over
/// random configurations, f32): it grows like ~6e-7/Ω for rectangles and
/// ~2e-6/Ω for triangles; at 1e-3 sr it is 6e-4 and 2e-3, at 1e-4 sr
/// already 6e-3 and 2e-2, and below 1e-5 sr the samplers are useless.
/// Area sampling costs little there: over a light of 1e-3 sr (~0.03 rad
/// across) cos/d² varies by a few percent unless the light is grazing.
pub const SOLID_ANGLE_AREA_FALLBACK: f32 = 1e-3;

/// Lights have at most 8 vertices (SCENE_FORMAT), so a fan has at most 6 triangles.
const MAX_VERTS: usize = 8;

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

/// The light's vertices relative to p, in a fixed-size buffer (no allocation
/// per shading point).
struct Rel {
    v: [Vec3; MAX_VERTS],
    n: usize,
}

impl Rel {
    fn new(light: &Light, p: Vec3) -> Rel {
        let mut v = [Vec3::ZERO; MAX_VERTS];
        let n = light.vertices.len().min(MAX_VERTS);
        for (dst, src) in v.iter_mut().zip(&light.vertices[..n]) {
            *dst = *src - p;
        }
        Rel { v, n }
    }

    fn verts(&self) -> &[Vec3] {
        &self.v[..self.n]
    }
}

/// How sample_light draws for one (light, p). Solid angles are the robust Van
/// Oosterom–Strackee values, per fan triangle.
enum Strategy {
    /// Rectangle: corner and orthogonal edges, relative to p.
    Rect {
        corner: Vec3,
        ex: Vec3,
        ey: Vec3,
        omega: f32,
    },
    /// Fan (v0, vi, vi+1) of spherical triangles chosen by solid angle.
    Fan {
        tri: [f32; MAX_VERTS - 2],
        omega: f32,
    },
    /// Uniform by area, pdf converted to solid angle.
    Area,
}

/// The light as a rectangle `(corner, ex, ey)` relative to p, if it is one:
/// a quad whose half-edges are orthogonal, or a 4-gon with orthogonal edges
/// that closes as a parallelogram. Parallelograms that are not rectangles are
/// not, and go to the triangle fan.
fn as_rect(light: &Light, rel: &Rel, p: Vec3) -> Option<(Vec3, Vec3, Vec3)> {
    const TOL: f32 = 1e-5;
    if let Some((c, u, v)) = light.quad {
        if u.dot(v).abs() <= TOL * u.length() * v.length() {
            return Some((c - u - v - p, 2.0 * u, 2.0 * v));
        }
        return None;
    }
    if rel.n == 4 {
        let [a, b, c, d] = [rel.v[0], rel.v[1], rel.v[2], rel.v[3]];
        let (ex, ey) = (b - a, d - a);
        let size = ex.length() + ey.length();
        let closes = (a + ex + ey - c).length() <= TOL * size;
        if closes && ex.dot(ey).abs() <= TOL * ex.length() * ey.length() {
            return Some((a, ex, ey));
        }
    }
    None
}

/// Signed distance of p from the light's plane, positive on the emitting side.
fn side(light: &Light, rel: &Rel) -> f32 {
    -rel.v[0].dot(light.normal)
}

/// The strategy for (light, p), or None when nothing can be sampled: p behind
/// a one-sided light, p in the light's plane, or a degenerate light.
fn strategy(light: &Light, rel: &Rel, p: Vec3) -> Option<Strategy> {
    if rel.n < 3 {
        return None;
    }
    let h = side(light, rel);
    if !h.is_finite() || h == 0.0 || (!light.two_sided && h < 0.0) {
        return None;
    }
    let vs = rel.verts();
    let mut tri = [0.0f32; MAX_VERTS - 2];
    let mut omega = 0.0;
    for i in 1..rel.n - 1 {
        tri[i - 1] = spherical_tri::solid_angle(vs[0], vs[i], vs[i + 1]);
        omega += tri[i - 1];
    }
    if !(omega > 0.0 && omega.is_finite()) {
        return None;
    }
    if omega < SOLID_ANGLE_AREA_FALLBACK {
        return Some(Strategy::Area);
    }
    if let Some((corner, ex, ey)) = as_rect(light, rel, p) {
        return Some(Strategy::Rect {
            corner,
            ex,
            ey,
            omega,
        });
    }
    Some(Strategy::Fan { tri, omega })
}

/// Uniform point on the polygon by area (relative or absolute, as given):
/// a fan triangle chosen by area, then uniform barycentrics by the square-root
/// map; `u.x` is reused after selection so strata survive.
fn area_point(vs: &[Vec3], u: Vec2) -> Vec3 {
    let n = vs.len();
    let mut areas = [0.0f32; MAX_VERTS - 2];
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

/// Picks index k with probability w[k]/total and rescales `x` to [0,1) within
/// the chosen interval (keeps stratification of `x`).
fn select(w: &[f32], total: f32, x: f32) -> (usize, f32) {
    let target = x * total;
    let mut acc = 0.0;
    for (k, &wk) in w.iter().enumerate() {
        let next = acc + wk;
        // The last non-empty entry also catches rounding at the top end.
        let last = w[k + 1..].iter().all(|&r| r <= 0.0);
        if wk > 0.0 && (target < next || last) {
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
    area_point(&light.vertices, u)
}

/// Solid-angle pdf of area sampling in direction `wi` hitting at `dist`:
/// dist² / (area · |cos θ_light|).
fn area_pdf(light: &Light, wi: Vec3, dist: f32) -> f32 {
    dist * dist / (light.area * wi.dot(light.normal).abs())
}

/// Finite, positive pdf and distance, else nothing (never NaN downstream).
fn valid(pdf: f32, dist: f32) -> bool {
    pdf.is_finite() && pdf > 0.0 && dist.is_finite() && dist > 0.0
}

/// Samples a direction toward `light` from `p` with `u` in [0,1)². `None` if p
/// is behind a one-sided light, in its plane, or the light subtends nothing
/// representable.
pub fn sample_light(light: &Light, p: Vec3, u: Vec2) -> Option<LightSample> {
    let rel = Rel::new(light, p);
    let strat = strategy(light, &rel, p)?;
    let q = match strat {
        Strategy::Rect { corner, ex, ey, .. } => SphericalRect::new(corner, ex, ey)?.sample(u),
        Strategy::Fan { tri, omega } => {
            let vs = rel.verts();
            let (k, ux) = select(&tri[..rel.n - 2], omega, u.x);
            let (a, b, c) = (vs[0], vs[k + 1], vs[k + 2]);
            let dir = spherical_tri::sample(
                a.normalize(),
                b.normalize(),
                c.normalize(),
                tri[k],
                Vec2::new(ux, u.y),
            );
            // Place the point on the light's plane: the renderer needs dist.
            let t = a.dot(light.normal) / dir.dot(light.normal);
            dir * t
        }
        Strategy::Area => area_point(rel.verts(), u),
    };
    let dist = q.length();
    let wi = q / dist;
    let pdf = strategy_pdf(&strat, light, wi, dist);
    valid(pdf, dist).then_some(LightSample { wi, dist, pdf })
}

/// The pdf of direction `wi` (hitting at `dist`) under the strategy for (light, p).
fn strategy_pdf(strat: &Strategy, light: &Light, wi: Vec3, dist: f32) -> f32 {
    match *strat {
        Strategy::Rect { omega, .. } | Strategy::Fan { omega, .. } => 1.0 / omega,
        Strategy::Area => area_pdf(light, wi, dist),
    }
}

/// Solid-angle pdf that `sample_light` gives to the unit direction `wi`, and
/// the distance to the light along it; `None` (pdf 0) if `wi` misses the light,
/// hits its back side, or the light cannot be sampled from `p`.
pub fn light_pdf(light: &Light, p: Vec3, wi: Vec3) -> Option<(f32, f32)> {
    let rel = Rel::new(light, p);
    let dist = intersect_rel(light, &rel, wi)?;
    let pdf = strategy_pdf(&strategy(light, &rel, p)?, light, wi, dist);
    valid(pdf, dist).then_some((pdf, dist))
}

/// Distance from `p` along unit `wi` to the light, if the ray hits its
/// emitting side (either side when two-sided). For BRDF-sampled directions.
pub fn intersect_light(light: &Light, p: Vec3, wi: Vec3) -> Option<f32> {
    intersect_rel(light, &Rel::new(light, p), wi)
}

fn intersect_rel(light: &Light, rel: &Rel, wi: Vec3) -> Option<f32> {
    if rel.n < 3 {
        return None;
    }
    let n = light.normal;
    let cos = wi.dot(n);
    // One-sided lights emit along +n: a ray sees the front only travelling against n.
    if cos == 0.0 || (!light.two_sided && cos > 0.0) {
        return None;
    }
    let t = rel.v[0].dot(n) / cos;
    if !(t > 0.0 && t.is_finite()) {
        return None;
    }
    let q = wi * t;
    let vs = rel.verts();
    for i in 0..rel.n {
        let a = vs[i];
        let e = vs[(i + 1) % rel.n] - a;
        // Right-hand rule: the interior is on the left of every edge seen
        // from +n. The slack covers rounding of a sample placed on an edge;
        // it scales with the edge and with the distance to p, which set the
        // size of that rounding.
        let tol = EDGE_SLACK * e.length() * (t + e.length());
        if e.cross(q - a).dot(n) < -tol {
            return None;
        }
    }
    Some(t)
}

/// Relative slack of the point-in-polygon test (a few dozen ulps).
const EDGE_SLACK: f32 = 2e-6;

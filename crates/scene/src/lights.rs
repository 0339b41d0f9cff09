//! Geometry checks for area lights and quads: the renderer's analytic
//! integrators (LTC, polygon form factors, spherical sampling) silently give
//! garbage for degenerate, non-planar, non-convex or self-overlapping
//! polygons, so those are refused here with a reason.
//!
//! Checks run in f64 with tolerances relative to the polygon's size, so the
//! same shape is accepted or refused whatever its scale.

use super::fields::fmt_vec3;
use glam::{DVec3, Vec3};

/// Relative tolerance below which an area (relative to size^2) or a corner's
/// sine counts as zero.
const DEGENERATE_REL: f64 = 1e-6;
/// Largest distance from the plane, relative to the polygon's diameter.
const PLANAR_REL: f64 = 1e-3;

/// `true` when the parallelogram spanned by `u` and `v` has (relatively)
/// zero area: u or v zero, or u parallel to v.
pub fn parallelogram_degenerate(u: Vec3, v: Vec3) -> bool {
    // The renderer works in f32: a cross product that underflows there has
    // no usable normal even if f64 could still see an area.
    if u.cross(v).try_normalize().is_none() {
        return true;
    }
    let (u, v) = (u.as_dvec3(), v.as_dvec3());
    let a = u.cross(v).length();
    // Inputs are finite (checked by the parser), so plain comparisons suffice.
    a == 0.0 || a <= DEGENERATE_REL * u.length() * v.length()
}

/// Unit normal and area of a polygon light, or why it is refused.
/// The normal is the right-hand-rule normal of the vertex order.
pub fn polygon_geometry(verts: &[Vec3]) -> Result<(Vec3, f32), String> {
    let n = verts.len();
    if !(3..=8).contains(&n) {
        return Err(format!("must have 3 to 8 vertices, found {n}"));
    }
    let p: Vec<DVec3> = verts.iter().map(|v| v.as_dvec3()).collect();
    let centroid = p.iter().copied().sum::<DVec3>() / n as f64;
    let mut size: f64 = 0.0;
    for a in &p {
        for b in &p {
            size = size.max(a.distance(*b));
        }
    }
    if size == 0.0 {
        return Err("all vertices coincide (zero area)".into());
    }
    for i in 0..n {
        let j = (i + 1) % n;
        if p[i].distance(p[j]) <= DEGENERATE_REL * size {
            return Err(format!("vertices {i} and {j} coincide (degenerate edge)"));
        }
    }
    // Newell's normal: twice the vector area, robust for any simple polygon.
    let mut newell = DVec3::ZERO;
    for i in 0..n {
        newell += (p[i] - centroid).cross(p[(i + 1) % n] - centroid);
    }
    let twice_area = newell.length();
    if twice_area <= 2.0 * DEGENERATE_REL * size * size {
        return Err("the vertices are collinear (zero area)".into());
    }
    if ((0.5 * twice_area) as f32) < f32::MIN_POSITIVE {
        return Err("the polygon is too small to represent (zero area in f32)".into());
    }
    let normal = newell / twice_area;
    for (i, q) in p.iter().enumerate() {
        let d = (*q - centroid).dot(normal).abs();
        if d > PLANAR_REL * size {
            return Err(format!(
                "not planar: vertex {i} is {d:.3e} off the plane of the others (tolerance {:.3e})",
                PLANAR_REL * size
            ));
        }
    }
    // Every corner must turn the same way (convex, consistently wound), and
    // the turns must add up to one full revolution (not a star that winds
    // around twice).
    let mut turning = 0.0;
    for i in 0..n {
        let e0 = p[i] - p[(i + n - 1) % n];
        let e1 = p[(i + 1) % n] - p[i];
        let sin = e0.cross(e1).dot(normal) / (e0.length() * e1.length());
        if sin < -DEGENERATE_REL {
            return Err(format!(
                "not convex (or inconsistently wound) at vertex {i}"
            ));
        }
        if sin <= DEGENERATE_REL {
            return Err(format!(
                "vertex {i} is collinear with its neighbours (degenerate corner)"
            ));
        }
        turning += e0.cross(e1).dot(normal).atan2(e0.dot(e1));
    }
    if turning > std::f64::consts::TAU + 1e-3 {
        return Err(format!(
            "self-overlapping winding: the edges turn {:.0} degrees in total, not 360",
            turning.to_degrees()
        ));
    }
    Ok((normal.as_vec3(), (0.5 * twice_area) as f32))
}

/// Why `Light::quad` or `Light::polygon` refused a light.
#[derive(Debug, Clone, PartialEq)]
pub enum LightError {
    /// A radiance channel is negative.
    NegativeRadiance(Vec3),
    /// The quad's `u` and `v` span zero area (a zero or parallel edge).
    ZeroArea { u: Vec3, v: Vec3 },
    /// The polygon's vertices are refused by `polygon_geometry`, for this reason.
    Polygon(String),
}

impl std::fmt::Display for LightError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            LightError::NegativeRadiance(r) => {
                write!(f, "radiance = {} has a negative channel", fmt_vec3(*r))
            }
            LightError::ZeroArea { u, v } => write!(
                f,
                "u = {} and v = {} span zero area (u x v = 0: a zero or parallel edge)",
                fmt_vec3(*u),
                fmt_vec3(*v)
            ),
            LightError::Polygon(msg) => write!(f, "vertices: {msg}"),
        }
    }
}

impl std::error::Error for LightError {}

fn check_radiance(radiance: Vec3) -> Result<(), LightError> {
    if radiance.min_element() < 0.0 {
        return Err(LightError::NegativeRadiance(radiance));
    }
    Ok(())
}

impl super::Light {
    /// A one-sided parallelogram light with corners `center` +- `u` +- `v`,
    /// emitting along `u` x `v`: the light a scene file's `type = "quad"`
    /// table describes. Refused where the loader refuses it.
    pub fn quad(center: Vec3, u: Vec3, v: Vec3, radiance: Vec3) -> Result<Self, LightError> {
        check_radiance(radiance)?;
        if parallelogram_degenerate(u, v) {
            return Err(LightError::ZeroArea { u, v });
        }
        let c = center;
        let cross = u.cross(v);
        Ok(super::Light {
            // Right-hand order: the emitting side is normalize(cross(u, v)).
            vertices: vec![c - u - v, c + u - v, c + u + v, c - u + v],
            radiance,
            two_sided: false,
            normal: cross.normalize(),
            area: 4.0 * cross.length(),
            quad: Some((c, u, v)),
        })
    }

    /// A one-sided planar convex polygon light of 3 to 8 vertices, emitting
    /// along the right-hand-rule normal of their order: the light a scene
    /// file's `type = "polygon"` table describes. Refused where the loader
    /// refuses it.
    pub fn polygon(vertices: Vec<Vec3>, radiance: Vec3) -> Result<Self, LightError> {
        check_radiance(radiance)?;
        let (normal, area) = polygon_geometry(&vertices).map_err(LightError::Polygon)?;
        Ok(super::Light {
            vertices,
            radiance,
            two_sided: false,
            normal,
            area,
            quad: None,
        })
    }

    /// The same light, emitting from both sides when `two_sided`.
    pub fn with_two_sided(mut self, two_sided: bool) -> Self {
        self.two_sided = two_sided;
        self
    }
}

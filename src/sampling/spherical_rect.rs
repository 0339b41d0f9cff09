//! Uniform solid-angle sampling of a rectangle (Ureña, Fajardo, King 2013,
//! "An Area-Preserving Parametrization for Spherical Rectangles"). Only for
//! true rectangles: the construction relies on the edges being orthogonal.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A rectangle as seen from the origin (the shading point), set up once for
/// any number of samples.
#[derive(Debug, Clone, Copy)]
pub struct SphericalRect {
    x: Vec3,
    y: Vec3,
    z: Vec3,
    z0: f32,
    x0: f32,
    x1: f32,
    y0: f32,
    y1: f32,
    b0: f32,
    b1: f32,
    k: f32,
    /// Solid angle from the construction (g0 + g1 − k): loses relative
    /// precision for tiny rectangles because it is a difference of angles near π.
    solid_angle: f32,
}

impl SphericalRect {
    /// `corner` relative to the viewpoint; `ex`, `ey` the two orthogonal edges
    /// leaving it. `None` if the viewpoint lies in the rectangle's plane or an
    /// edge is degenerate.
    pub fn new(corner: Vec3, ex: Vec3, ey: Vec3) -> Option<SphericalRect> {
        let (lx, ly) = (ex.length(), ey.length());
        if !(lx > 0.0 && ly > 0.0) {
            return None;
        }
        let x = ex / lx;
        let y = ey / ly;
        let mut z = x.cross(y);
        let x0 = corner.dot(x);
        let y0 = corner.dot(y);
        let mut z0 = corner.dot(z);
        // Work with the rectangle in the half space z < 0 of its own frame.
        if z0 > 0.0 {
            z0 = -z0;
            z = -z;
        }
        if z0.is_nan() || z0 >= 0.0 {
            return None;
        }
        let x1 = x0 + lx;
        let y1 = y0 + ly;
        // Normals of the four planes through the origin and each edge, in
        // closed form (cross products of the corner vectors, simplified).
        let n0 = Vec3::new(0.0, z0, -y0) / (z0 * z0 + y0 * y0).sqrt();
        let n1 = Vec3::new(-z0, 0.0, x1) / (z0 * z0 + x1 * x1).sqrt();
        let n2 = Vec3::new(0.0, -z0, y1) / (z0 * z0 + y1 * y1).sqrt();
        let n3 = Vec3::new(z0, 0.0, -x0) / (z0 * z0 + x0 * x0).sqrt();
        // Interior angles of the spherical quadrilateral.
        let g0 = (-n0.dot(n1)).clamp(-1.0, 1.0).acos();
        let g1 = (-n1.dot(n2)).clamp(-1.0, 1.0).acos();
        let g2 = (-n2.dot(n3)).clamp(-1.0, 1.0).acos();
        let g3 = (-n3.dot(n0)).clamp(-1.0, 1.0).acos();
        let k = 2.0 * PI - g2 - g3;
        let solid_angle = g0 + g1 - k;
        Some(SphericalRect {
            x,
            y,
            z,
            z0,
            x0,
            x1,
            y0,
            y1,
            b0: n0.z,
            b1: n2.z,
            k,
            solid_angle,
        })
    }

    /// The construction's own solid angle (see the field's note on precision).
    pub fn solid_angle(&self) -> f32 {
        self.solid_angle
    }

    /// A point on the rectangle (relative to the viewpoint) whose direction is
    /// uniform in solid angle. `u.x` picks the column x (by the solid angle of
    /// the slab left of it), `u.y` the height within it, so strata in `u` stay
    /// strata on the rectangle.
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let au = u.x * self.solid_angle + self.k;
        let (sin_au, cos_au) = au.sin_cos();
        let fu = (cos_au * self.b0 - self.b1) / sin_au;
        let cu = ((fu * fu + self.b0 * self.b0).sqrt().recip()).copysign(fu);
        let cu = if cu.is_finite() {
            cu.clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let xu = -(cu * self.z0) / (1.0 - cu * cu).max(0.0).sqrt();
        // NaN (0/0) or ±inf at the ends of the range: clamp puts it on the edge.
        let xu = if xu.is_nan() { self.x0 } else { xu };
        let xu = xu.clamp(self.x0, self.x1);
        let d2 = xu * xu + self.z0 * self.z0;
        let d = d2.sqrt();
        let h0 = self.y0 / (d2 + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d2 + self.y1 * self.y1).sqrt();
        let hv = h0 + u.y * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-6 {
            (hv * d / (1.0 - hv2).sqrt()).clamp(self.y0, self.y1)
        } else if hv > 0.0 {
            self.y1
        } else {
            self.y0
        };
        xu * self.x + yv * self.y + self.z0 * self.z
    }
}

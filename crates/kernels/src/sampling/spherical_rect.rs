//! Uniform solid-angle sampling of a rectangle (Ureña, Fajardo, King 2013,
//! "An Area-Preserving Parametrization for Spherical Rectangles"). Only for
//! true rectangles: the construction relies on the edges being orthogonal.

use super::lanes8::{
    D, D3, DM, F, F3, add3, clampc, clampf, copysign, cross, dnan, dot, ds, finite, fmax, fnan, fs,
    narrow, narrow3, scale3, widen, widen3,
};
use super::trig;
use glam::{DVec3, Vec2, Vec3};

/// The rectangle's own frame, independent of the viewpoint: built once per
/// light so that per-point setup is three dot products. f64 because the
/// per-point solid angle is only as accurate as the height `z0` taken from it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct RectFrame {
    x: DVec3,
    y: DVec3,
    lx: f64,
    ly: f64,
}

impl RectFrame {
    /// `ex`, `ey` the two orthogonal edges; `None` if one is degenerate.
    pub(crate) fn new(ex: Vec3, ey: Vec3) -> Option<RectFrame> {
        let (ex, ey) = (ex.as_dvec3(), ey.as_dvec3());
        let (lx, ly) = (ex.length(), ey.length());
        if !(lx > 0.0 && ly > 0.0 && lx.is_finite() && ly.is_finite()) {
            return None;
        }
        Some(RectFrame {
            x: ex / lx,
            y: ey / ly,
            lx,
            ly,
        })
    }
}

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
    /// sin and cos of Ureña's k = 2π − γ2 − γ3. Sampling needs only
    /// sin/cos(k + u·Ω), which the addition theorem gives from these and
    /// sin/cos(u·Ω): no inverse trigonometry in the setup, and no loss of the
    /// small u·Ω against k ≈ π in f32.
    sin_k: f32,
    cos_k: f32,
    /// Solid angle by Van Oosterom–Strackee on the two halves of the
    /// rectangle, combined into a single atan2 (see `from_frame`).
    solid_angle: f32,
}

impl SphericalRect {
    /// `corner` relative to the viewpoint; `ex`, `ey` the two orthogonal edges
    /// leaving it. `None` if the viewpoint lies in the rectangle's plane or an
    /// edge is degenerate.
    pub fn new(corner: Vec3, ex: Vec3, ey: Vec3) -> Option<SphericalRect> {
        Self::from_frame(corner, &RectFrame::new(ex, ey)?)
    }

    /// As `new`, with the viewpoint-independent frame precomputed.
    pub(crate) fn from_frame(corner: Vec3, f: &RectFrame) -> Option<SphericalRect> {
        let c = corner.as_dvec3();
        let mut z = f.x.cross(f.y);
        let x0 = c.dot(f.x);
        let y0 = c.dot(f.y);
        let mut z0 = c.dot(z);
        // Work with the rectangle in the half space z < 0 of its own frame.
        if z0 > 0.0 {
            z0 = -z0;
            z = -z;
        }
        if z0.is_nan() || z0 >= 0.0 {
            return None;
        }
        let (x1, y1) = (x0 + f.lx, y0 + f.ly);
        // Everything below is f64: a handful of scalar operations, and it
        // keeps the solid angle exact to f32 for lights from ~π sr (heavy
        // cancellation in the VOS denominators) down to the area fallback.
        let z2 = z0 * z0;
        let (xx0, xx1, yy0, yy1) = (x0 * x0, x1 * x1, y0 * y0, y1 * y1);
        // Distances to the corners c_ij = (x_i, y_j, z0).
        let r00 = (xx0 + yy0 + z2).sqrt();
        let r10 = (xx1 + yy0 + z2).sqrt();
        let r11 = (xx1 + yy1 + z2).sqrt();
        let r01 = (xx0 + yy1 + z2).sqrt();
        // Van Oosterom–Strackee for (c00, c10, c11) and (c00, c11, c01): both
        // triple products are exactly |z0|·lx·ly in this frame (no
        // cancellation for tiny distant rectangles).
        let num = -z0 * f.lx * f.ly;
        let (d00_10, d00_11, d00_01) = (
            x0 * x1 + yy0 + z2,
            x0 * x1 + y0 * y1 + z2,
            xx0 + y0 * y1 + z2,
        );
        let (d10_11, d11_01) = (xx1 + y0 * y1 + z2, x0 * x1 + yy1 + z2);
        let den1 = r00 * r10 * r11 + d00_10 * r11 + d00_11 * r10 + d10_11 * r00;
        let den2 = r00 * r11 * r01 + d00_11 * r01 + d00_01 * r11 + d11_01 * r00;
        // Ω/2 = atan2(num, den1) + atan2(num, den2) = arg((den1 + i·num)(den2 + i·num)),
        // which stays below π for any planar rectangle: one atan2 instead of two.
        let solid_angle = (2.0 * trig::atan2(num * (den1 + den2), den1 * den2 - num * num)) as f32;
        // Great-circle normals through the edges (Ureña's n0, n2, n3) are
        // (0, z0, −y0)/r0, (0, −z0, y1)/r2, (z0, 0, −x0)/r3; their interior
        // angles γ2, γ3 in closed form, cos and sin both.
        let r0 = (z2 + yy0).sqrt();
        let r2 = (z2 + yy1).sqrt();
        let r3 = (z2 + xx0).sqrt();
        let (c2, s2) = (x0 * y1 / (r2 * r3), -z0 * r01 / (r2 * r3));
        let (c3, s3) = (-x0 * y0 / (r3 * r0), -z0 * r00 / (r3 * r0));
        // k = 2π − (γ2 + γ3).
        let cos_k = c2 * c3 - s2 * s3;
        let sin_k = -(s2 * c3 + c2 * s3);
        Some(SphericalRect {
            x: f.x.as_vec3(),
            y: f.y.as_vec3(),
            z: z.as_vec3(),
            z0: z0 as f32,
            x0: x0 as f32,
            x1: x1 as f32,
            y0: y0 as f32,
            y1: y1 as f32,
            b0: (-y0 / r0) as f32,
            b1: (y1 / r2) as f32,
            sin_k: sin_k as f32,
            cos_k: cos_k as f32,
            solid_angle,
        })
    }

    /// The solid angle the sampler covers (exact to f32 rounding).
    pub fn solid_angle(&self) -> f32 {
        self.solid_angle
    }

    /// A point on the rectangle (relative to the viewpoint) whose direction is
    /// uniform in solid angle. `u.x` picks the column x (by the solid angle of
    /// the slab left of it), `u.y` the height within it, so strata in `u` stay
    /// strata on the rectangle.
    pub fn sample(&self, u: Vec2) -> Vec3 {
        // sin/cos of au = k + u.x·Ω by the addition theorem.
        let (st, ct) = trig::sin_cos_f32(u.x * self.solid_angle);
        let sin_au = self.sin_k * ct + self.cos_k * st;
        let cos_au = self.cos_k * ct - self.sin_k * st;
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

impl RectFrame {
    /// The frame's axes and edge lengths: `(x, y, lx, ly)`.
    pub(crate) fn parts(&self) -> (DVec3, DVec3, f64, f64) {
        (self.x, self.y, self.lx, self.ly)
    }
}

/// `SphericalRect` for eight viewpoints at once, one per lane, each
/// lane's numbers the bits `SphericalRect::from_frame` and `sample` give
/// for it: the same operations in the same order, branches as selects.
#[derive(Debug, Clone, Copy)]
pub struct SphericalRectLanes {
    x: F3,
    y: F3,
    z: F3,
    z0: F,
    x0: F,
    x1: F,
    y0: F,
    y1: F,
    b0: F,
    b1: F,
    sin_k: F,
    cos_k: F,
    pub solid_angle: F,
}

impl SphericalRectLanes {
    /// `from_frame` per lane: `corner` relative to the viewpoint, the
    /// frame's axes `fx`, `fy` and edge lengths `lx`, `ly`. The mask holds
    /// the lanes where `from_frame` gives a rectangle.
    #[inline(always)]
    pub fn from_frame(corner: &F3, fx: &D3, fy: &D3, lx: D, ly: D) -> (SphericalRectLanes, DM) {
        let c = widen3(corner);
        let z = cross(fx, fy);
        let x0 = dot(&c, fx);
        let y0 = dot(&c, fy);
        let z0 = dot(&c, &z);
        let flip = z0.gt(ds(0.0));
        let z0 = flip.select(-z0, z0);
        let z = [
            flip.select(-z[0], z[0]),
            flip.select(-z[1], z[1]),
            flip.select(-z[2], z[2]),
        ];
        let ok = dnan(z0).or(z0.ge(ds(0.0))).invert();
        let (x1, y1) = (x0 + lx, y0 + ly);
        let z2 = z0 * z0;
        let (xx0, xx1, yy0, yy1) = (x0 * x0, x1 * x1, y0 * y0, y1 * y1);
        let r00 = (xx0 + yy0 + z2).sqrt();
        let r10 = (xx1 + yy0 + z2).sqrt();
        let r11 = (xx1 + yy1 + z2).sqrt();
        let r01 = (xx0 + yy1 + z2).sqrt();
        let num = -z0 * lx * ly;
        let (d00_10, d00_11, d00_01) = (
            x0 * x1 + yy0 + z2,
            x0 * x1 + y0 * y1 + z2,
            xx0 + y0 * y1 + z2,
        );
        let (d10_11, d11_01) = (xx1 + y0 * y1 + z2, x0 * x1 + yy1 + z2);
        let den1 = r00 * r10 * r11 + d00_10 * r11 + d00_11 * r10 + d10_11 * r00;
        let den2 = r00 * r11 * r01 + d00_11 * r01 + d00_01 * r11 + d11_01 * r00;
        let solid_angle =
            narrow(ds(2.0) * trig::atan2_lanes(num * (den1 + den2), den1 * den2 - num * num));
        let r0 = (z2 + yy0).sqrt();
        let r2 = (z2 + yy1).sqrt();
        let r3 = (z2 + xx0).sqrt();
        let (c2, s2) = (x0 * y1 / (r2 * r3), -z0 * r01 / (r2 * r3));
        let (c3, s3) = (-x0 * y0 / (r3 * r0), -z0 * r00 / (r3 * r0));
        let cos_k = c2 * c3 - s2 * s3;
        let sin_k = -(s2 * c3 + c2 * s3);
        let r = SphericalRectLanes {
            x: narrow3(fx),
            y: narrow3(fy),
            z: narrow3(&z),
            z0: narrow(z0),
            x0: narrow(x0),
            x1: narrow(x1),
            y0: narrow(y0),
            y1: narrow(y1),
            b0: narrow(-y0 / r0),
            b1: narrow(y1 / r2),
            sin_k: narrow(sin_k),
            cos_k: narrow(cos_k),
            solid_angle,
        };
        (r, ok)
    }

    /// `sample` per lane, `u = (ux, uy)`.
    #[inline(always)]
    pub fn sample(&self, ux: F, uy: F) -> F3 {
        let (st, ct) = trig::sin_cos_lanes(widen(ux * self.solid_angle));
        let (st, ct) = (narrow(st), narrow(ct));
        let sin_au = self.sin_k * ct + self.cos_k * st;
        let cos_au = self.cos_k * ct - self.sin_k * st;
        let fu = (cos_au * self.b0 - self.b1) / sin_au;
        let cu = copysign(fs(1.0) / (fu * fu + self.b0 * self.b0).sqrt(), fu);
        let cu = finite(cu).select(clampc(cu, -1.0, 1.0), fs(0.0));
        let xu = -(cu * self.z0) / fmax(fs(1.0) - cu * cu, fs(0.0)).sqrt();
        let xu = fnan(xu).select(self.x0, xu);
        let xu = clampf(xu, self.x0, self.x1);
        let d2 = xu * xu + self.z0 * self.z0;
        let d = d2.sqrt();
        let h0 = self.y0 / (d2 + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d2 + self.y1 * self.y1).sqrt();
        let hv = h0 + uy * (h1 - h0);
        let hv2 = hv * hv;
        let inside = clampf(hv * d / (fs(1.0) - hv2).sqrt(), self.y0, self.y1);
        let yv = hv2
            .lt(fs(1.0 - 1e-6))
            .select(inside, hv.gt(fs(0.0)).select(self.y1, self.y0));
        let a = scale3(&self.x, xu);
        let b = scale3(&self.y, yv);
        let c = scale3(&self.z, self.z0);
        add3(&add3(&a, &b), &c)
    }
}

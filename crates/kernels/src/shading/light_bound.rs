//! Upper bounds on the analytic `U` one light can give any point of a group
//! (a screen tile): the light culling of the `U` stage skips a light only
//! when these bounds prove its share negligible.
//!
//! The bounds hold for the BRDF of docs/scene-format.md and every point of
//! the group, whatever its position, normal, view and roughness within the
//! group's ranges:
//! - Lambert: `U_d <= kd / pi * L * omega * cos_max`, and `<= kd * L` (a form
//!   factor is at most 1);
//! - GGX: `f cos_i = F D G2 / (4 cos_o) <= F_max D_max G1(wo) / (4 cos_o)`
//!   (height-correlated `G2 <= G1(wo)`), so `U_s <= L F_max D_max G1 / (4
//!   cos_o) * omega`, and `<= L F_max` (directional albedo at most `F_max`),
//!   each with a margin for the LTC fit; none where a view lies under its
//!   shading horizon;
//! - the light's solid angle `omega <= A cos_light_max / d_min^2`, and
//!   `<= 2 pi`.
//!
//! Every maximum comes from cones: of the directions from the group to the
//! light (spheres around both), of the group's shading normals and of its
//! view directions. Angles are carried as (cosine, sine) pairs so that a
//! bound costs square roots only.

use super::SurfacePoint;
use super::brdf::alpha_from_roughness;
use glam::Vec3;
use penumbra_scene::Light;
use penumbra_scene::color::luminance;

/// Margin on the GGX bound (its lobe term and its albedo cap) for the LTC
/// fit's own error: the computed `U` may exceed the exact integral by the
/// fit's error (under 85 % in the worst case docs/accuracy.md asserts), and
/// a bound must hold for what would be computed. The tests measure the
/// computed `U` against the bound.
pub(super) const LTC_FIT_MARGIN: f32 = 2.0;

/// An angle in [0, pi] as its cosine and sine.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Angle {
    cos: f32,
    sin: f32,
}

impl Angle {
    const ZERO: Angle = Angle { cos: 1.0, sin: 0.0 };
    const PI: Angle = Angle {
        cos: -1.0,
        sin: 0.0,
    };

    fn from_cos(cos: f32) -> Angle {
        let cos = cos.clamp(-1.0, 1.0);
        Angle {
            cos,
            sin: (1.0 - cos * cos).max(0.0).sqrt(),
        }
    }

    fn from_sin(sin: f32) -> Angle {
        let sin = sin.clamp(0.0, 1.0);
        Angle {
            cos: (1.0 - sin * sin).max(0.0).sqrt(),
            sin,
        }
    }

    /// Between two unit vectors.
    fn between(a: Vec3, b: Vec3) -> Angle {
        Angle::from_cos(a.dot(b))
    }

    /// `self + other`, at most pi.
    fn plus(self, other: Angle) -> Angle {
        if self.cos + other.cos <= 0.0 {
            return Angle::PI;
        }
        Angle {
            cos: self.cos * other.cos - self.sin * other.sin,
            sin: (self.sin * other.cos + self.cos * other.sin).max(0.0),
        }
    }

    /// `self - other`, at least 0.
    fn minus(self, other: Angle) -> Angle {
        if self.cos >= other.cos {
            return Angle::ZERO;
        }
        Angle {
            cos: self.cos * other.cos + self.sin * other.sin,
            sin: (self.sin * other.cos - self.cos * other.sin).max(0.0),
        }
    }

    /// The chord `|a - b|` of two unit vectors this angle apart.
    fn chord(self) -> f32 {
        (2.0 * (1.0 - self.cos)).max(0.0).sqrt()
    }
}

/// A cone of unit directions: its axis and half-angle.
#[derive(Clone, Copy, Debug)]
struct Cone {
    axis: Vec3,
    half: Angle,
}

impl Cone {
    /// The smallest cone about the directions' normalised sum that holds
    /// them all; the whole sphere when they cancel.
    fn around(dirs: impl Iterator<Item = Vec3> + Clone) -> Cone {
        let sum: Vec3 = dirs.clone().sum();
        let Some(axis) = sum.try_normalize() else {
            return Cone {
                axis: Vec3::Z,
                half: Angle::PI,
            };
        };
        let cos = dirs.fold(1.0f32, |c, d| c.min(axis.dot(d)));
        Cone {
            axis,
            half: Angle::from_cos(cos),
        }
    }
}

/// What the bounds need of a light: a sphere around it, its area, plane,
/// sidedness and the luminance of its radiance.
#[derive(Clone, Copy, Debug)]
pub struct LightExtent {
    pub(super) centre: Vec3,
    pub(super) radius: f32,
    pub(super) area: f32,
    pub(super) normal: Vec3,
    pub(super) two_sided: bool,
    luminance: f32,
}

impl LightExtent {
    pub fn new(light: &Light) -> LightExtent {
        let n = light.vertices.len().max(1) as f32;
        let centre = light.vertices.iter().copied().sum::<Vec3>() / n;
        let radius = light
            .vertices
            .iter()
            .fold(0.0f32, |r, v| r.max(v.distance(centre)));
        LightExtent {
            centre,
            // Rounding of the centre and of the vertices' distances.
            radius: radius * (1.0 + 1e-5) + 1e-6 * centre.abs().max_element(),
            area: light.area,
            normal: light.normal,
            two_sided: light.two_sided,
            luminance: luminance(light.radiance),
        }
    }
}

/// What bounds any light's `U` over a group of shading points.
#[derive(Clone, Copy, Debug)]
pub struct PointGroup {
    centre: Vec3,
    radius: f32,
    normals: Cone,
    views: Cone,
    /// Smallest `n . wo`: at or below 0 some point's view is under its
    /// shading horizon (a bent normal), where the LTC reads its grazing
    /// entry instead of the BRDF, and no GGX bound holds.
    cos_view: f32,
    alpha_min: f32,
    alpha_max: f32,
    /// Largest channel of the diffuse albedo.
    diffuse: f32,
    /// Largest channel of F0 among points with a specular lobe; `None` when
    /// no point has one.
    specular: Option<f32>,
}

/// Bounds on one light's `U` over a group, in luminance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeBound {
    pub diffuse: f32,
    pub specular: f32,
}

impl LobeBound {
    /// No bound: the light is too close to the group to bound it.
    pub const NONE: LobeBound = LobeBound {
        diffuse: f32::INFINITY,
        specular: f32::INFINITY,
    };

    pub fn total(self) -> f32 {
        self.diffuse + self.specular
    }
}

impl PointGroup {
    /// The group of `points`; `None` when it is empty.
    pub fn new(points: &[SurfacePoint]) -> Option<PointGroup> {
        let first = points.first()?;
        let (mut lo, mut hi) = (first.p, first.p);
        let mut group = PointGroup {
            centre: Vec3::ZERO,
            radius: 0.0,
            normals: Cone::around(points.iter().map(|s| s.n)),
            views: Cone::around(points.iter().map(|s| s.wo)),
            cos_view: 1.0,
            alpha_min: f32::INFINITY,
            alpha_max: 0.0,
            diffuse: 0.0,
            specular: None,
        };
        for s in points {
            lo = lo.min(s.p);
            hi = hi.max(s.p);
            group.cos_view = group.cos_view.min(s.n.dot(s.wo));
            let alpha = alpha_from_roughness(s.roughness);
            group.alpha_min = group.alpha_min.min(alpha);
            group.alpha_max = group.alpha_max.max(alpha);
            group.diffuse = group.diffuse.max(s.diffuse.max_element());
            let ks = s.specular.max_element();
            if ks > 0.0 {
                group.specular = Some(group.specular.map_or(ks, |k: f32| k.max(ks)));
            }
        }
        group.centre = 0.5 * (lo + hi);
        let scale = lo.abs().max(hi.abs()).max_element();
        group.radius = 0.5 * (hi - lo).length() * (1.0 + 1e-5) + 1e-6 * scale;
        Some(group)
    }

    /// The largest channel of the group's diffuse albedo.
    pub fn albedo(&self) -> f32 {
        self.diffuse
    }

    /// Upper bounds on `light`'s Lambert and GGX `U` at every point of the group.
    pub fn bound(&self, light: &LightExtent) -> LobeBound {
        let to = light.centre - self.centre;
        let dist = to.length();
        let reach = self.radius + light.radius;
        // Closer than this the cones below grow to a hemisphere and more:
        // nothing useful can be bounded.
        // NaN distances count as close.
        let apart = dist > 1.5 * reach;
        if !apart || light.luminance <= 0.0 {
            return if light.luminance > 0.0 {
                LobeBound::NONE
            } else {
                LobeBound {
                    diffuse: 0.0,
                    specular: 0.0,
                }
            };
        }
        let axis = to / dist;
        let spread = Angle::from_sin(reach / dist);
        let zero = LobeBound {
            diffuse: 0.0,
            specular: 0.0,
        };
        // The light's own cosine towards the group.
        let cos_light = if light.two_sided {
            light.normal.dot(axis).abs()
        } else {
            -light.normal.dot(axis)
        };
        let cos_light = Angle::from_cos(cos_light).minus(spread).cos;
        if cos_light <= 0.0 {
            return zero;
        }
        // The surfaces' cosine towards the light.
        let to_light = Angle::between(self.normals.axis, axis);
        let cos_surface = to_light.minus(self.normals.half.plus(spread)).cos;
        if cos_surface <= 0.0 {
            return zero;
        }
        let near = dist - reach;
        let omega = (light.area * cos_light / (near * near)).min(std::f32::consts::TAU);
        let diffuse = self.diffuse
            * light.luminance
            * (omega * cos_surface * std::f32::consts::FRAC_1_PI).min(1.0);
        let specular = match self.specular {
            Some(_) if self.cos_view <= 0.0 => f32::INFINITY,
            Some(ks) => light.luminance * ks_bound(self, ks, axis, spread, omega),
            None => 0.0,
        };
        LobeBound { diffuse, specular }
    }
}

/// How the points of a group see a light that is wholly above every
/// point's horizon and faces every point, each edge under 60 degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FarView {
    /// Least distance from a point to the light.
    pub near: f32,
    /// Largest coordinate magnitude of the points and the light.
    pub scale: f32,
}

impl PointGroup {
    /// `Some` when `light` is seen by every point of the group wholly above
    /// its horizon, from its emitting side, every edge under 60 degrees
    /// (the far case of `shading::far_light`).
    pub fn far_view(&self, light: &LightExtent) -> Option<FarView> {
        let to = light.centre - self.centre;
        let dist = to.length();
        let reach = self.radius + light.radius;
        let near = dist - reach;
        // An edge is at most 2 r long, seen from at least 2 r away.
        let apart = dist > 1.5 * reach && near > 2.0 * light.radius;
        if !apart {
            return None;
        }
        let axis = to / dist;
        let spread = Angle::from_sin(reach / dist);
        let widest_surface =
            Angle::between(self.normals.axis, axis).plus(self.normals.half.plus(spread));
        let facing = if light.two_sided {
            light.normal.dot(axis).abs()
        } else {
            -light.normal.dot(axis)
        };
        let widest_light = Angle::from_cos(facing).plus(spread);
        // A margin over 0: the cones' own rounding.
        (widest_surface.cos > 1e-4 && widest_light.cos > 1e-4).then(|| FarView {
            near,
            scale: (self.centre.abs() + Vec3::splat(self.radius))
                .max(light.centre.abs() + Vec3::splat(light.radius))
                .max_element(),
        })
    }
}

/// The GGX lobe's bound per unit radiance: `F_max * min(1, D_max * G1 /
/// (4 cos_o) * omega)`, with the fit's margin.
fn ks_bound(g: &PointGroup, ks: f32, axis: Vec3, spread: Angle, omega: f32) -> f32 {
    // Half vectors: wi within `spread` of `axis`, wo within the views' cone;
    // |wi + wo - (axis + view axis)| is at most the sum of the chords.
    let sum = axis + g.views.axis;
    let m = sum.length();
    let e = spread.chord() + g.views.half.chord();
    let (half_axis, half_spread) = if e < m {
        (sum / m, Angle::from_sin(e / m))
    } else {
        (g.normals.axis, Angle::PI)
    };
    let off_peak =
        Angle::between(g.normals.axis, half_axis).minus(half_spread.plus(g.normals.half));
    let d_max = ggx_d_max(off_peak, g.alpha_min, g.alpha_max);
    let c = g.cos_view;
    let a = g.alpha_min;
    let g1_over = 1.0 / (2.0 * (c + (a * a * (1.0 - c * c) + c * c).sqrt()));
    // Fresnel at the smallest wo . h: half the largest angle between wi and wo.
    let wide = Angle::between(axis, g.views.axis).plus(spread.plus(g.views.half));
    let cos_d = (0.5 * (1.0 + wide.cos)).max(0.0).sqrt();
    let f_max = ks + (1.0 - ks) * (1.0 - cos_d).powi(5);
    f_max * (LTC_FIT_MARGIN * d_max * g1_over * omega).min(LTC_FIT_MARGIN)
}

/// The largest GGX `D` at an angle of at least `off` from the normal, over
/// `alpha` in `[lo, hi]`: at a fixed angle `D` peaks at `alpha = tan(off)`.
fn ggx_d_max(off: Angle, lo: f32, hi: f32) -> f32 {
    let tan = if off.cos > 0.0 {
        off.sin / off.cos
    } else {
        f32::INFINITY
    };
    let a = tan.clamp(lo, hi);
    let a2 = a * a;
    let c2 = off.cos.max(0.0) * off.cos.max(0.0);
    let den = c2 * (a2 - 1.0) + 1.0;
    a2 / (std::f32::consts::PI * den * den)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Angle, b: Angle) -> bool {
        (a.cos - b.cos).abs() < 1e-5 && (a.sin - b.sin).abs() < 1e-5
    }

    #[test]
    fn angle_arithmetic_matches_radians_and_clamps() {
        let r = |x: f32| Angle {
            cos: x.cos(),
            sin: x.sin(),
        };
        assert!(close(r(0.3).plus(r(0.5)), r(0.8)));
        assert!(close(r(0.8).minus(r(0.5)), r(0.3)));
        assert_eq!(r(0.3).minus(r(0.5)), Angle::ZERO);
        assert_eq!(r(2.0).plus(r(1.5)), Angle::PI);
        assert!((r(0.6).chord() - 2.0 * 0.3f32.sin()).abs() < 1e-6);
    }

    #[test]
    fn ggx_d_max_is_the_peak_at_the_normal_and_falls_off_it() {
        let alpha = 0.1;
        let peak = ggx_d_max(Angle::ZERO, alpha, alpha);
        assert!((peak - 1.0 / (std::f32::consts::PI * alpha * alpha)).abs() < 1e-3 * peak);
        let off = Angle::from_cos(0.9);
        assert!(ggx_d_max(off, alpha, alpha) < peak);
        // Over a range of roughness the angle's own best alpha wins.
        let best = ggx_d_max(off, 0.01, 1.0);
        for a in [0.01, 0.1, 0.3, 0.48, 0.6, 1.0] {
            assert!(ggx_d_max(off, a, a) <= best * (1.0 + 1e-5));
        }
    }
}

//! The specular lobe as a guide of the spatial filter.
//!
//! What a glossy receiver shows of a shadow is the visibility seen through
//! its BRDF lobe: the narrower the lobe, the faster that visibility changes
//! from pixel to pixel (a near-mirror shows the occluder's silhouette as
//! sharply as a mirror image). Two pixels of such a receiver may average
//! their ratios only when their lobes look at the same directions, so a tap's
//! weight falls with the angle between the two mirror directions measured in
//! lobe widths. Where the diffuse lobe carries most of the light the ratio is
//! as smooth as the diffuse visibility, so the term is scaled by the
//! specular lobe's share and vanishes on a Lambert surface.

use glam::Vec3;

/// One pixel's specular lobe, as the filter compares it with a tap's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Lobe {
    /// Unit mirror direction of the view ray about the shading normal.
    pub dir: Vec3,
    /// specular share / (lobe width)^2, with the width in radians of the
    /// mirror direction: the squared distance between two pixels' `dir`
    /// times this is their separation in lobe widths, squared. 0: no
    /// specular lobe (or none known), no constraint.
    pub sharpness: f32,
    /// The specular lobe's share of the luminance of `U`, in [0, 1]: the
    /// rest (the diffuse part) does not depend on the view, which is what
    /// lets the history tell a camera move from a light change.
    pub share: f32,
}

impl Lobe {
    /// The lobe of a surface point with unit shading normal `n`, unit
    /// direction to the eye `wo`, GGX width `alpha` (of the microfacet
    /// normals) and specular share `share` in [0, 1] of its reflectance.
    #[inline]
    pub fn new(n: Vec3, wo: Vec3, alpha: f32, share: f32) -> Lobe {
        let share = if share.is_finite() {
            share.clamp(0.0, 1.0)
        } else {
            0.0
        };
        // Reflection doubles the angle of the microfacet normal: the mirror
        // directions spread over about twice the width of the normals.
        let width = 2.0 * alpha.max(1e-4);
        let dir = (2.0 * n.dot(wo) * n - wo).normalize_or_zero();
        if share <= 0.0 || dir == Vec3::ZERO {
            return Lobe {
                share,
                ..Lobe::default()
            };
        }
        Lobe {
            dir,
            sharpness: share / (width * width),
            share,
        }
    }

    /// Squared separation of `other`'s mirror direction from this lobe's, in
    /// its widths (scaled by the specular share); 0 where this pixel has no
    /// specular lobe.
    #[inline(always)]
    pub fn separation2(&self, other: &Lobe) -> f32 {
        if self.sharpness > 0.0 {
            (self.dir - other.dir).length_squared() * self.sharpness
        } else {
            0.0
        }
    }
}

//! Per-pixel light estimates: analytic `U` and, per mode, the stochastic
//! `U_N`, `S_N` that the composite turns into the frame.

use super::gbuffer::{GSample, PixelKind};
use super::mode::Mode;
use super::world::World;
use crate::shading::{SurfacePoint, unshadowed};
use glam::Vec3;

pub fn mode_available(mode: Mode) -> bool {
    matches!(mode, Mode::Unshadowed)
}

#[inline]
pub fn surface_point(g: &GSample) -> SurfacePoint {
    SurfacePoint {
        p: g.position,
        n: g.ns,
        wo: g.wo,
        diffuse: g.diffuse,
        specular: g.specular,
        roughness: g.roughness,
    }
}

/// Analytic unshadowed light, all lights summed; zero off surfaces.
#[inline]
pub fn analytic_u(world: &World, g: &GSample) -> Vec3 {
    if g.kind != PixelKind::Surface {
        return Vec3::ZERO;
    }
    let sp = surface_point(g);
    world
        .scene
        .lights
        .iter()
        .map(|light| unshadowed(&sp, light))
        .sum()
}

/// `S_N / U_N` per channel, defined as 1 (fully lit) where `U_N` carries no
/// energy: there the estimate has nothing to say about visibility, and the
/// analytic `U` it multiplies is itself (near) zero.
#[inline]
pub fn ratio(sn: Vec3, un: Vec3) -> Vec3 {
    let r = |s: f32, u: f32| if u > 1e-20 { (s / u).clamp(0.0, 1.0) } else { 1.0 };
    Vec3::new(r(sn.x, un.x), r(sn.y, un.y), r(sn.z, un.z))
}

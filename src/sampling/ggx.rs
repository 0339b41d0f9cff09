//! The GGX pieces the sampler needs, in a local frame where the normal is +z.
//! Exactly the SCENE_FORMAT definitions: Trowbridge–Reitz D with `alpha`, and
//! the Smith Λ whose height-correlated form gives G2.

use glam::Vec3;
use std::f32::consts::PI;

/// Smallest alpha the samplers use: at 1e-4 the peak of D is ~3e7, still far
/// from f32 overflow in D² products; smaller is a mirror in all but name.
pub const MIN_ALPHA: f32 = 1e-4;

/// GGX normal distribution D(h) for a local half vector `h` (unit, z = n·h).
pub fn d(h: Vec3, alpha: f32) -> f32 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    // (x² + y²)/a² + z² form avoids the cancellation of (z²(a²−1)+1) for small alpha.
    let t = (h.x * h.x + h.y * h.y) / a2 + h.z * h.z;
    1.0 / (PI * a2 * t * t)
}

/// Smith Λ(w) for GGX: (−1 + sqrt(1 + α² tan²θ)) / 2.
pub fn lambda(w: Vec3, alpha: f32) -> f32 {
    let z2 = w.z * w.z;
    if z2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan2 = (w.x * w.x + w.y * w.y) / z2;
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// Smith masking G1(w) = 1 / (1 + Λ(w)); 0 at and below the horizon.
pub fn g1(w: Vec3, alpha: f32) -> f32 {
    if w.z <= 0.0 {
        return 0.0;
    }
    1.0 / (1.0 + lambda(w, alpha))
}

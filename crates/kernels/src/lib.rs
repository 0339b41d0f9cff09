//! The numeric kernels of a frame's shading: the BRDF, the analytic
//! unshadowed light `U` on polygonal lights (exact Lambert form factor, LTC
//! for GGX, in lanes across pixels) and the sampling math of the
//! stochastic estimators. Pure functions over plain data: no rays, no
//! threads of their own.

pub mod sampling;
pub mod shading;

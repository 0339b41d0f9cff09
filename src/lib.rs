//! penumbra: a CPU real-time renderer of correct soft shadows from polygonal
//! area lights (Heitz, Hill, McGuire 2018: analytic direct light times a
//! ratio of stochastic estimates).

pub mod embree;
pub mod scene;
pub mod shading;

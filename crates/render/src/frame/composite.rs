//! The colour from the estimates (`U · S_N / U_N`, or the mode's own), and
//! its temporal resolve.

use super::Frame;
use crate::estimate::ratio;
use crate::gbuffer::GSample;
use crate::plan::{Composite, ResolveInput};
use glam::Vec3;
use penumbra_denoise::{CameraMotion, DenoiseSettings, ResolveSettings};
use rayon::prelude::*;

/// A pixel's colour from its estimates.
#[inline]
pub(super) fn shade(composite: Composite, g: &GSample, u: Vec3, un: Vec3, sn: Vec3) -> Vec3 {
    let lit = match composite {
        Composite::Unshadowed => u,
        Composite::Ratio => u * ratio(sn, un),
        Composite::Stochastic => sn,
    };
    finite_or_zero(g.emission + lit)
}

/// The last line of defence of the no-NaN rule: a non-finite value becomes 0.
#[inline]
pub fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() { v } else { Vec3::ZERO }
}

impl Frame {
    /// The temporal resolve (see `denoise::resolve`): averages over the
    /// jittered frames what no earlier stage has averaged. The denoiser's
    /// temporal history already averages `U_N` and `S_N` over the same
    /// jittered frames, so a denoised colour `U · dn(S_N) / dn(U_N)` is
    /// resolved as `resolve(U) · dn(S_N) / dn(U_N)`, and denoised
    /// `stochastic` as `resolve(emission) + dn(S_N)`: averaging the denoised
    /// colour again would weight the early frames' samples up to 20x more
    /// than the late ones' (a running mean of running means). Where the
    /// jitter (or the motion) crossed a geometric edge, the resolved `U`
    /// mixes surfaces that this frame's ratio does not describe, and the
    /// resolved colour is taken instead; an undenoised frame is resolved
    /// whole. The frame's composite is computed as before: this stage only
    /// averages it, or its per-frame noise-free factor, over frames.
    // Out of line: a stage of `make profile` (scripts/profile.py).
    #[inline(never)]
    pub(super) fn resolve_colour(&mut self, input: ResolveInput, motion: CameraMotion) {
        let guide = self.guide.buffers(&self.u);
        self.resolve.resolve(
            &guide,
            (&mut self.resolve_in, &mut self.color),
            motion,
            &ResolveSettings::default(),
            &DenoiseSettings::default(),
        );
        if input == ResolveInput::Whole {
            return;
        }
        self.color
            .par_iter_mut()
            .zip(&self.guide.depth)
            .zip(&self.resolve_in)
            .zip(self.resolve.mixed())
            .zip(self.un.par_iter().zip(&self.sn))
            .for_each(|((((c, &depth), b), &mixed), (un, sn))| {
                if mixed {
                    return;
                }
                // Surfaces (depth > 0 in the guides) carry a ratio; lights
                // and misses are their emission alone.
                *c = match input {
                    ResolveInput::Modulated if depth > 0.0 => finite_or_zero(*b * ratio(*sn, *un)),
                    ResolveInput::Additive => finite_or_zero(*b + *sn),
                    _ => *b,
                }
            });
    }

    // Out of line: a stage of `make profile` (scripts/profile.py).

    #[inline(never)]
    pub(super) fn composite(&mut self, composite: Composite) {
        self.color
            .par_iter_mut()
            .zip(&self.gbuf)
            .zip(&self.u)
            .zip(&self.un)
            .zip(&self.sn)
            .for_each(|((((c, g), u), un), sn)| *c = shade(composite, g, *u, *un, *sn));
    }
}

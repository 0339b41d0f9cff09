//! What a frame runs, decided once from the settings: which samples are
//! drawn and at what rate, whether they are denoised, how the colour is
//! composed and what the temporal resolve averages. The stages read the
//! plan's fields; none of them looks at the mode again.

use super::estimate::Estimator;
use super::mode::Mode;
use super::settings::{RenderSettings, VisibilityRate};

/// How a pixel's colour is formed from the frame's signals.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Composite {
    /// `emission + U`.
    Unshadowed,
    /// `emission + U · S_N / U_N` (ratio and soft-shadow).
    Ratio,
    /// `emission + S_N` (full Monte Carlo).
    Stochastic,
}

/// What the temporal resolve averages over jittered frames, so that nothing
/// is averaged twice (see `Frame::resolve_colour`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ResolveInput {
    /// Denoised ratio: the resolve averages `emission + U`, the frame's
    /// ratio multiplies the result.
    Modulated,
    /// Denoised stochastic: the resolve averages the emission, the
    /// denoised `S_N` is added.
    Additive,
    /// Undenoised or unshadowed: the resolve averages the colour.
    Whole,
}

/// The stages of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FramePlan {
    /// Progressive accumulation of jittered samples: the reference path.
    pub reference: bool,
    /// What the visibility samples estimate; `None`: no samples.
    pub estimator: Option<Estimator>,
    /// Where samples are drawn (`Quarter` only where they are denoised
    /// into a ratio).
    pub rate: VisibilityRate,
    pub denoise: bool,
    /// Denoised stochastic filters `S_N` against the noise-free `U` (its
    /// whole noise, not only visibility's, then drives the filter).
    pub filter_against_u: bool,
    pub composite: Composite,
    /// Settled tiles draw no samples under a still camera (full rate,
    /// denoised).
    pub settle: bool,
    /// Per-frame sub-pixel jitter of the camera rays.
    pub jitter: bool,
    /// The frame's own temporal resolve; `None`: none (no jitter, or the
    /// frame is resolved at a larger output size after it, see
    /// `render::upscaled`).
    pub resolve: Option<ResolveInput>,
}

impl FramePlan {
    pub fn of(s: &RenderSettings) -> FramePlan {
        let reference = s.mode == Mode::Reference;
        let estimator = match s.mode {
            Mode::Ratio | Mode::Stochastic | Mode::Reference => Some(Estimator::Mis),
            Mode::SoftShadow => Some(Estimator::AreaVisibility),
            Mode::Unshadowed => None,
        };
        let composite = match s.mode {
            Mode::Ratio | Mode::SoftShadow => Composite::Ratio,
            Mode::Stochastic => Composite::Stochastic,
            Mode::Unshadowed | Mode::Reference => Composite::Unshadowed,
        };
        let denoise = s.denoise && estimator.is_some() && !reference;
        let rate = if denoise && composite == Composite::Ratio {
            s.visibility
        } else {
            VisibilityRate::Full
        };
        let jitter = s.taa && !reference;
        let resolve = (jitter && !s.upscaled).then_some(match (composite, denoise) {
            (Composite::Ratio, true) => ResolveInput::Modulated,
            (Composite::Stochastic, true) => ResolveInput::Additive,
            _ => ResolveInput::Whole,
        });
        FramePlan {
            reference,
            estimator,
            rate,
            denoise,
            filter_against_u: denoise && composite == Composite::Stochastic,
            composite,
            settle: s.settle && denoise && rate == VisibilityRate::Full,
            jitter,
            resolve,
        }
    }

    /// Whether the band pass fills the guides (the denoiser and the
    /// resolves, the frame's own or the upscale's, read them).
    pub fn needs_guides(&self) -> bool {
        self.denoise || self.jitter
    }
}

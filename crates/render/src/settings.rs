//! What a frame is asked for: the mode, samples, seed, denoising, jitter,
//! visibility rate and light culling.

use crate::shadow::PacketWidth;
use std::fmt;
use std::str::FromStr;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderSettings {
    pub mode: crate::mode::Mode,
    /// Light samples per sampled pixel per frame (`reference`: per call).
    pub spp: u32,
    pub seed: u32,
    /// How shadow rays are handed to Embree.
    pub packet: PacketWidth,
    /// Temporal + spatial denoising of `U_N`, `S_N` (ratio, stochastic, soft-shadow).
    pub denoise: bool,
    /// Per-frame sub-pixel jitter of the camera rays plus a temporal resolve
    /// of the colour (every mode but `reference`, which jitters per sample).
    /// Frame 0 is unjittered, so a one-frame render is the same either way.
    pub taa: bool,
    /// Which pixels draw visibility samples each frame (denoised ratio and
    /// soft-shadow; every other plan samples every pixel).
    pub visibility: VisibilityRate,
    /// Under a still camera, tiles whose visibility has settled (exactly
    /// lit or in umbra, with a long history) draw no samples, but for a
    /// periodic refresh (denoised, full rate).
    pub settle: bool,
    /// The `U` stage's light culling: every surface pixel's `U` is at
    /// least `1 - light_tolerance` of the sum over every light
    /// (`analytic_u_band`); 0 evaluates every light at every pixel.
    pub light_tolerance: f32,
    /// The frame is rendered below its output's size and resolved there
    /// (`render::upscaled`): its camera rays are jittered as under `taa`,
    /// but its own temporal resolve is left out.
    pub upscaled: bool,
}

/// The shipped light culling tolerance: a fiftieth of `U`, well inside
/// the LTC fit's own error (docs/accuracy.md).
pub const LIGHT_TOLERANCE: f32 = 0.02;

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            mode: crate::mode::Mode::Ratio,
            spp: 1,
            seed: 0,
            packet: PacketWidth::Sixteen,
            denoise: true,
            taa: true,
            visibility: VisibilityRate::default(),
            settle: true,
            light_tolerance: LIGHT_TOLERANCE,
            upscaled: false,
        }
    }
}

/// How many pixels draw visibility samples (`U_N`, `S_N`) per frame. `U` is
/// evaluated at every pixel every frame whatever the rate: the shading
/// detail lives there.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum VisibilityRate {
    /// Every pixel, every frame.
    #[default]
    Full,
    /// One pixel of each 2x2 quad per frame, rotating so every pixel is
    /// sampled once in 4 frames; the samples are denoised at quad
    /// resolution and the ratio is brought back to every pixel with the
    /// G-buffer as guide.
    Quarter,
}

impl VisibilityRate {
    pub const ALL: [VisibilityRate; 2] = [VisibilityRate::Full, VisibilityRate::Quarter];

    pub fn name(self) -> &'static str {
        match self {
            VisibilityRate::Full => "full",
            VisibilityRate::Quarter => "quarter",
        }
    }

    /// The next rate in `ALL` (the viewer's key cycles through them).
    pub fn next(self) -> VisibilityRate {
        let i = Self::ALL.iter().position(|r| *r == self).unwrap_or(0);
        Self::ALL[(i + 1) % Self::ALL.len()]
    }
}

impl fmt::Display for VisibilityRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for VisibilityRate {
    type Err = String;
    fn from_str(s: &str) -> Result<VisibilityRate, String> {
        Self::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| format!("unknown visibility rate \"{s}\" (expected full or quarter)"))
    }
}

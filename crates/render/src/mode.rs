//! What a frame computes: the method and the answers it is compared with.

use std::fmt;
use std::str::FromStr;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// `U · S_N / U_N`: analytic light times the ratio of stochastic estimates.
    Ratio,
    /// Full Monte Carlo (light + BRDF sampling, MIS).
    Stochastic,
    /// `U` times the plain average of visibility over the light's area.
    SoftShadow,
    /// `U` only: analytic, no visibility.
    Unshadowed,
    /// Progressive accumulation of the full estimator with pixel jitter.
    Reference,
}

impl Mode {
    pub const ALL: [Mode; 5] = [
        Mode::Ratio,
        Mode::Stochastic,
        Mode::SoftShadow,
        Mode::Unshadowed,
        Mode::Reference,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Mode::Ratio => "ratio",
            Mode::Stochastic => "stochastic",
            Mode::SoftShadow => "soft-shadow",
            Mode::Unshadowed => "unshadowed",
            Mode::Reference => "reference",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Mode {
    type Err = String;
    fn from_str(s: &str) -> Result<Mode, String> {
        Mode::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = Mode::ALL.iter().map(|m| m.name()).collect();
                format!(
                    "unknown mode \"{s}\" (expected one of: {})",
                    names.join(", ")
                )
            })
    }
}

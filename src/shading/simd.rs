//! Which vector instructions the batched `U` runs with, chosen at run time,
//! so one build runs on any x86-64 and uses AVX-512 where the CPU has it.
//!
//! The kernels (`PixelBatch::new`, `lobes_batch`) are compiled once per
//! level: `Avx512` (x86-64-v4 and the AVX-512 extensions of Ice Lake and
//! Zen 4, which `multiversion` requires so that CPUs with AVX-512's
//! frequency penalty take AVX2), `Avx2` (x86-64-v3: AVX2, FMA) and
//! `Baseline` (SSE2). Each level's copy is an `#[inherit_target]` function
//! of a `#[multiversion]` selector, which hands it out as a plain `fn` only
//! when the CPU runs it: the target-feature `unsafe` stays inside
//! `multiversion`. What a kernel inlines (`#[inline(always)]` through
//! `u_batch`, `lanes`, `ltc_correction`, `ltc`) is compiled with its
//! level's instructions; what it calls out of line is baseline code.
//!
//! `PENUMBRA_SIMD=baseline|avx2|avx512` forces a level (valgrind cannot run
//! AVX-512; tests compare the levels); a level the CPU lacks, or an unknown
//! value, falls back to the best the CPU has, with one warning on stderr.
//! The three levels give the same bits: `Lanes::mul_add` is always fused
//! (a `fma` library call per lane on the baseline level), and nothing else
//! the kernels compute depends on the instructions.

use super::u_batch::{BatchLight, LaneCounts, LaneLobes, PixelBatch};
use super::unshadowed::SurfacePoint;
use multiversion::target::match_target;
use multiversion::{inherit_target, multiversion};
use std::sync::OnceLock;

/// The environment variable that forces a level.
pub const ENV_VAR: &str = "PENUMBRA_SIMD";

/// An instruction-set level of the kernels, lowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    Baseline,
    Avx2,
    Avx512,
}

impl Level {
    pub const ALL: [Level; 3] = [Level::Baseline, Level::Avx2, Level::Avx512];

    pub fn name(self) -> &'static str {
        match self {
            Level::Baseline => "baseline",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    pub fn parse(s: &str) -> Option<Level> {
        Level::ALL.into_iter().find(|l| l.name() == s.trim())
    }
}

impl std::fmt::Display for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The per-pixel setup of a batch (`PixelBatch::new`).
pub type SetupFn = fn(&[Option<SurfacePoint>]) -> PixelBatch;
/// One light over a batch (`lobes_batch`).
pub type LobesFn = fn(&PixelBatch, &BatchLight, &mut LaneLobes) -> LaneCounts;

/// The kernels of one level.
#[derive(Clone, Copy)]
pub struct Kernels {
    pub level: Level,
    pub setup: SetupFn,
    pub lobes: LobesFn,
}

#[multiversion(targets(
    "x86_64+avx+avx2+avx512bw+avx512cd+avx512dq+avx512f+avx512vl+bmi1+bmi2+f16c+fma+lzcnt+movbe+popcnt+sse3+sse4.1+sse4.2+ssse3"
))]
fn avx512_kernels() -> Option<Kernels> {
    match_target! {
        "x86_64+avx512f" => {
            #[inherit_target]
            fn setup(points: &[Option<SurfacePoint>]) -> PixelBatch {
                PixelBatch::build(points)
            }
            #[inherit_target]
            fn lobes(b: &PixelBatch, l: &BatchLight, out: &mut LaneLobes) -> LaneCounts {
                super::u_batch::lobes_batch_inline(b, l, out)
            }
            Some(Kernels { level: Level::Avx512, setup, lobes })
        }
        _ => None,
    }
}

#[multiversion(targets(
    "x86_64+avx+avx2+bmi1+bmi2+f16c+fma+lzcnt+movbe+popcnt+sse3+sse4.1+sse4.2+ssse3"
))]
fn avx2_kernels() -> Option<Kernels> {
    match_target! {
        "x86_64+avx2+fma" => {
            #[inherit_target]
            fn setup(points: &[Option<SurfacePoint>]) -> PixelBatch {
                PixelBatch::build(points)
            }
            #[inherit_target]
            fn lobes(b: &PixelBatch, l: &BatchLight, out: &mut LaneLobes) -> LaneCounts {
                super::u_batch::lobes_batch_inline(b, l, out)
            }
            Some(Kernels { level: Level::Avx2, setup, lobes })
        }
        _ => None,
    }
}

fn baseline_kernels() -> Kernels {
    fn setup(points: &[Option<SurfacePoint>]) -> PixelBatch {
        PixelBatch::build(points)
    }
    fn lobes(b: &PixelBatch, l: &BatchLight, out: &mut LaneLobes) -> LaneCounts {
        super::u_batch::lobes_batch_inline(b, l, out)
    }
    Kernels {
        level: Level::Baseline,
        setup,
        lobes,
    }
}

/// The kernels of `level`; `None` when this CPU cannot run them.
pub fn kernels_at(level: Level) -> Option<Kernels> {
    match level {
        Level::Avx512 => avx512_kernels(),
        Level::Avx2 => avx2_kernels(),
        Level::Baseline => Some(baseline_kernels()),
    }
}

/// The best level this CPU runs.
pub fn detected() -> Level {
    Level::ALL
        .into_iter()
        .rev()
        .find(|&l| kernels_at(l).is_some())
        .unwrap_or(Level::Baseline)
}

/// The level for a `PENUMBRA_SIMD` value (`None`: unset) on a CPU whose
/// best is `best`, and the warning to print when the value cannot be
/// followed.
pub fn choose(value: Option<&str>, best: Level) -> (Level, Option<String>) {
    let Some(value) = value.filter(|v| !v.trim().is_empty()) else {
        return (best, None);
    };
    match Level::parse(value) {
        Some(l) if l <= best => (l, None),
        Some(l) => (
            best,
            Some(format!(
                "{ENV_VAR}={l}: this CPU lacks {l}'s instructions; using {best}"
            )),
        ),
        None => (
            best,
            Some(format!(
                "{ENV_VAR}={value:?} is not one of baseline, avx2, avx512; using {best}"
            )),
        ),
    }
}

/// The kernels every batch runs with: the best level, or the one
/// `PENUMBRA_SIMD` asks for (read once per process).
pub fn kernels() -> &'static Kernels {
    static SELECTED: OnceLock<Kernels> = OnceLock::new();
    SELECTED.get_or_init(|| {
        let value = std::env::var(ENV_VAR).ok();
        let (level, warning) = choose(value.as_deref(), detected());
        if let Some(w) = warning {
            eprintln!("penumbra: {w}");
        }
        kernels_at(level).unwrap_or_else(baseline_kernels)
    })
}

/// The level every batch runs with.
pub fn selected() -> Level {
    kernels().level
}

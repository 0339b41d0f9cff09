//! The instruction set the hot loops run, chosen once at run time: AVX-512
//! (with the Ice Lake extensions), else AVX2 with FMA, else baseline x86-64.
//! One build runs on any x86-64 CPU and takes the widest level it has.
//!
//! A hot loop is written once, as a `Kernel` (a struct of its arguments),
//! and run through `run`, which has it compiled once per level: its body is
//! inlined into a clone that `multiversion` compiles with that level's
//! target features, so everything it inlines runs that level's
//! instructions. What such a loop calls out of line runs at baseline unless
//! it too is a `Kernel`. A kernel that runs slower at AVX-512 than at AVX2
//! (the `U` stage's) goes through `run_at_most_avx2` instead, and is
//! compiled twice.
//!
//! Every level computes the same values: nothing here selects an algorithm
//! by level, Rust does not contract a multiply and an add into one, and
//! `mul_add` is fused on every level (a library call at baseline), so
//! `PENUMBRA_ISA` changes the speed of a frame and not its bytes
//! (`tests/integration/cli/isa.rs`).

use multiversion::multiversion;
use multiversion::target::match_target;
use std::sync::OnceLock;

/// The environment variable that caps the level (`baseline`, `avx2`,
/// `avx512`): for tests, valgrind (which runs no AVX-512) and comparisons.
pub const ENV: &str = "PENUMBRA_ISA";

/// An instruction-set level, lowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    /// x86-64 (SSE2), or any other architecture.
    Baseline,
    /// x86-64-v3: AVX2, FMA, BMI1/2.
    Avx2,
    /// x86-64-v4 and the Ice Lake AVX-512 extensions.
    Avx512,
}

impl Isa {
    /// Every level, lowest first.
    pub const ALL: [Isa; 3] = [Isa::Baseline, Isa::Avx2, Isa::Avx512];

    /// The name `PENUMBRA_ISA` takes.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }

    /// The level named `name`.
    pub fn parse(name: &str) -> Option<Isa> {
        Isa::ALL.into_iter().find(|isa| isa.name() == name)
    }

    /// The widest level this CPU runs (the features `run`'s clones need).
    pub fn detected() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let v3 = has!("avx")
                && has!("avx2")
                && has!("fma")
                && has!("bmi1")
                && has!("bmi2")
                && has!("lzcnt")
                && has!("popcnt")
                && has!("f16c");
            // `multiversion` asks for Ice Lake's extensions with AVX-512
            // (older AVX-512 CPUs lower their clock for it).
            let v4 = v3
                && has!("avx512f")
                && has!("avx512bw")
                && has!("avx512cd")
                && has!("avx512dq")
                && has!("avx512vl")
                && has!("avx512bitalg")
                && has!("avx512ifma")
                && has!("avx512vbmi")
                && has!("avx512vbmi2")
                && has!("avx512vnni")
                && has!("avx512vpopcntdq")
                && has!("gfni")
                && has!("vaes")
                && has!("vpclmulqdq");
            if v4 {
                Isa::Avx512
            } else if v3 {
                Isa::Avx2
            } else {
                Isa::Baseline
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Isa::Baseline
        }
    }

    /// The level `PENUMBRA_ISA` asks for, if set: an error names a value
    /// that is not a level, or one above what this CPU runs.
    pub fn requested() -> Result<Option<Isa>, String> {
        let Some(value) = std::env::var_os(ENV) else {
            return Ok(None);
        };
        let value = value.to_string_lossy();
        let names = Isa::ALL.map(Isa::name).join(", ");
        let isa = Isa::parse(value.trim())
            .ok_or_else(|| format!("{ENV}={value}: not a level (one of {names})"))?;
        let detected = Isa::detected();
        if isa > detected {
            return Err(format!(
                "{ENV}={value}: this CPU runs at most {}",
                detected.name()
            ));
        }
        Ok(Some(isa))
    }

    /// The level the hot loops run: `PENUMBRA_ISA` where it is valid, else
    /// the detected one. Read once.
    pub fn active() -> Isa {
        static ACTIVE: OnceLock<Isa> = OnceLock::new();
        *ACTIVE.get_or_init(|| {
            Isa::requested()
                .ok()
                .flatten()
                .unwrap_or_else(Isa::detected)
        })
    }
}

/// A hot loop that `run` compiles once per level: a struct of its
/// arguments, whose `run` is `#[inline(always)]` so that each level's clone
/// holds its body (a function called through `Fn` was not inlined there,
/// and ran at baseline).
pub trait Kernel {
    type Out;
    fn run(self) -> Self::Out;
}

/// `kernel.run()`, compiled for and run at `Isa::active()`.
#[inline(always)]
pub fn run<K: Kernel>(kernel: K) -> K::Out {
    match Isa::active() {
        Isa::Avx512 => on_avx512(kernel),
        Isa::Avx2 => on_avx2(kernel),
        Isa::Baseline => on_baseline(kernel),
    }
}

/// `kernel.run()` at `Isa::active()`, but never above AVX2: for kernels
/// whose AVX-512 clone runs slower than their AVX2 one. The `U` stage's
/// kernels are eight-lane `f32` code (one 256-bit vector per operation);
/// allowed 512-bit registers, LLVM's vectorizer joins pairs of independent
/// eight-lane operations into one and splits the result again, and the
/// stage took 1.2x its AVX2 time (docs/performance.md, "The `U` stage at
/// most at AVX2"). Such a kernel also has no AVX-512 clone to compile.
#[inline(always)]
pub fn run_at_most_avx2<K: Kernel>(kernel: K) -> K::Out {
    match Isa::active() {
        Isa::Avx512 | Isa::Avx2 => on_avx2(kernel),
        Isa::Baseline => on_baseline(kernel),
    }
}

// Each level's function has one clone with that level's features; its
// fallback (the clone for a CPU without them, which `run` never reaches
// there) hands down to the next level instead of holding a copy of the
// kernel.

#[multiversion(targets(
    "x86_64+avx512f+avx512bw+avx512cd+avx512dq+avx512vl+avx+avx2+fma+bmi1+bmi2+lzcnt+popcnt+f16c"
))]
fn on_avx512<K: Kernel>(kernel: K) -> K::Out {
    match_target! {
        "x86_64+avx512f" => kernel.run(),
        _ => on_avx2(kernel),
    }
}

#[multiversion(targets("x86_64+avx+avx2+fma+bmi1+bmi2+lzcnt+popcnt+f16c"))]
fn on_avx2<K: Kernel>(kernel: K) -> K::Out {
    match_target! {
        "x86_64+avx2" => kernel.run(),
        _ => on_baseline(kernel),
    }
}

#[inline(never)]
fn on_baseline<K: Kernel>(kernel: K) -> K::Out {
    kernel.run()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_level_has_a_name_that_parses_back() {
        for isa in Isa::ALL {
            assert_eq!(Isa::parse(isa.name()), Some(isa));
        }
        assert_eq!(Isa::parse("sse9"), None);
    }

    struct Fused(f64, f64, f64);

    impl Kernel for Fused {
        type Out = f64;
        #[inline(always)]
        fn run(self) -> f64 {
            self.0.mul_add(self.1, self.2)
        }
    }

    #[test]
    fn a_kernel_keeps_its_fused_multiply_add_at_the_active_level() {
        // 1 + 2^-30 squared, less its rounded square: only a fused
        // multiply-add keeps the 2^-60.
        let x = 1.0 + 2f64.powi(-30);
        assert_eq!(run(Fused(x, x, -(x * x))), 2f64.powi(-60));
    }

    #[test]
    fn a_kernel_held_at_most_at_avx2_computes_what_every_level_computes() {
        let x = 1.0 + 2f64.powi(-30);
        assert_eq!(run_at_most_avx2(Fused(x, x, -(x * x))), 2f64.powi(-60));
    }
}

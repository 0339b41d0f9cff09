//! Per-thread floating-point setup for rendering threads.

/// MXCSR bit 15: flush-to-zero (denormal results become 0).
#[cfg(target_arch = "x86_64")]
const MXCSR_FTZ: u32 = 1 << 15;
/// MXCSR bit 6: denormals-are-zero (denormal inputs read as 0).
#[cfg(target_arch = "x86_64")]
const MXCSR_DAZ: u32 = 1 << 6;

/// Sets flush-to-zero and denormals-are-zero in MXCSR for the calling thread.
///
/// Embree recommends this on every thread that traces rays: denormals take a
/// microcode slow path that can cost ~100 cycles per operation. No-op on
/// targets other than x86_64.
pub fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    {
        let csr = read_mxcsr() | MXCSR_FTZ | MXCSR_DAZ;
        // SAFETY: `ldmxcsr` reads 4 bytes from `csr`, a live local. It only sets
        // the FTZ/DAZ bits of this thread's MXCSR (rounding mode and exception
        // masks are kept), so the only observable effect is that subnormal
        // values read and compute as zero. That is the documented intent, the
        // same state every C/C++ Embree renderer runs in; no Rust invariant
        // depends on subnormal arithmetic.
        unsafe {
            core::arch::asm!(
                "ldmxcsr [{p}]",
                p = in(reg) &csr as *const u32,
                options(nostack, preserves_flags, readonly)
            );
        }
    }
}

/// This thread's MXCSR register.
#[cfg(target_arch = "x86_64")]
fn read_mxcsr() -> u32 {
    let mut csr: u32 = 0;
    // SAFETY: `stmxcsr` stores the 4-byte MXCSR into `csr`, a live, aligned
    // local we hold a unique borrow of; it touches no other memory or flags.
    unsafe {
        core::arch::asm!(
            "stmxcsr [{p}]",
            p = in(reg) &mut csr as *mut u32,
            options(nostack, preserves_flags)
        );
    }
    csr
}

/// Reads this thread's MXCSR (tests check that FTZ/DAZ are really set).
#[cfg(target_arch = "x86_64")]
pub fn flush_denormals_enabled() -> bool {
    read_mxcsr() & (MXCSR_FTZ | MXCSR_DAZ) == MXCSR_FTZ | MXCSR_DAZ
}

/// On targets without MXCSR there is nothing to enable.
#[cfg(not(target_arch = "x86_64"))]
pub fn flush_denormals_enabled() -> bool {
    false
}

/// A rayon pool with `threads` threads (0 = one per core) whose threads all
/// call [`set_flush_denormals`] before running any work.
pub fn thread_pool(threads: usize) -> Result<rayon::ThreadPool, rayon::ThreadPoolBuildError> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("penumbra-render-{i}"))
        .start_handler(|_| set_flush_denormals())
        .build()
}

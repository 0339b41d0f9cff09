//! Finds Debian's Embree (3 or 4) and generates its bindings with bindgen.
//!
//! Search order: `EMBREE_DIR` (a prefix holding `include/embree{4,3}` and
//! `lib`), then `/usr/include/embree4`, then `/usr/include/embree3`. Emits
//! `cfg(embree4)` or `cfg(embree3)` so the safe wrapper compiles against either.
//! A library found under `EMBREE_DIR` is linked with an rpath to its folder,
//! so the binaries run without `LD_LIBRARY_PATH`; an `EMBREE_DIR` without
//! headers is an error, not a silent fall-back to the system's Embree.

use std::env;
use std::path::{Path, PathBuf};

struct Found {
    include_dir: PathBuf,
    header: PathBuf,
    lib_dir: Option<PathBuf>,
    major: u32,
}

fn find_in(prefix: &Path, lib_dir: Option<PathBuf>) -> Option<Found> {
    for major in [4u32, 3] {
        let inc = prefix.join(format!("embree{major}"));
        let header = inc.join("rtcore.h");
        if header.is_file() {
            return Some(Found {
                include_dir: prefix.to_path_buf(),
                header,
                lib_dir,
                major,
            });
        }
    }
    None
}

fn find() -> Result<Found, String> {
    if let Some(dir) = env::var_os("EMBREE_DIR").filter(|d| !d.is_empty()) {
        // Absolute, so the rpath holds wherever the binary is run from.
        let dir = std::fs::canonicalize(&dir).map_err(|e| {
            format!(
                "EMBREE_DIR={} cannot be opened: {e}",
                Path::new(&dir).display()
            )
        })?;
        for lib in ["lib", "lib64"] {
            let lib_dir = dir.join(lib);
            if lib_dir.is_dir()
                && let Some(f) = find_in(&dir.join("include"), Some(lib_dir))
            {
                return Ok(f);
            }
        }
        return find_in(&dir.join("include"), None).ok_or_else(|| {
            format!(
                "EMBREE_DIR={} has no include/embree4/rtcore.h or include/embree3/rtcore.h",
                dir.display()
            )
        });
    }
    find_in(Path::new("/usr/include"), None).ok_or_else(|| {
        // One clear line: the fix is a package install.
        "Embree not found (looked in $EMBREE_DIR, /usr/include/embree4, /usr/include/embree3): install it with `sudo apt-get install libembree-dev` (and `libclang-dev` for bindgen), or set EMBREE_DIR".to_string()
    })
}

/// The AVX-512 features the build targets that the machine building it
/// (and, natively, running it) lacks: such a binary would stop at its first
/// AVX-512 instruction. `None` when cross-compiling or when all are there.
fn missing_cpu_features() -> Option<String> {
    let target = std::env::var("CARGO_CFG_TARGET_FEATURE").unwrap_or_default();
    if std::env::var("HOST").ok() != std::env::var("TARGET").ok() {
        return None;
    }
    #[cfg(target_arch = "x86_64")]
    {
        let have = |f: &str| match f {
            "avx512f" => std::arch::is_x86_feature_detected!("avx512f"),
            "avx512bw" => std::arch::is_x86_feature_detected!("avx512bw"),
            "avx512cd" => std::arch::is_x86_feature_detected!("avx512cd"),
            "avx512dq" => std::arch::is_x86_feature_detected!("avx512dq"),
            "avx512vl" => std::arch::is_x86_feature_detected!("avx512vl"),
            _ => true,
        };
        let missing: Vec<&str> = target.split(',').filter(|f| !have(f)).collect();
        if !missing.is_empty() {
            return Some(missing.join(", "));
        }
    }
    let _ = target;
    None
}

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    if let Some(missing) = missing_cpu_features() {
        println!(
            "cargo::error=this build targets AVX-512 (RUSTFLAGS) but this CPU lacks {missing}: build without a target CPU (`make`, or `cargo build --release` with RUSTFLAGS unset); the hot loops pick the best level this CPU runs at run time"
        );
        return;
    }

    let found = match find() {
        Ok(found) => found,
        Err(message) => {
            println!("cargo::error={message}");
            return;
        }
    };

    println!("cargo:rustc-cfg=embree{}", found.major);
    if let Some(lib_dir) = &found.lib_dir {
        println!("cargo:rustc-link-search=native={}", lib_dir.display());
        // A private prefix is not on the loader's path: this crate's own
        // tests get an rpath here, and the binaries of crates that depend
        // on it read the folder from `DEP_EMBREE_RPATH` (`links`).
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib_dir.display());
        println!("cargo:rpath={}", lib_dir.display());
    }
    println!("cargo:rustc-link-lib=embree{}", found.major);
    println!("cargo:rerun-if-changed={}", found.header.display());

    let bindings = bindgen::Builder::default()
        .header(found.header.to_string_lossy())
        .clang_arg(format!("-I{}", found.include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .layout_tests(false)
        .derive_default(true)
        .generate();
    let bindings = match bindings {
        Ok(b) => b,
        Err(e) => {
            println!(
                "cargo::error=bindgen failed on {}: {e} (is libclang-dev installed?)",
                found.header.display()
            );
            return;
        }
    };
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings
        .write_to_file(out.join("embree_bindings.rs"))
        .expect("OUT_DIR is writable");
}

//! Links the application's binaries (and its tests and examples) with an
//! rpath to a private Embree when the binding found one under `EMBREE_DIR`,
//! so they run without `LD_LIBRARY_PATH`. Link arguments do not pass from a
//! dependency to its dependents: the binding hands the folder over as
//! `DEP_EMBREE_RPATH`.

fn main() {
    println!("cargo:rerun-if-env-changed=DEP_EMBREE_RPATH");
    if let Ok(dir) = std::env::var("DEP_EMBREE_RPATH") {
        println!("cargo:rustc-link-arg=-Wl,-rpath,{dir}");
    }
}

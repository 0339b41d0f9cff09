//! `PENUMBRA_ISA`: every instruction-set level the CPU runs gives the same
//! frame, byte for byte, and a level that is not one, or that the CPU
//! lacks, is an error.

use crate::support::{penumbra, scene_path, temp};
use penumbra::isa::{ENV, Isa};

/// Small frames: the baseline level runs the batched `U` several times
/// slower (a library call per fused multiply-add).
const SIZE: [&str; 4] = ["--width", "96", "--height", "54"];

/// The frame `render` writes for `args` with `PENUMBRA_ISA=isa`.
fn frame_at(isa: Isa, name: &str, args: &[&str]) -> Vec<u8> {
    let out = temp("isa", &format!("{name}-{}.exr", isa.name()));
    let run = penumbra()
        .env(ENV, isa.name())
        .arg("render")
        .args(args)
        .args(SIZE)
        .args(["--frames", "3", "--threads", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{ENV}={}: {}",
        isa.name(),
        String::from_utf8_lossy(&run.stderr)
    );
    std::fs::read(&out).unwrap()
}

fn same_bytes_at_every_level(name: &str, args: &[&str]) {
    let levels: Vec<Isa> = Isa::ALL
        .into_iter()
        .filter(|&isa| isa <= Isa::detected())
        .collect();
    let first = frame_at(levels[0], name, args);
    for &isa in &levels[1..] {
        assert!(
            frame_at(isa, name, args) == first,
            "{name}: {} differs from {}",
            isa.name(),
            levels[0].name()
        );
    }
}

#[test]
fn the_builtin_scene_has_the_same_bytes_at_every_level() {
    same_bytes_at_every_level("builtin", &["--mode", "ratio"]);
}

#[test]
fn the_hall_has_the_same_bytes_at_every_level() {
    let hall = scene_path("hall.toml");
    let hall = hall.to_str().unwrap();
    same_bytes_at_every_level("hall", &[hall, "--mode", "ratio"]);
    same_bytes_at_every_level("hall-unshadowed", &[hall, "--mode", "unshadowed"]);
}

/// What `render` says on stderr with `PENUMBRA_ISA=value`, which it must
/// refuse.
fn refusal(value: &str) -> String {
    let run = penumbra()
        .env(ENV, value)
        .args(["render", "--out"])
        .arg(temp("isa", "never.png"))
        .output()
        .unwrap();
    assert!(!run.status.success(), "{ENV}={value} was accepted");
    String::from_utf8_lossy(&run.stderr).into_owned()
}

#[test]
fn a_level_that_is_not_one_is_an_error() {
    let err = refusal("sse9");
    assert!(
        err.contains("PENUMBRA_ISA=sse9") && err.contains("baseline, avx2, avx512"),
        "{err}"
    );
}

#[test]
fn a_level_above_the_cpu_is_an_error() {
    let Some(&above) = Isa::ALL.iter().find(|&&isa| isa > Isa::detected()) else {
        return; // this CPU runs every level
    };
    let err = refusal(above.name());
    assert!(err.contains("this CPU runs at most"), "{err}");
}

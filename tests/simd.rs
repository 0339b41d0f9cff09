//! The batched `U`'s instruction-set levels (`shading::simd`): every level
//! the CPU runs gives the same pixels, `PENUMBRA_SIMD` picks one, and a
//! value it cannot follow is said once and falls back.
use penumbra::compare::{self, Image};
use penumbra::shading::simd::{self, ENV_VAR, Level};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn render(dir: &Path, simd: Option<&str>, name: &str) -> (PathBuf, Output) {
    let out = dir.join(name);
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_penumbra"));
    cmd.current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "render",
            "scenes/room.toml",
            "--width",
            "96",
            "--height",
            "54",
        ])
        .args(["--frames", "2", "--threads", "2", "--out"])
        .arg(&out)
        .env_remove(ENV_VAR);
    if let Some(v) = simd {
        cmd.env(ENV_VAR, v);
    }
    let run = cmd.output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    (out, run)
}

#[test]
fn every_level_this_cpu_runs_renders_the_same_pixels_as_baseline() {
    let dir = tempfile::tempdir().unwrap();
    let (base, _) = render(dir.path(), Some("baseline"), "baseline.exr");
    let base = Image::load(&base).unwrap();
    let best = simd::detected();
    for level in Level::ALL
        .into_iter()
        .filter(|&l| l > Level::Baseline && l <= best)
    {
        let (p, _) = render(dir.path(), Some(level.name()), &format!("{level}.exr"));
        let c = compare::compare(&Image::load(&p).unwrap(), &base).unwrap();
        // The levels run the same operations in the same order, FMA
        // included (`Lanes::mul_add`): not merely close, equal.
        assert_eq!(
            (c.rel_mse, c.max_abs),
            (0.0, 0.0),
            "{level} against baseline: relMSE {:e}, largest difference {} at ({}, {})",
            c.rel_mse,
            c.max_abs,
            c.worst.x,
            c.worst.y
        );
    }
    let (p, _) = render(dir.path(), None, "detected.exr");
    let c = compare::compare(&Image::load(&p).unwrap(), &base).unwrap();
    assert_eq!((c.rel_mse, c.max_abs), (0.0, 0.0), "detected ({best})");
}

#[test]
fn an_unknown_value_is_said_once_and_the_render_goes_on() {
    let dir = tempfile::tempdir().unwrap();
    let (_, run) = render(dir.path(), Some("sse9"), "x.exr");
    let err = String::from_utf8_lossy(&run.stderr);
    let warnings: Vec<_> = err.lines().filter(|l| l.contains(ENV_VAR)).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(warnings[0].contains("\"sse9\""), "{err}");
}

#[test]
fn the_variable_picks_any_level_up_to_the_best() {
    for best in Level::ALL {
        assert_eq!(simd::choose(None, best), (best, None));
        assert_eq!(simd::choose(Some(""), best), (best, None));
        for want in Level::ALL {
            let (got, warning) = simd::choose(Some(want.name()), best);
            if want <= best {
                assert_eq!((got, warning), (want, None));
            } else {
                assert_eq!(got, best);
                assert!(warning.unwrap().contains("lacks"));
            }
        }
        let (got, warning) = simd::choose(Some("AVX9"), best);
        assert_eq!(got, best);
        assert!(warning.unwrap().contains("baseline, avx2, avx512"));
    }
}

#[test]
fn the_levels_below_the_detected_one_are_all_available() {
    let best = simd::detected();
    for l in Level::ALL {
        assert_eq!(simd::kernels_at(l).is_some(), l <= best, "{l}");
        if let Some(k) = simd::kernels_at(l) {
            assert_eq!(k.level, l);
        }
    }
}

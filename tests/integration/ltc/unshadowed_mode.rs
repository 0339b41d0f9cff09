//! `--mode unshadowed` and `--aov u` as a user runs them: U is analytic, so
//! the image is noise-free (the same whatever the seed), finite and >= 0.

use crate::support;
use std::path::PathBuf;
use std::process::Command;

fn temp(name: &str) -> PathBuf {
    support::temp("ltc-mode", name)
}

/// Renders `scenes/shadow-plane.toml` in unshadowed mode with the `u` AOV;
/// returns (frame, u AOV) as linear RGB floats.
fn render_unshadowed(name: &str, seed: &str) -> (Vec<f32>, Vec<f32>) {
    let out = temp(&format!("{name}.exr"));
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/shadow-plane.toml");
    let status = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["render", scene, "--mode", "unshadowed", "--width", "64"])
        .args(["--height", "36", "--seed", seed, "--aov", "u", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let read = |p: PathBuf| {
        let img = image::open(&p).unwrap().to_rgb32f();
        assert_eq!(img.dimensions(), (64, 36), "{}", p.display());
        img.into_raw()
    };
    (
        read(out.clone()),
        read(out.with_file_name(format!("{name}.u.exr"))),
    )
}

#[test]
fn unshadowed_mode_is_noise_free_finite_and_writes_the_u_aov() {
    let (a, ua) = render_unshadowed("seed1", "1");
    let (b, ub) = render_unshadowed("seed2", "2");
    assert_eq!(a, b, "the unshadowed frame depends on the seed");
    assert_eq!(ua, ub, "the u AOV depends on the seed");
    assert!(ua.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(ua.iter().any(|v| *v > 0.0), "the u AOV is black");
    // The frame is U plus emission where the camera sees a light: never less.
    for (f, u) in a.iter().zip(&ua) {
        assert!(
            f.is_finite() && *f >= *u * (1.0 - 1e-6),
            "frame {f} < U {u}"
        );
    }
}

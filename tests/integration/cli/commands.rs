//! The command line as a user meets it.
use crate::support::{self, penumbra};
use std::path::PathBuf;

fn temp(name: &str) -> PathBuf {
    support::temp("cli", name)
}

#[test]
fn render_writes_a_png_of_the_builtin_scene() {
    let out = temp("builtin.png");
    let status = penumbra()
        .args(["render", "--width", "96", "--height", "54", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let img = image::open(&out).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (96, 54));
    assert!(img.pixels().any(|p| p.0 != [0, 0, 0]));
}

#[test]
fn render_writes_exr_and_aovs_beside_it() {
    let out = temp("aov.exr");
    let status = penumbra()
        .args([
            "render",
            "--width",
            "32",
            "--height",
            "18",
            "--aov",
            "albedo,normal,depth",
            "--out",
        ])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    for name in [
        "aov.exr",
        "aov.albedo.exr",
        "aov.normal.exr",
        "aov.depth.exr",
    ] {
        let img = image::open(out.with_file_name(name)).unwrap().to_rgb32f();
        assert_eq!(img.dimensions(), (32, 18), "{name}");
    }
}

#[test]
fn a_bad_scene_is_refused_with_file_and_line() {
    let scene = temp("bad.toml");
    std::fs::write(
        &scene,
        "[camera]\neye = [0.0, 1.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\nfov_y = 200.0\n",
    )
    .unwrap();
    let out = temp("bad.png");
    let run = penumbra()
        .arg("render")
        .arg(&scene)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("bad.toml:4:") && err.contains("fov_y"),
        "stderr: {err}"
    );
    assert!(!err.contains("panicked"), "stderr: {err}");
    assert!(!out.exists());
}

#[test]
fn an_unknown_output_format_is_refused() {
    let run = penumbra()
        .args(["render", "--out", "x.jpg"])
        .output()
        .unwrap();
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains(".png or .exr"));
}

#[test]
fn an_unknown_aov_is_refused() {
    let run = penumbra()
        .args(["render", "--aov", "albedo,bogus", "--out"])
        .arg(temp("a.png"))
        .output()
        .unwrap();
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("bogus"));
}

#[test]
fn view_without_a_display_suggests_render() {
    let run = penumbra()
        .arg("view")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("penumbra render") && !err.contains("panicked"),
        "stderr: {err}"
    );
}

#[test]
fn fit_ltc_writes_a_table_the_renderer_can_load() {
    let table = temp("ltc_4.bin");
    let heatmap = temp("ltc_4.png");
    let run = penumbra()
        .args(["fit-ltc", "--size", "4", "--out"])
        .arg(&table)
        .arg("--heatmap")
        .arg(&heatmap)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let bytes = std::fs::read(&table).unwrap();
    let loaded = penumbra::shading::ltc::LtcTable::from_bytes(&bytes).unwrap();
    assert_eq!(loaded.size, 4);
    assert!(image::open(&heatmap).is_ok());
}

#[test]
fn a_zero_width_is_refused() {
    let run = penumbra()
        .args(["render", "--width", "0", "--out"])
        .arg(temp("z.png"))
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("resolution 0x") && !err.contains("panicked"),
        "stderr: {err}"
    );
}

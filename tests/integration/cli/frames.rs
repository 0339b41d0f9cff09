//! `render --frames N` with `--orbit DEG` and a `{frame}` pattern in `--out`.

use crate::support::{FLOOR, penumbra};
use std::path::{Path, PathBuf};

/// A fresh directory per test, so file listings see only that test's output.
fn temp_dir(test: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("penumbra-cli-frames-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The shared floor, a box on it and a quad light, seen from `eye` towards the origin.
fn scene_text(eye: [f32; 3]) -> String {
    let [x, y, z] = eye;
    format!(
        r#"
[camera]
eye = [{x}, {y}, {z}]
target = [0.0, 0.0, 0.0]
fov_y = 50.0
{FLOOR}
[[object]]
material = "m"
type = "box"
center = [0.8, 0.5, 0.3]
size = [1.0, 1.0, 0.4]

[[light]]
type = "quad"
center = [0.5, 3.0, 0.5]
u = [1.0, 0.0, 0.0]
v = [0.0, 0.0, 0.5]
radiance = [8.0, 8.0, 8.0]
"#
    )
}

fn render(scene: &Path, out: &Path, extra: &[&str]) {
    let run = penumbra()
        .arg("render")
        .arg(scene)
        .args(["--width", "64", "--height", "36", "--out"])
        .arg(out)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "stderr: {}",
        String::from_utf8_lossy(&run.stderr)
    );
}

fn pixels(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().to_rgb8().into_raw()
}

fn mean_abs_diff(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(&x, &y)| (x as f64 - y as f64).abs())
        .sum::<f64>()
        / a.len() as f64
}

#[test]
fn frame_pattern_writes_every_frame_numbered_from_zero_with_four_digits() {
    let dir = temp_dir("pattern");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, scene_text([0.0, 3.0, -6.0])).unwrap();
    render(&scene, &dir.join("f{frame}.png"), &["--frames", "3"]);
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".png"))
        .collect();
    names.sort();
    assert_eq!(names, ["f0000.png", "f0001.png", "f0002.png"]);
}

#[test]
fn without_a_pattern_only_the_last_frame_is_written() {
    let dir = temp_dir("last");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, scene_text([0.0, 3.0, -6.0])).unwrap();
    render(&scene, &dir.join("last.png"), &["--frames", "3"]);
    let files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .filter(|n| n.to_string_lossy().ends_with(".png"))
        .collect();
    assert_eq!(files, ["last.png"]);
}

#[test]
fn orbit_turns_the_eye_about_the_target_by_deg_per_frame() {
    let dir = temp_dir("orbit");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, scene_text([0.0, 3.0, -6.0])).unwrap();
    // Turning +90 degrees about +Y (right-hand rule) maps -Z to -X.
    let turned = dir.join("turned.toml");
    std::fs::write(&turned, scene_text([-6.0, 3.0, 0.0])).unwrap();
    // Without jitter: frame 1 is compared with an unjittered render.
    let args = [
        "--mode",
        "unshadowed",
        "--frames",
        "2",
        "--orbit",
        "90",
        "--taa",
        "off",
    ];
    render(&scene, &dir.join("o{frame}.png"), &args);
    render(&turned, &dir.join("turned.png"), &["--mode", "unshadowed"]);
    render(&scene, &dir.join("still.png"), &["--mode", "unshadowed"]);
    let first = pixels(&dir.join("o0000.png"));
    let second = pixels(&dir.join("o0001.png"));
    // Frame 0 is not turned; frame 1 sees what the turned camera sees (up to
    // float rounding of the rotation), which is a different picture.
    assert_eq!(first, pixels(&dir.join("still.png")));
    let same = mean_abs_diff(&second, &pixels(&dir.join("turned.png")));
    let moved = mean_abs_diff(&second, &first);
    assert!(same < 0.5, "frame 1 vs turned camera: {same}");
    assert!(moved > 10.0 * same.max(0.1), "frame 1 vs frame 0: {moved}");
}

#[test]
fn taa_leaves_the_first_frame_alone_and_averages_jittered_frames_after_it() {
    let dir = temp_dir("taa");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, scene_text([0.0, 3.0, -6.0])).unwrap();
    let shot = |name: &str, frames: &str, taa: &str| {
        let out = dir.join(name);
        let args = ["--mode", "unshadowed", "--frames", frames, "--taa", taa];
        render(&scene, &out, &args);
        pixels(&out)
    };
    // Frame 0 is the pixel centre: one frame is the same bytes either way.
    assert_eq!(shot("on1.png", "1", "on"), shot("off1.png", "1", "off"));
    // A still camera without TAA renders the same frame again; with TAA the
    // jittered frames average, which changes edge pixels.
    let off = shot("off4.png", "4", "off");
    assert_eq!(off, shot("off1b.png", "1", "off"));
    assert_ne!(shot("on4.png", "4", "on"), off);
}

/// Renders a tiny frame with `flag value`; the run must fail with a message
/// naming the flag, and without a panic.
fn assert_refused(dir: &str, flag: &str, value: &str) {
    let dir = temp_dir(dir);
    let run = penumbra()
        .args(["render", "--width", "16", "--height", "9", flag, value])
        .arg("--out")
        .arg(dir.join("x.png"))
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains(flag), "stderr: {err}");
    assert!(!err.contains("panicked"), "stderr: {err}");
}

#[test]
fn an_unknown_taa_value_is_refused() {
    assert_refused("taa-bad", "--taa", "maybe");
}

#[test]
fn a_non_finite_orbit_is_refused() {
    assert_refused("nan", "--orbit", "NaN");
}

#[test]
fn a_missing_output_directory_is_refused_before_rendering() {
    let dir = temp_dir("nodir");
    let out = dir.join("missing").join("f{frame}.png");
    let run = penumbra()
        .args([
            "render", "--width", "16", "--height", "9", "--frames", "2", "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("missing") && err.contains("does not exist"),
        "stderr: {err}"
    );
    assert!(!err.contains("panicked"), "stderr: {err}");
}

#[test]
fn a_light_tolerance_outside_0_to_half_is_refused() {
    assert_refused("tol-big", "--light-tolerance", "0.7");
    assert_refused("tol-neg", "--light-tolerance", "-0.1");
    assert_refused("tol-nan", "--light-tolerance", "NaN");
}

#[test]
fn a_render_scale_outside_0_to_1_is_refused() {
    assert_refused("scale-zero", "--render-scale", "0");
    assert_refused("scale-big", "--render-scale", "1.5");
    assert_refused("scale-neg", "--render-scale", "-0.5");
    assert_refused("scale-nan", "--render-scale", "NaN");
}

#[test]
fn an_upscaled_render_writes_the_output_size_and_names_the_render_size() {
    let dir = temp_dir("upscaled");
    let out = dir.join("u.png");
    let run = penumbra()
        .args(["render", "--width", "32", "--height", "18"])
        .args(["--render-scale", "0.5", "--frames", "3", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "stderr: {err}");
    assert!(err.contains("32x18 (rendered at 16x9)"), "stderr: {err}");
    let img = image::open(&out).unwrap();
    assert_eq!((img.width(), img.height()), (32, 18));
}

#[test]
fn frame_aovs_below_render_scale_1_are_refused_before_rendering() {
    let dir = temp_dir("upscaled-aov");
    let run = penumbra()
        .args(["render", "--width", "32", "--height", "18"])
        .args(["--render-scale", "0.5", "--aov", "u", "--out"])
        .arg(dir.join("u.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(
        err.contains("--render-scale") && err.contains("--aov"),
        "stderr: {err}"
    );
    assert!(
        std::fs::read_dir(&dir).unwrap().next().is_none(),
        "a file was written"
    );
}

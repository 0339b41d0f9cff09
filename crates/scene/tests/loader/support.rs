//! Helpers shared by the scene tests.

use glam::Vec3;
use penumbra_scene::{Scene, SceneError};
use std::path::Path;

/// A valid preamble: camera and one material "m". Bad-input tests append the
/// section under test.
pub const BASE: &str = r#"
[camera]
eye    = [0.0, 2.0, -5.0]
target = [0.0, 0.0, 0.0]
fov_y  = 45.0

[[material]]
name      = "m"
diffuse   = [0.5, 0.5, 0.5]
specular  = [0.04, 0.04, 0.04]
roughness = 0.5
"#;

pub fn parse(text: &str) -> Result<Scene, SceneError> {
    Scene::parse(text, Path::new("test.toml"))
}

pub fn parse_ok(text: &str) -> Scene {
    parse(text).unwrap_or_else(|e| panic!("expected a valid scene, got: {e}"))
}

/// 1-based line of the first line of `text` containing `marker`.
pub fn line_of(text: &str, marker: &str) -> usize {
    text.lines()
        .position(|l| l.contains(marker))
        .unwrap_or_else(|| panic!("marker {marker:?} not in the text"))
        + 1
}

/// Asserts `text` is refused at the line containing `marker` with a message
/// containing every one of `needles`, displayed as `file:line: message`.
pub fn assert_refused(text: &str, marker: &str, needles: &[&str]) {
    let line = line_of(text, marker);
    let err = match parse(text) {
        Ok(_) => panic!("expected refusal at line {line} ({marker:?}), but the scene loaded"),
        Err(e) => e,
    };
    assert_eq!(err.line, line, "wrong line in: {err}");
    for n in needles {
        assert!(err.message.contains(n), "message lacks {n:?}: {err}");
    }
    assert!(
        err.to_string().starts_with(&format!("test.toml:{line}: ")),
        "display: {err}"
    );
}

/// BASE followed by `extra`.
pub fn with(extra: &str) -> String {
    format!("{BASE}{extra}")
}

/// A fresh empty directory, removed when the guard drops.
pub fn temp_dir() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("penumbra-scene-test-")
        .tempdir()
        .expect("create temp dir")
}

/// Writes `scene` as scene.toml in `dir` (with any extra files) and loads it.
pub fn load_in(dir: &Path, scene: &str) -> Result<Scene, SceneError> {
    let p = dir.join("scene.toml");
    std::fs::write(&p, scene).expect("write scene");
    Scene::load(&p)
}

/// Whether two loaded positions or normals agree to within f32 rounding of
/// the loader's transforms.
pub fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

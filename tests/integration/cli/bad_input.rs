//! Bad input through the command line, end to end: the process exits
//! non-zero, stderr holds exactly one message naming the file, line and key,
//! nothing panics and no output file appears.
use std::path::{Path, PathBuf};
use std::process::Command;

const CAMERA: &str = "[camera]\neye = [0.0, 2.0, -5.0]\ntarget = [0.0, 0.0, 0.0]\nfov_y = 45.0\n";
const MATERIAL: &str = "[[material]]\nname = \"m\"\ndiffuse = [0.5, 0.5, 0.5]\nspecular = [0.04, 0.04, 0.04]\nroughness = 0.5\n";

/// Writes `files` into a fresh directory, runs `penumbra render scene.toml
/// --out out.png` plus `extra` (default: an 8x8 frame) there, and checks the refusal: non-zero exit,
/// one stderr line containing every needle, no panic, no out.png.
fn assert_cli_refuses(files: &[(&str, &[u8])], extra: &[&str], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in files {
        std::fs::write(dir.path().join(name), bytes).unwrap();
    }
    let out = dir.path().join("out.png");
    let size: &[&str] = if extra.is_empty() {
        &["--width", "8", "--height", "8"]
    } else {
        extra
    };
    let run = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .current_dir(dir.path())
        .args(["render", "scene.toml", "--out"])
        .arg(&out)
        .args(size)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success(), "exit 0; stderr: {err}");
    assert_eq!(run.status.code(), Some(1), "stderr: {err}");
    assert!(!err.contains("panicked"), "stderr: {err}");
    assert_eq!(err.trim_end().lines().count(), 1, "not one message: {err}");
    for n in needles {
        assert!(err.contains(n), "lacks {n:?}: {err}");
    }
    assert!(!out.exists(), "an output file was written");
    assert!(
        run.stdout.is_empty(),
        "stdout: {}",
        String::from_utf8_lossy(&run.stdout)
    );
    assert!(
        only_inputs_in(dir.path(), files),
        "files appeared beside the inputs"
    );
}

fn only_inputs_in(dir: &Path, files: &[(&str, &[u8])]) -> bool {
    std::fs::read_dir(dir).unwrap().all(|e| {
        let name = e.unwrap().file_name();
        files.iter().any(|(f, _)| name == *f)
    })
}

fn scene(body: &str) -> Vec<u8> {
    format!("{CAMERA}{MATERIAL}{body}").into_bytes()
}

/// 1-based line of `marker` in the scene `scene(body)`, as "scene.toml:N:".
fn at(body: &str, marker: &str) -> String {
    let text = String::from_utf8(scene(body)).unwrap();
    let line = text.lines().position(|l| l.contains(marker)).unwrap() + 1;
    format!("scene.toml:{line}:")
}

#[test]
fn toml_syntax_error_is_one_message_with_file_and_line() {
    let body = "[[object]\nmaterial = \"m\"\n";
    assert_cli_refuses(
        &[("scene.toml", &scene(body))],
        &[],
        &[&at(body, "[[object]"), "invalid TOML"],
    );
}

#[test]
fn unknown_key_is_one_message_naming_it() {
    let body = "[[light]]\ntype = \"quad\"\ncenter = [0, 3, 0]\nu = [1, 0, 0]\nv = [0, 0, 1]\nradiance = [1, 1, 1]\nintensity = 3\n";
    assert_cli_refuses(
        &[("scene.toml", &scene(body))],
        &[],
        &[&at(body, "intensity"), "intensity"],
    );
}

#[test]
fn nan_number_is_one_message_naming_the_key() {
    let body =
        "[[object]]\nmaterial = \"m\"\ntype = \"sphere\"\ncenter = [0, nan, 0]\nradius = 1\n";
    assert_cli_refuses(
        &[("scene.toml", &scene(body))],
        &[],
        &[&at(body, "center"), "center"],
    );
}

#[test]
fn missing_camera_section_is_one_message() {
    assert_cli_refuses(
        &[("scene.toml", MATERIAL.as_bytes())],
        &[],
        &["scene.toml:1:", "[camera]"],
    );
}

#[test]
fn unknown_material_is_one_message_naming_it() {
    let body = "[[object]]\nmaterial = \"gold\"\ntype = \"quad\"\ncenter = [0, 0, 0]\nu = [1, 0, 0]\nv = [0, 0, 1]\n";
    assert_cli_refuses(
        &[("scene.toml", &scene(body))],
        &[],
        &[&at(body, "gold"), "\"gold\""],
    );
}

#[test]
fn obj_with_out_of_range_face_names_both_files_and_lines() {
    let body = "[[object]]\nmaterial = \"m\"\ntype = \"mesh\"\npath = \"bad.obj\"\n";
    assert_cli_refuses(
        &[
            ("scene.toml", &scene(body)),
            ("bad.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n"),
        ],
        &[],
        &[&at(body, "path"), "path", "bad.obj:4:", "out of range"],
    );
}

#[test]
fn missing_obj_is_one_message_naming_the_key() {
    let body = "[[object]]\nmaterial = \"m\"\ntype = \"mesh\"\npath = \"gone.obj\"\n";
    assert_cli_refuses(
        &[("scene.toml", &scene(body))],
        &[],
        &[&at(body, "path"), "gone.obj", "cannot read"],
    );
}

#[test]
fn garbage_image_is_one_message_naming_the_map_key() {
    let body = "[[material]]\nname = \"t\"\ndiffuse = [1, 1, 1]\nspecular = [0, 0, 0]\nroughness = 0.5\nnormal_map = \"n.png\"\n";
    assert_cli_refuses(
        &[
            ("scene.toml", &scene(body)),
            ("n.png", b"\x89PNG\r\n\x1a\ngarbage"),
        ],
        &[],
        &[&at(body, "normal_map"), "normal_map", "n.png"],
    );
}

#[test]
fn binary_scene_file_is_one_message() {
    assert_cli_refuses(
        &[("scene.toml", b"\x00\xff\xfe garbage \x80")],
        &[],
        &["scene.toml:1:", "not UTF-8"],
    );
}

#[test]
fn missing_scene_file_is_one_message() {
    assert_cli_refuses(&[], &[], &["scene.toml", "cannot read"]);
}

#[test]
fn scene_resolution_too_large_is_one_message() {
    let body = "[output]\nwidth = 16384\nheight = 16384\n";
    let text = format!("{CAMERA}{body}");
    let dir_line = text.lines().position(|l| l.contains("height")).unwrap() + 1;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), &text).unwrap();
    let out = dir.path().join("out.png");
    // Without --width/--height, so the scene's [output] is what is checked.
    let run = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .current_dir(dir.path())
        .args(["render", "scene.toml", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains(&format!("scene.toml:{dir_line}:")) && err.contains("64 Mpixel"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn command_line_resolution_too_large_is_one_message() {
    assert_cli_refuses(
        &[("scene.toml", &scene(""))],
        &["--width", "16384", "--height", "16384"],
        &["16384x16384", "limit"],
    );
}

#[test]
fn bad_scene_in_the_viewer_is_one_message_too() {
    let dir = tempfile::tempdir().unwrap();
    let text = format!("{CAMERA}roughness = 2\n");
    std::fs::write(dir.path().join("scene.toml"), &text).unwrap();
    // The scene is loaded before any window opens, so a display that does
    // not exist is never reached.
    let run = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .current_dir(dir.path())
        .args(["view", "scene.toml", "--frames", "1"])
        .env("DISPLAY", ":31999")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success());
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("scene.toml:5:") && err.contains("roughness"),
        "{err}"
    );
}

/// Keeps the helper honest: a good scene passes every check but the exit.
#[test]
fn a_good_scene_renders_through_the_same_path() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scene.toml"), scene("")).unwrap();
    let out: PathBuf = dir.path().join("out.png");
    let run = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .current_dir(dir.path())
        .args([
            "render",
            "scene.toml",
            "--width",
            "8",
            "--height",
            "8",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(out.exists());
}

#[test]
fn debug_pixel_outside_the_frame_is_one_message_naming_the_frame() {
    assert_cli_refuses(
        &[("scene.toml", &scene(""))],
        &["--width", "8", "--height", "8", "--debug-pixel", "8,2"],
        &["--debug-pixel 8,2", "8x8"],
    );
}

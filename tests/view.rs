//! The window, driven under Xvfb (installed by `make test`).
use std::path::PathBuf;
use std::process::Command;

fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-view-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn a_scripted_window_shows_what_render_writes() {
    let shot = temp("shot.png");
    let rendered = temp("render.png");
    let bin = env!("CARGO_BIN_EXE_penumbra");
    let view = Command::new("xvfb-run")
        .args([
            "-a",
            "-s",
            "-screen 0 640x480x24",
            bin,
            "view",
            "--mode",
            "unshadowed",
            "--width",
            "160",
            "--height",
            "90",
        ])
        .args(["--frames", "3", "--screenshot"])
        .arg(&shot)
        .output()
        .expect("xvfb-run is installed (make test installs it)");
    assert!(
        view.status.success(),
        "view failed: {}",
        String::from_utf8_lossy(&view.stderr)
    );
    let render = Command::new(bin)
        .args([
            "render",
            "--mode",
            "unshadowed",
            "--width",
            "160",
            "--height",
            "90",
            "--out",
        ])
        .arg(&rendered)
        .status()
        .unwrap();
    assert!(render.success());
    let a = image::open(&shot).unwrap().to_rgb8();
    let b = image::open(&rendered).unwrap().to_rgb8();
    assert_eq!(a.dimensions(), b.dimensions());
    let off = a
        .pixels()
        .zip(b.pixels())
        .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > 2))
        .count();
    assert!(
        off * 1000 <= (160 * 90),
        "{off} pixels differ between window and render"
    );
}

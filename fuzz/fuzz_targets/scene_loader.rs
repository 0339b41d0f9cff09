//! Fuzzes the scene loader with the files a scene can pull in: the input is
//! split into a scene (TOML), an OBJ mesh and an image, written to a private
//! directory as `scene.toml`, `mesh.obj` and `map.png`, and loaded the way
//! the command line does. Seeds refer to those two names.
//!
//! A finding is a panic, or a loaded scene that breaks the loader's promises
//! (finite geometry, unit normals, sizes within the limits), or an error
//! whose line does not exist in the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use penumbra::scene::{Scene, check_resolution};
use std::path::PathBuf;
use std::sync::OnceLock;

/// Separates the scene from the OBJ, and the OBJ from the image.
const OBJ_MARK: &[u8] = b"\n%%obj\n";
const IMG_MARK: &[u8] = b"\n%%img\n";

fn split<'a>(data: &'a [u8], mark: &[u8]) -> (&'a [u8], &'a [u8]) {
    match data.windows(mark.len()).position(|w| w == mark) {
        Some(i) => (&data[..i], &data[i + mark.len()..]),
        None => (data, &[]),
    }
}

fn dir() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("penumbra-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("fuzz temp dir");
        d
    })
}

fn check_loaded(scene: &Scene) {
    assert!(check_resolution(scene.width, scene.height).is_ok());
    let c = &scene.camera;
    assert!(c.eye.is_finite() && c.target.is_finite() && c.up.is_finite());
    assert!(c.fov_y > 0.0 && c.fov_y < 180.0);
    for m in &scene.meshes {
        assert!(m.positions.iter().all(|p| p.is_finite()));
        if let Some(ns) = &m.normals {
            assert_eq!(ns.len(), m.positions.len());
            assert!(ns.iter().all(|n| (n.length() - 1.0).abs() < 1e-3), "normal not unit");
        }
        if let Some(uvs) = &m.uvs {
            assert_eq!(uvs.len(), m.positions.len());
            assert!(uvs.iter().all(|t| t.is_finite()));
        }
        let n = m.positions.len();
        assert!(m.indices.iter().flatten().all(|&i| (i as usize) < n));
        assert!((m.material as usize) < scene.materials.len());
    }
    for l in &scene.lights {
        assert!((3..=8).contains(&l.vertices.len()));
        assert!(l.vertices.iter().all(|v| v.is_finite()));
        assert!(l.radiance.is_finite() && l.radiance.min_element() >= 0.0);
        assert!(l.area > 0.0 && l.area.is_finite());
        assert!((l.normal.length() - 1.0).abs() < 1e-3);
    }
    for m in &scene.materials {
        for t in [&m.diffuse_map, &m.roughness_map, &m.normal_map].into_iter().flatten() {
            assert_eq!(t.texels.len(), t.width as usize * t.height as usize);
            assert!(t.texels.iter().flatten().all(|c| c.is_finite()));
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let (toml, rest) = split(data, OBJ_MARK);
    let (obj, img) = split(rest, IMG_MARK);
    let d = dir();
    let scene_path = d.join("scene.toml");
    std::fs::write(&scene_path, toml).unwrap();
    std::fs::write(d.join("mesh.obj"), obj).unwrap();
    std::fs::write(d.join("map.png"), img).unwrap();
    match Scene::load(&scene_path) {
        Ok(scene) => check_loaded(&scene),
        Err(e) => {
            assert!(!e.message.is_empty());
            let lines = toml.split(|&b| b == b'\n').count();
            assert!(e.line <= lines.max(1), "line {} of {lines}: {e}", e.line);
        }
    }
});

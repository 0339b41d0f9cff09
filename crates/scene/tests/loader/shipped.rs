//! Every scene shipped in scenes/ loads, and has what it is there for.

use penumbra_scene::Scene;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join("scenes")
        .join(name)
}

fn load(name: &str) -> Scene {
    Scene::load(&scene_path(name)).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn every_shipped_scene_loads() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join("scenes");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let s = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert!(s.triangle_count() > 0, "{}", path.display());
            n += 1;
        }
    }
    assert!(
        n >= 4,
        "expected default, shadow-plane, room, many-tris; found {n}"
    );
}

/// Quads among the built-in scene's meshes: its floor strips.
fn strips(s: &Scene) -> Vec<&penumbra_scene::Material> {
    s.meshes
        .iter()
        .filter(|m| m.indices.len() == 2)
        .map(|m| &s.materials[m.material as usize])
        .collect()
}

#[test]
fn builtin_scene_is_normal_mapped_strips_of_four_roughnesses_under_two_polygon_lights() {
    let s = Scene::builtin();
    // Four strips (2 triangles each) and four posts (boxes, 12 each).
    assert_eq!(s.triangle_count(), 4 * 2 + 4 * 12);
    assert_eq!(s.lights.len(), 2);
    assert!(s.lights.iter().all(|l| l.quad.is_none()), "polygon lights");
    assert_eq!((s.width, s.height), (1280, 720));
    let strips = strips(&s);
    assert_eq!(strips.len(), 4);
    assert!(strips.iter().all(|m| m.normal_map.is_some()));
    let mut roughness: Vec<f32> = strips.iter().map(|m| m.roughness).collect();
    roughness.sort_by(f32::total_cmp);
    roughness.dedup();
    assert_eq!(
        roughness.len(),
        4,
        "four distinct roughnesses: {roughness:?}"
    );
    assert!(roughness[0] < 0.2, "a polished strip: {roughness:?}");
    assert_eq!(
        strips
            .iter()
            .filter(|m| m.specular.max_element() == 0.0)
            .count(),
        1,
        "one Lambert strip"
    );
}

#[test]
fn builtin_scene_equals_scenes_default_toml_loaded_from_disk() {
    let (built, file) = (Scene::builtin(), load("default.toml"));
    assert_eq!(built.triangle_count(), file.triangle_count());
    assert_eq!(built.lights, file.lights);
    for (a, b) in strips(&built).iter().zip(strips(&file)) {
        let (ta, tb) = (
            a.normal_map.as_ref().unwrap(),
            b.normal_map.as_ref().unwrap(),
        );
        assert_eq!((ta.width, ta.height), (tb.width, tb.height));
        assert!(ta.texels == tb.texels, "the compiled-in map is the file's");
    }
}

#[test]
fn shadow_plane_has_three_receivers_with_distinct_brdfs() {
    let s = load("shadow-plane.toml");
    assert_eq!((s.width, s.height), (1280, 720));
    assert_eq!(s.lights.len(), 1);
    let quads: Vec<_> = s.meshes.iter().filter(|m| m.indices.len() == 2).collect();
    assert_eq!(quads.len(), 3);
    let mats: Vec<_> = quads
        .iter()
        .map(|m| &s.materials[m.material as usize])
        .collect();
    assert_eq!(mats[0].specular.max_element(), 0.0, "Lambert receiver");
    assert!((mats[1].roughness - 0.3).abs() < 1e-6, "glossy receiver");
    assert!(
        mats[2].roughness <= 0.05 && mats[2].specular.min_element() >= 0.9,
        "mirror"
    );
}

#[test]
fn room_has_two_lights_of_different_shape_and_colour_and_mapped_floor() {
    let s = load("room.toml");
    assert_eq!(s.lights.len(), 2);
    assert_ne!(s.lights[0].vertices.len(), s.lights[1].vertices.len());
    assert_ne!(s.lights[0].radiance, s.lights[1].radiance);
    let floor = &s.materials[s.meshes[0].material as usize];
    assert!(floor.roughness_map.is_some() && floor.normal_map.is_some());
    assert!(floor.diffuse_map.is_some());
    // The camera is inside the 8 x 3 x 10 room.
    let e = s.camera.eye;
    assert!(e.x.abs() < 4.0 && e.y > 0.0 && e.y < 3.0 && e.z.abs() < 5.0);
}

#[test]
fn many_tris_has_over_a_million_triangles_and_loads_quickly() {
    let t = Instant::now();
    let s = load("many-tris.toml");
    let ms = t.elapsed().as_secs_f64() * 1e3;
    eprintln!(
        "many-tris.toml: {} triangles in {ms:.0} ms",
        s.triangle_count()
    );
    assert_eq!(s.triangle_count(), 4 * 327_680 + 2);
}

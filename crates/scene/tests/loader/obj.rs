//! OBJ meshes: attributes, triangulation, the transform order, and refusals.

use crate::support::{BASE, close, load_in, temp_dir};
use glam::{Vec2, Vec3};
use penumbra_scene::Scene;
use std::path::Path;

/// Writes `obj` as mesh.obj next to a scene with one mesh object using
/// `extra` keys, and loads it.
fn load_mesh(obj: &str, extra: &str) -> Result<Scene, penumbra_scene::SceneError> {
    let dir = temp_dir();
    std::fs::write(dir.path().join("mesh.obj"), obj).unwrap();
    load_in(
        dir.path(),
        &format!(
            "{BASE}\n[[object]]\nmaterial = \"m\"\ntype = \"mesh\"\npath = \"mesh.obj\"\n{extra}\n"
        ),
    )
}

const TRI_FULL: &str =
    "v 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nf 1/1/1 2/2/1 3/3/1\n";
const QUAD_BARE: &str = "v 0 0 0\nv 1 0 0\nv 1 0 1\nv 0 0 1\nf 1 2 3 4\n";

#[test]
fn obj_with_normals_and_uvs_keeps_them_normalised() {
    let s = load_mesh(TRI_FULL, "").unwrap();
    let m = &s.meshes[0];
    assert_eq!(m.indices.len(), 1);
    let ns = m.normals.as_ref().expect("normals kept");
    assert!(
        ns.iter().all(|n| close(*n, Vec3::Z)),
        "renormalised from (0,0,2)"
    );
    let uvs = m.uvs.as_ref().expect("uvs kept");
    let i = m
        .positions
        .iter()
        .position(|p| close(*p, Vec3::new(0.0, 1.0, 0.0)))
        .unwrap();
    assert_eq!(uvs[i], Vec2::new(1.0, 0.0));
}

#[test]
fn obj_without_normals_has_face_normals_and_polygons_are_triangulated() {
    let s = load_mesh(QUAD_BARE, "").unwrap();
    let m = &s.meshes[0];
    assert!(m.normals.is_none());
    assert!(m.uvs.is_none());
    assert_eq!(m.indices.len(), 2);
}

#[test]
fn shipped_pedestal_obj_triangulates_hexagon_caps() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join("scenes/room.toml");
    let s = Scene::load(&p).unwrap();
    // 2 hexagons (4 triangles each) + 6 side quads (2 each).
    assert!(
        s.meshes
            .iter()
            .any(|m| m.indices.len() == 20 && m.normals.is_none())
    );
}

#[test]
fn mesh_rotate_y_90_maps_plus_x_to_minus_z() {
    let s = load_mesh(TRI_FULL, "rotate_y = 90").unwrap();
    let m = &s.meshes[0];
    assert!(
        m.positions
            .iter()
            .any(|p| close(*p, Vec3::new(0.0, 0.0, -1.0)))
    );
    assert!(
        m.positions
            .iter()
            .any(|p| close(*p, Vec3::new(1.0, 0.0, 0.0))),
        "+Z maps to +X"
    );
    assert!(
        m.normals
            .as_ref()
            .unwrap()
            .iter()
            .all(|n| close(*n, Vec3::X))
    );
}

#[test]
fn mesh_transform_is_scale_then_rotate_then_translate() {
    let s = load_mesh(
        TRI_FULL,
        "scale = [2, 3, 4]\nrotate_y = 90\ntranslate = [10, 20, 30]",
    )
    .unwrap();
    let p = &s.meshes[0].positions;
    // (1,0,0) -> scale (2,0,0) -> rotate (0,0,-2) -> translate (10,20,28).
    assert!(
        p.iter().any(|q| close(*q, Vec3::new(10.0, 20.0, 28.0))),
        "{p:?}"
    );
    // (0,0,1) -> (0,0,4) -> (4,0,0) -> (14,20,30).
    assert!(
        p.iter().any(|q| close(*q, Vec3::new(14.0, 20.0, 30.0))),
        "{p:?}"
    );
    // (0,1,0) -> (0,3,0) -> (0,3,0) -> (10,23,30).
    assert!(
        p.iter().any(|q| close(*q, Vec3::new(10.0, 23.0, 30.0))),
        "{p:?}"
    );
}

#[test]
fn mesh_uniform_scale_number_is_accepted() {
    let s = load_mesh(TRI_FULL, "scale = 2").unwrap();
    assert!(
        s.meshes[0]
            .positions
            .iter()
            .any(|q| close(*q, Vec3::new(2.0, 0.0, 0.0)))
    );
}

#[test]
fn mesh_normals_use_the_inverse_transpose_under_nonuniform_scale() {
    // A plane x + y = 1 with normal (1,1,0)/sqrt2. Scaling x by 2 gives the
    // plane x/2 + y = 1, whose normal is (1/2, 1, 0) normalised, not (2,1,0).
    let obj = "v 1 0 0\nv 0 1 0\nv 1 0 1\nvn 1 1 0\nf 1//1 2//1 3//1\n";
    let s = load_mesh(obj, "scale = [2, 1, 1]").unwrap();
    let n = s.meshes[0].normals.as_ref().unwrap()[0];
    assert!(close(n, Vec3::new(0.5, 1.0, 0.0).normalize()), "{n}");
    let m = &s.meshes[0];
    let [a, b, c] = m.indices[0].map(|i| m.positions[i as usize]);
    assert!(
        (b - a).cross(c - a).normalize().dot(n).abs() > 0.9999,
        "normal is perpendicular"
    );
}

#[test]
fn mesh_path_is_relative_to_the_scene_file() {
    let dir = temp_dir();
    std::fs::create_dir_all(dir.path().join("meshes")).unwrap();
    std::fs::write(dir.path().join("meshes/q.obj"), QUAD_BARE).unwrap();
    let s = load_in(
        dir.path(),
        &format!(
            "{BASE}\n[[object]]\nmaterial = \"m\"\ntype = \"mesh\"\npath = \"meshes/q.obj\"\n"
        ),
    );
    assert!(s.is_ok(), "{:?}", s.err());
}

/// The OBJ is refused: the scene line is the `path` key's line, and the
/// message names the key, the OBJ file and (when given) its line.
fn assert_obj_refused(obj: &[u8], obj_line: Option<usize>, needle: &str) {
    let dir = temp_dir();
    std::fs::write(dir.path().join("bad.obj"), obj).unwrap();
    let scene =
        format!("{BASE}\n[[object]]\nmaterial = \"m\"\ntype = \"mesh\"\npath = \"bad.obj\"\n");
    let e = load_in(dir.path(), &scene).expect_err("refused");
    assert_eq!(e.line, crate::support::line_of(&scene, "path = "), "{e}");
    assert!(e.message.contains("path = \"bad.obj\""), "{e}");
    let at = match obj_line {
        Some(l) => format!("bad.obj:{l}: "),
        None => "bad.obj: ".into(),
    };
    assert!(e.message.contains(&at), "lacks {at:?}: {e}");
    assert!(e.message.contains(needle), "lacks {needle:?}: {e}");
}

#[test]
fn obj_missing_file_is_refused() {
    let dir = temp_dir();
    let scene =
        format!("{BASE}\n[[object]]\nmaterial = \"m\"\ntype = \"mesh\"\npath = \"nope.obj\"\n");
    let e = load_in(dir.path(), &scene).expect_err("refused");
    assert_eq!(e.line, crate::support::line_of(&scene, "path = "));
    assert!(
        e.message.contains("nope.obj") && e.message.contains("cannot read"),
        "{e}"
    );
}

#[test]
fn obj_face_index_out_of_range_is_refused_with_obj_line() {
    assert_obj_refused(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n",
        Some(4),
        "out of range",
    );
}

#[test]
fn obj_relative_index_out_of_range_is_refused() {
    assert_obj_refused(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n",
        Some(4),
        "out of range",
    );
}

#[test]
fn obj_zero_index_is_refused() {
    assert_obj_refused(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", Some(4), "index 0");
}

#[test]
fn obj_nan_vertex_is_refused() {
    assert_obj_refused(
        b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n",
        Some(2),
        "non-finite",
    );
}

#[test]
fn obj_non_number_vertex_is_refused() {
    assert_obj_refused(b"v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n", Some(2), "zero");
}

#[test]
fn obj_zero_normal_is_refused() {
    assert_obj_refused(
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n",
        Some(4),
        "zero length",
    );
}

#[test]
fn obj_without_faces_is_refused() {
    assert_obj_refused(b"# just points\nv 0 0 0\nv 1 0 0\n", None, "no faces");
}

#[test]
fn obj_face_with_two_vertices_is_refused() {
    assert_obj_refused(b"v 0 0 0\nv 1 0 0\nf 1 2\n", Some(3), "at least 3");
}

#[test]
fn obj_binary_garbage_is_refused() {
    assert_obj_refused(
        &[0xff, 0xfe, 0x00, 0x13, 0x80, 0x81, 0x9f],
        None,
        "not UTF-8",
    );
}

#[test]
fn obj_text_garbage_is_refused() {
    assert_obj_refused(b"hello world\nthis is not a mesh\n", None, "no faces");
}

#[test]
fn mesh_zero_scale_is_refused() {
    let e = load_mesh(QUAD_BARE, "scale = [1, 0, 1]").expect_err("refused");
    assert!(
        e.message.contains("scale") && e.message.contains("zero"),
        "{e}"
    );
}

//! Bad files behind a scene: unreadable, truncated, garbage or hostile OBJ
//! meshes and image maps, and scene files that are not text. Each is refused
//! with the scene line of the key that names the file, never a panic.

use crate::support::{BASE, line_of, load_in, temp_dir};
use image::{ImageFormat, Rgb, Rgb32FImage, RgbImage};
use penumbra_scene::{Scene, SceneError};
use std::path::Path;

/// Makes `path` unreadable. Returns false where permissions do not bite
/// (running as root, or a file system without modes): the caller then skips.
fn make_unreadable(path: &Path) -> bool {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o000)).unwrap();
    if std::fs::read(path).is_ok() {
        eprintln!("skipped: {} is still readable (root?)", path.display());
        return false;
    }
    true
}

fn mesh_scene(file: &str) -> String {
    format!("{BASE}\n[[object]]\nmaterial = \"m\"\ntype = \"mesh\"\npath = \"{file}\"\n")
}

fn map_scene(key: &str, file: &str) -> String {
    format!(
        "{BASE}\n[[material]]\nname = \"t\"\ndiffuse = [1,1,1]\nspecular = [0,0,0]\nroughness = 0.5\n{key} = \"{file}\"\n"
    )
}

/// Loads `scene` from `dir` and asserts it is refused at the line containing
/// `marker`, with a message holding every needle.
fn assert_refused_in(dir: &Path, scene: &str, marker: &str, needles: &[&str]) -> SceneError {
    let e = load_in(dir, scene).expect_err("refused");
    assert_eq!(e.line, line_of(scene, marker), "{e}");
    for n in needles {
        assert!(e.message.contains(n), "lacks {n:?}: {e}");
    }
    e
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";

fn assert_obj_refused(obj: &str, needles: &[&str]) {
    let dir = temp_dir();
    std::fs::write(dir.path().join("bad.obj"), obj).unwrap();
    assert_refused_in(dir.path(), &mesh_scene("bad.obj"), "path = ", needles);
}

// ---- scene files -------------------------------------------------------

#[test]
fn unreadable_scene_file_is_refused() {
    let dir = temp_dir();
    let p = dir.path().join("locked.toml");
    std::fs::write(&p, BASE).unwrap();
    if !make_unreadable(&p) {
        return;
    }
    let e = Scene::load(&p).expect_err("refused");
    assert!(e.to_string().contains("locked.toml") && e.message.contains("cannot read"));
}

#[test]
fn scene_path_that_is_a_directory_is_refused() {
    let dir = temp_dir();
    let e = Scene::load(dir.path()).expect_err("refused");
    assert!(e.message.contains("cannot read"), "{e}");
}

#[test]
fn binary_scene_file_is_refused_at_the_first_bad_line() {
    let dir = temp_dir();
    let p = dir.path().join("bin.toml");
    let mut bytes = BASE.as_bytes().to_vec();
    let line = BASE.lines().count() + 1;
    bytes.extend_from_slice(&[0xff, 0xfe, 0x00, 0x80]);
    std::fs::write(&p, bytes).unwrap();
    let e = Scene::load(&p).expect_err("refused");
    assert_eq!(e.line, line, "{e}");
    assert!(e.message.contains("not UTF-8"), "{e}");
}

#[test]
fn scene_with_a_nul_byte_is_refused_with_its_line() {
    let text = format!("{BASE}\n[output]\nwidth = 6\0\n");
    let e = crate::support::parse(&text).expect_err("refused");
    assert_eq!(e.line, line_of(&text, "width"), "{e}");
}

// ---- OBJ meshes --------------------------------------------------------

#[test]
fn unreadable_obj_is_refused() {
    let dir = temp_dir();
    let p = dir.path().join("locked.obj");
    std::fs::write(&p, format!("{TRI}f 1 2 3\n")).unwrap();
    if !make_unreadable(&p) {
        return;
    }
    assert_refused_in(
        dir.path(),
        &mesh_scene("locked.obj"),
        "path = ",
        &["locked.obj", "cannot read"],
    );
}

#[test]
fn obj_path_that_is_a_directory_is_refused() {
    let dir = temp_dir();
    std::fs::create_dir(dir.path().join("d.obj")).unwrap();
    assert_refused_in(
        dir.path(),
        &mesh_scene("d.obj"),
        "path = ",
        &["d.obj", "cannot read"],
    );
}

#[test]
fn empty_obj_is_refused() {
    assert_obj_refused("", &["bad.obj", "no faces"]);
}

#[test]
fn obj_truncated_inside_a_face_is_refused_at_that_line() {
    assert_obj_refused(&format!("{TRI}f 1 2"), &["bad.obj:4:", "at least 3"]);
}

#[test]
fn obj_truncated_inside_a_vertex_is_refused_at_that_line() {
    assert_obj_refused(
        &format!("{TRI}f 1 2 3\nv 1 2"),
        &["bad.obj:5:", "3 numbers"],
    );
}

#[test]
fn every_truncation_of_the_shipped_obj_loads_or_is_refused_cleanly() {
    let obj = include_str!(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/meshes/pedestal.obj"
    ));
    let dir = temp_dir();
    let scene = mesh_scene("cut.obj");
    for (i, _) in obj.char_indices() {
        std::fs::write(dir.path().join("cut.obj"), &obj[..i]).unwrap();
        match load_in(dir.path(), &scene) {
            Ok(s) => assert!(
                s.meshes
                    .iter()
                    .all(|m| m.positions.iter().all(|p| p.is_finite()))
            ),
            Err(e) => assert_eq!(e.line, line_of(&scene, "path = "), "{e}"),
        }
    }
}

#[test]
fn obj_nan_normal_is_refused() {
    assert_obj_refused(
        &format!("{TRI}vn 0 nan 1\nf 1//1 2//1 3//1\n"),
        &["bad.obj:4:", "non-finite"],
    );
}

#[test]
fn obj_infinite_normal_is_refused() {
    assert_obj_refused(
        &format!("{TRI}vn 0 0 inf\nf 1//1 2//1 3//1\n"),
        &["bad.obj:4:", "non-finite"],
    );
}

#[test]
fn obj_nan_texture_coordinate_is_refused() {
    assert_obj_refused(
        &format!("{TRI}vt nan 0\nf 1/1 2/1 3/1\n"),
        &["bad.obj:4:", "non-finite"],
    );
}

#[test]
fn obj_infinite_texture_coordinate_is_refused() {
    assert_obj_refused(
        &format!("{TRI}vt 0 -inf\nf 1/1 2/1 3/1\n"),
        &["bad.obj:4:", "non-finite"],
    );
}

#[test]
fn obj_infinite_vertex_is_refused() {
    assert_obj_refused(
        "v 0 0 0\nv 1 0 0\nv 0 1e39 0\nf 1 2 3\n",
        &["bad.obj:3:", "non-finite"],
    );
}

#[test]
fn obj_normal_too_large_to_square_still_loads_as_unit_normal() {
    let dir = temp_dir();
    std::fs::write(
        dir.path().join("big.obj"),
        format!("{TRI}vn 0 0 3e38\nf 1//1 2//1 3//1\n"),
    )
    .unwrap();
    let s = load_in(dir.path(), &mesh_scene("big.obj")).expect("loads");
    for n in s.meshes[0].normals.as_ref().expect("normals kept") {
        assert!((n.length() - 1.0).abs() < 1e-5, "{n:?}");
    }
}

#[test]
fn obj_coordinate_beyond_the_scene_limit_is_refused() {
    assert_obj_refused(
        "v 0 0 0\nv 1 0 0\nv 0 1e30 0\nf 1 2 3\n",
        &["bad.obj:3:", "1e8"],
    );
}

#[test]
fn mesh_scale_that_overflows_the_scene_limit_is_refused() {
    let dir = temp_dir();
    std::fs::write(
        dir.path().join("m.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1e7 0\nf 1 2 3\n",
    )
    .unwrap();
    let scene = format!("{}scale = 1e6\n", mesh_scene("m.obj"));
    assert_refused_in(dir.path(), &scene, "path = ", &["m.obj", "1e8"]);
}

#[test]
fn obj_face_with_empty_normal_slot_is_refused() {
    assert_obj_refused(
        &format!("{TRI}f 1// 2// 3//\n"),
        &["bad.obj:4:", "malformed"],
    );
}

#[test]
fn obj_face_with_non_number_index_is_refused() {
    assert_obj_refused(&format!("{TRI}f 1 2 x\n"), &["bad.obj:4:", "malformed"]);
}

#[test]
fn obj_face_index_beyond_i64_is_refused() {
    assert_obj_refused(
        &format!("{TRI}f 1 2 99999999999999999999999\n"),
        &["bad.obj:4:", "malformed"],
    );
}

// ---- image maps --------------------------------------------------------

const MAPS: [&str; 3] = ["diffuse_map", "roughness_map", "normal_map"];

fn png_bytes() -> Vec<u8> {
    let mut buf = std::io::Cursor::new(Vec::new());
    RgbImage::from_pixel(32, 32, Rgb([10, 200, 30]))
        .write_to(&mut buf, ImageFormat::Png)
        .unwrap();
    buf.into_inner()
}

fn exr_bytes(value: f32) -> Vec<u8> {
    let mut buf = std::io::Cursor::new(Vec::new());
    Rgb32FImage::from_pixel(4, 4, image::Rgb([0.5, value, 0.5]))
        .write_to(&mut buf, ImageFormat::OpenExr)
        .unwrap();
    buf.into_inner()
}

/// Every map key refuses `bytes` written as `file`, at its own line.
fn assert_every_map_refuses(file: &str, bytes: &[u8], needles: &[&str]) {
    for key in MAPS {
        let dir = temp_dir();
        std::fs::write(dir.path().join(file), bytes).unwrap();
        let scene = map_scene(key, file);
        let mut all = vec![key, file];
        all.extend_from_slice(needles);
        assert_refused_in(dir.path(), &scene, key, &all);
    }
}

#[test]
fn unreadable_image_is_refused_for_every_map_kind() {
    for key in MAPS {
        let dir = temp_dir();
        let p = dir.path().join("locked.png");
        std::fs::write(&p, png_bytes()).unwrap();
        if !make_unreadable(&p) {
            return;
        }
        assert_refused_in(dir.path(), &map_scene(key, "locked.png"), key, &["cannot"]);
    }
}

#[test]
fn image_path_that_is_a_directory_is_refused_for_every_map_kind() {
    for key in MAPS {
        let dir = temp_dir();
        std::fs::create_dir(dir.path().join("d.png")).unwrap();
        assert_refused_in(dir.path(), &map_scene(key, "d.png"), key, &["d.png"]);
    }
}

#[test]
fn empty_image_file_is_refused_for_every_map_kind() {
    assert_every_map_refuses("e.png", b"", &[]);
}

#[test]
fn garbage_image_is_refused_for_every_map_kind() {
    assert_every_map_refuses("g.png", &[0x13, 0x37, 0xff, 0x00, 0x42, 0x99, 0x10], &[]);
}

#[test]
fn truncated_png_is_refused_for_every_map_kind() {
    let png = png_bytes();
    for cut in [8, 20, 40, png.len() / 2, png.len() - 13] {
        assert_every_map_refuses("cut.png", &png[..cut], &[]);
    }
}

#[test]
fn png_with_corrupted_pixel_data_is_refused_for_every_map_kind() {
    let mut png = png_bytes();
    // Past the 8-byte signature and IHDR, inside the compressed IDAT stream;
    // the chunk CRC no longer matches.
    let at = png.len() - 20;
    png[at] ^= 0xff;
    assert_every_map_refuses("bad.png", &png, &[]);
}

#[test]
fn png_header_claiming_a_huge_image_is_refused_for_every_map_kind() {
    let mut png = png_bytes();
    // IHDR width and height (big endian) at bytes 16..24; the chunk CRC is
    // fixed up so only the size is hostile.
    png[16..20].copy_from_slice(&1_000_000u32.to_be_bytes());
    png[20..24].copy_from_slice(&1_000_000u32.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    assert_every_map_refuses("huge.png", &png, &["1000000x1000000", "16384"]);
}

#[test]
fn truncated_exr_is_refused_for_every_map_kind() {
    let exr = exr_bytes(0.5);
    for cut in [4, 40, exr.len() / 2, exr.len() - 4] {
        assert_every_map_refuses("cut.exr", &exr[..cut], &[]);
    }
}

#[test]
fn exr_with_a_nan_texel_is_refused_for_every_map_kind() {
    assert_every_map_refuses("nan.exr", &exr_bytes(f32::NAN), &["NaN"]);
}

#[test]
fn exr_with_an_infinite_texel_is_refused_for_every_map_kind() {
    assert_every_map_refuses("inf.exr", &exr_bytes(f32::INFINITY), &["inf"]);
}

#[test]
fn exr_with_a_negative_texel_is_refused_for_every_map_kind() {
    assert_every_map_refuses("neg.exr", &exr_bytes(-0.25), &["outside [0, 1]"]);
}

/// CRC-32 (IEEE) as PNG chunks use it, bit by bit: small and obviously right.
fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

//! Material texture maps: decoding conventions, relative paths and refusals.

use crate::support::{BASE, line_of, load_in, temp_dir};
use image::{GrayImage, Luma, Rgb, RgbImage};

fn scene_with_map(key: &str, file: &str) -> String {
    format!(
        "{BASE}\n[[material]]\nname = \"t\"\ndiffuse = [1,1,1]\nspecular = [0,0,0]\nroughness = 0.5\n{key} = \"{file}\"\n"
    )
}

#[test]
fn diffuse_map_is_decoded_from_srgb_to_linear() {
    let dir = temp_dir();
    RgbImage::from_pixel(2, 2, Rgb([128, 255, 0]))
        .save(dir.path().join("c.png"))
        .unwrap();
    let s = load_in(dir.path(), &scene_with_map("diffuse_map", "c.png")).unwrap();
    let t = s.materials[1].diffuse_map.as_ref().unwrap();
    assert_eq!((t.width, t.height), (2, 2));
    let px = t.texels[0];
    // sRGB 128/255 is 0.2158 in linear light.
    assert!((px[0] - 0.2158).abs() < 1e-3, "{px:?}");
    assert!((px[1] - 1.0).abs() < 1e-6 && px[2] == 0.0 && px[3] == 1.0);
}

#[test]
fn roughness_and_normal_maps_are_kept_as_stored() {
    let dir = temp_dir();
    GrayImage::from_pixel(1, 1, Luma([128]))
        .save(dir.path().join("r.png"))
        .unwrap();
    RgbImage::from_pixel(1, 1, Rgb([128, 128, 255]))
        .save(dir.path().join("n.png"))
        .unwrap();
    let text = format!(
        "{BASE}\n[[material]]\nname = \"t\"\ndiffuse = [1,1,1]\nspecular = [0,0,0]\nroughness = 0.5\nroughness_map = \"r.png\"\nnormal_map = \"n.png\"\n"
    );
    let s = load_in(dir.path(), &text).unwrap();
    let r = s.materials[1].roughness_map.as_ref().unwrap().texels[0];
    assert!((r[0] - 128.0 / 255.0).abs() < 1e-6, "{r:?}");
    let n = s.materials[1].normal_map.as_ref().unwrap().texels[0];
    assert!(
        (n[0] - 128.0 / 255.0).abs() < 1e-6 && (n[2] - 1.0).abs() < 1e-6,
        "{n:?}"
    );
}

#[test]
fn image_rows_are_stored_top_first() {
    let dir = temp_dir();
    let mut img = GrayImage::new(1, 2);
    img.put_pixel(0, 0, Luma([255])); // top
    img.put_pixel(0, 1, Luma([0])); // bottom
    img.save(dir.path().join("g.png")).unwrap();
    let s = load_in(dir.path(), &scene_with_map("roughness_map", "g.png")).unwrap();
    let t = s.materials[1].roughness_map.as_ref().unwrap();
    assert_eq!(t.texels[0][0], 1.0);
    assert_eq!(t.texels[1][0], 0.0);
    // t = 1 is the top row (OpenGL convention).
    assert!(t.sample(glam::Vec2::new(0.5, 0.75))[0] == 1.0);
    assert!(t.sample(glam::Vec2::new(0.5, 0.25))[0] == 0.0);
}

#[test]
fn missing_image_is_refused_at_the_map_key() {
    let dir = temp_dir();
    let text = scene_with_map("normal_map", "missing.png");
    let e = load_in(dir.path(), &text).expect_err("refused");
    assert_eq!(e.line, line_of(&text, "normal_map"));
    assert!(
        e.message
            .contains("material \"t\": normal_map = \"missing.png\""),
        "{e}"
    );
    assert!(e.message.contains("cannot open"), "{e}");
}

#[test]
fn garbage_image_is_refused() {
    let dir = temp_dir();
    std::fs::write(dir.path().join("bad.png"), b"this is not an image at all").unwrap();
    let text = scene_with_map("diffuse_map", "bad.png");
    let e = load_in(dir.path(), &text).expect_err("refused");
    assert_eq!(e.line, line_of(&text, "diffuse_map"));
    assert!(
        e.message.contains("diffuse_map") && e.message.contains("bad.png"),
        "{e}"
    );
}

#[test]
fn truncated_png_is_refused() {
    let dir = temp_dir();
    let p = dir.path().join("full.png");
    RgbImage::from_pixel(64, 64, Rgb([10, 20, 30]))
        .save(&p)
        .unwrap();
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(dir.path().join("cut.png"), &bytes[..bytes.len() / 2]).unwrap();
    let text = scene_with_map("roughness_map", "cut.png");
    let e = load_in(dir.path(), &text).expect_err("refused");
    assert_eq!(e.line, line_of(&text, "roughness_map"));
    assert!(e.message.contains("roughness_map"), "{e}");
}

#[test]
fn map_path_must_be_a_string() {
    let text = format!(
        "{BASE}\n[[material]]\nname = \"t\"\ndiffuse = [1,1,1]\nspecular = [0,0,0]\nroughness = 0.5\ndiffuse_map = 3\n"
    );
    let e = crate::support::parse(&text).expect_err("refused");
    assert_eq!(e.line, line_of(&text, "diffuse_map"));
    assert!(
        e.message.contains("diffuse_map") && e.message.contains("string"),
        "{e}"
    );
}

#[test]
fn missing_scene_file_is_an_error_not_a_panic() {
    let dir = temp_dir();
    let e = penumbra_scene::Scene::load(&dir.path().join("none.toml")).expect_err("refused");
    assert!(
        e.to_string().contains("none.toml") && e.message.contains("cannot read"),
        "{e}"
    );
}

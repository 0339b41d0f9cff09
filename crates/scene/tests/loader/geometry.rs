//! Conventions of the generated geometry: counts, winding, uvs, transforms,
//! light vertex order and normals, texture addressing.

use crate::support::{close, parse_ok, with};
use glam::{Vec2, Vec3};
use penumbra_scene::{Light, LightError, Mesh, Texture};
use std::time::Instant;

fn one_object(obj: &str) -> Mesh {
    let s = parse_ok(&with(&format!("[[object]]\nmaterial = \"m\"\n{obj}")));
    assert_eq!(s.meshes.len(), 1);
    s.meshes.into_iter().next().unwrap()
}

fn face_normal(m: &Mesh, t: [u32; 3]) -> Vec3 {
    let [a, b, c] = t.map(|i| m.positions[i as usize]);
    (b - a).cross(c - a).normalize()
}

#[test]
fn quad_has_two_triangles_and_four_vertices() {
    let m = one_object("type = \"quad\"\ncenter = [0,0,0]\nu = [1,0,0]\nv = [0,0,1]");
    assert_eq!(m.indices.len(), 2);
    assert_eq!(m.positions.len(), 4);
}

#[test]
fn box_has_twelve_triangles_and_24_vertices_with_flat_outward_normals() {
    let m = one_object("type = \"box\"\ncenter = [1,2,3]\nsize = [2,4,6]");
    assert_eq!(m.indices.len(), 12);
    assert_eq!(m.positions.len(), 24);
    let ns = m.normals.as_ref().unwrap();
    for t in &m.indices {
        let fnorm = face_normal(&m, *t);
        for &i in t {
            assert!(
                close(ns[i as usize], fnorm),
                "flat normal agrees with winding"
            );
        }
        let centroid = t.iter().map(|&i| m.positions[i as usize]).sum::<Vec3>() / 3.0;
        assert!(
            (centroid - Vec3::new(1.0, 2.0, 3.0)).dot(fnorm) > 0.0,
            "outward"
        );
    }
    let uvs = m.uvs.as_ref().unwrap();
    assert!(
        uvs.iter()
            .all(|uv| (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y))
    );
}

#[test]
fn sphere_triangle_count_is_20_times_4_to_the_level() {
    for level in 0..=4u32 {
        let m = one_object(&format!(
            "type = \"sphere\"\ncenter = [0,0,0]\nradius = 1\nsubdivisions = {level}"
        ));
        assert_eq!(m.indices.len(), 20 * 4usize.pow(level), "level {level}");
    }
}

#[test]
fn sphere_default_subdivision_is_3() {
    let m = one_object("type = \"sphere\"\ncenter = [0,0,0]\nradius = 1");
    assert_eq!(m.indices.len(), 1280);
}

#[test]
fn sphere_vertices_lie_on_the_sphere_with_radial_normals_and_outward_winding() {
    let c = Vec3::new(1.0, -2.0, 0.5);
    let m = one_object("type = \"sphere\"\ncenter = [1,-2,0.5]\nradius = 2\nsubdivisions = 2");
    let ns = m.normals.as_ref().unwrap();
    for (p, n) in m.positions.iter().zip(ns) {
        assert!(((*p - c).length() - 2.0).abs() < 1e-5);
        assert!(close(*n, (*p - c).normalize()));
    }
    for t in &m.indices {
        assert!(face_normal(&m, *t).dot(m.positions[t[0] as usize] - c) > 0.0);
    }
}

#[test]
fn sphere_uvs_do_not_wrap_across_a_triangle() {
    let m = one_object("type = \"sphere\"\ncenter = [0,0,0]\nradius = 1\nsubdivisions = 3");
    let uvs = m.uvs.as_ref().unwrap();
    for t in &m.indices {
        let s: Vec<f32> = t.iter().map(|&i| uvs[i as usize].x).collect();
        let spread =
            s.iter().cloned().fold(f32::MIN, f32::max) - s.iter().cloned().fold(f32::MAX, f32::min);
        assert!(spread < 0.5, "seam triangle spans s {s:?}");
    }
}

#[test]
fn level_8_sphere_loads_fast_in_release() {
    let t = Instant::now();
    let m = one_object("type = \"sphere\"\ncenter = [0,0,0]\nradius = 1\nsubdivisions = 8");
    let secs = t.elapsed().as_secs_f64();
    assert_eq!(m.indices.len(), 20 * 4usize.pow(8));
    eprintln!(
        "level-8 sphere: {} triangles in {:.0} ms",
        m.indices.len(),
        secs * 1e3
    );
    // Generous bound (debug builds and busy machines); release is ~10x faster.
    if !cfg!(debug_assertions) {
        assert!(secs < 5.0, "took {secs} s");
    }
}

#[test]
fn quad_uv_origin_is_center_minus_u_minus_v_and_s_runs_along_u() {
    let m = one_object("type = \"quad\"\ncenter = [1,0,0]\nu = [2,0,0]\nv = [0,0,3]");
    let uvs = m.uvs.as_ref().unwrap();
    let at = |p: Vec3| {
        let i = m.positions.iter().position(|q| close(*q, p)).unwrap();
        uvs[i]
    };
    assert_eq!(at(Vec3::new(-1.0, 0.0, -3.0)), Vec2::new(0.0, 0.0));
    assert_eq!(at(Vec3::new(3.0, 0.0, -3.0)), Vec2::new(1.0, 0.0));
    assert_eq!(at(Vec3::new(3.0, 0.0, 3.0)), Vec2::new(1.0, 1.0));
    assert_eq!(at(Vec3::new(-1.0, 0.0, 3.0)), Vec2::new(0.0, 1.0));
}

#[test]
fn quad_normal_is_normalized_cross_u_v_and_matches_winding() {
    let m = one_object("type = \"quad\"\ncenter = [0,0,0]\nu = [0,0,5]\nv = [5,0,0]");
    for n in m.normals.as_ref().unwrap() {
        assert!(close(*n, Vec3::Y));
    }
    for t in &m.indices {
        assert!(close(face_normal(&m, *t), Vec3::Y));
    }
}

#[test]
fn box_rotate_y_90_maps_plus_x_to_minus_z() {
    // A box long in x; after rotate_y = 90 it must be long in z.
    let m = one_object("type = \"box\"\ncenter = [0,0,0]\nsize = [4,1,1]\nrotate_y = 90");
    let max_z = m.positions.iter().map(|p| p.z.abs()).fold(0.0, f32::max);
    let max_x = m.positions.iter().map(|p| p.x.abs()).fold(0.0, f32::max);
    assert!((max_z - 2.0).abs() < 1e-5 && (max_x - 0.5).abs() < 1e-5);
}

#[test]
fn box_rotate_y_positive_turns_plus_x_towards_minus_z() {
    // A symmetric box alone cannot tell +90 from -90; at 30 degrees the
    // corner furthest along +X has moved to -Z under the right-hand rule.
    let m = one_object("type = \"box\"\ncenter = [0,0,0]\nsize = [4,1,1]\nrotate_y = 30");
    let far = m
        .positions
        .iter()
        .copied()
        .fold(Vec3::splat(f32::MIN), |a, p| if p.x > a.x { p } else { a });
    assert!(far.z < -0.5, "corner at {far}");
}

#[test]
fn box_rotates_about_its_own_center() {
    let m = one_object("type = \"box\"\ncenter = [5,1,2]\nsize = [2,2,2]\nrotate_y = 45");
    let mean = m.positions.iter().sum::<Vec3>() / m.positions.len() as f32;
    assert!(close(mean, Vec3::new(5.0, 1.0, 2.0)));
}

#[test]
fn quad_light_vertices_are_in_the_documented_order_with_right_hand_normal() {
    let s = parse_ok(&with(
        "[[light]]\ntype = \"quad\"\ncenter = [0,4,0]\nu = [1,0,0]\nv = [0,0,0.5]\nradiance = [1,1,1]",
    ));
    let l = &s.lights[0];
    let (c, u, v) = (Vec3::new(0.0, 4.0, 0.0), Vec3::X, Vec3::new(0.0, 0.0, 0.5));
    let expect = [c - u - v, c + u - v, c + u + v, c - u + v];
    for (a, b) in l.vertices.iter().zip(expect) {
        assert!(close(*a, b));
    }
    assert!(close(l.normal, Vec3::NEG_Y), "cross(+X, +Z) = -Y");
    assert!((l.area - 2.0).abs() < 1e-6);
    assert_eq!(l.quad, Some((c, u, v)));
    assert!(!l.two_sided);
}

#[test]
fn polygon_light_normal_follows_vertex_winding() {
    let ccw = "[[light]]\ntype = \"polygon\"\nvertices = [[0,2,0],[1,2,0],[0,2,1]]\nradiance = [1,1,1]\ntwo_sided = true";
    let cw =
        "[[light]]\ntype = \"polygon\"\nvertices = [[0,2,0],[0,2,1],[1,2,0]]\nradiance = [1,1,1]";
    let a = &parse_ok(&with(ccw)).lights[0];
    let b = &parse_ok(&with(cw)).lights[0];
    assert!(
        close(a.normal, Vec3::NEG_Y),
        "cross(+X, +Z) = -Y, got {}",
        a.normal
    );
    assert!(close(b.normal, Vec3::Y));
    assert!((a.area - 0.5).abs() < 1e-6);
    assert!(a.two_sided && a.quad.is_none());
}

#[test]
fn polygon_light_hexagon_area_and_vertices_kept() {
    let verts: Vec<String> = (0..6)
        .map(|k| {
            let t = (k as f32 * 60.0).to_radians();
            format!("[{}, 1.0, {}]", t.cos(), -t.sin())
        })
        .collect();
    let s = parse_ok(&with(&format!(
        "[[light]]\ntype = \"polygon\"\nvertices = [{}]\nradiance = [1,1,1]",
        verts.join(", ")
    )));
    let l = &s.lights[0];
    assert_eq!(l.vertices.len(), 6);
    assert!((l.area - 1.5 * 3f32.sqrt()).abs() < 1e-4);
    assert!(close(l.normal, Vec3::Y));
}

#[test]
fn zero_radiance_light_is_allowed() {
    let s = parse_ok(&with(
        "[[light]]\ntype = \"quad\"\ncenter = [0,4,0]\nu = [1,0,0]\nv = [0,0,1]\nradiance = [0,0,0]",
    ));
    assert_eq!(s.lights[0].radiance, Vec3::ZERO);
}

#[test]
fn scene_without_objects_or_lights_is_valid() {
    let s = parse_ok(crate::support::BASE);
    assert!(s.meshes.is_empty() && s.lights.is_empty());
    assert_eq!((s.width, s.height), (1280, 720));
    assert_eq!(s.camera.up, Vec3::Y);
}

#[test]
fn output_size_is_read() {
    let s = parse_ok(&with("[output]\nwidth = 640\nheight = 480\n"));
    assert_eq!((s.width, s.height), (640, 480));
}

#[test]
fn integers_are_accepted_where_numbers_are_expected() {
    let s = parse_ok(&with(
        "[[object]]\nmaterial = \"m\"\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 2\n",
    ));
    let c = Vec3::new(0.0, 1.0, 0.0);
    assert!(
        s.meshes[0]
            .positions
            .iter()
            .all(|p| ((*p - c).length() - 2.0).abs() < 1e-5)
    );
    assert_eq!(s.camera.fov_y, 45.0);
}

fn texture_2x2() -> Texture {
    // Row 0 (top): red, green. Row 1 (bottom): blue, white.
    Texture {
        width: 2,
        height: 2,
        texels: vec![
            [1.0, 0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0, 1.0],
            [0.0, 0.0, 1.0, 1.0],
            [1.0, 1.0, 1.0, 1.0],
        ],
    }
}

#[test]
fn texture_t_zero_is_the_bottom_row() {
    let t = texture_2x2();
    assert_eq!(
        t.sample(Vec2::new(0.25, 0.25)),
        [0.0, 0.0, 1.0, 1.0],
        "bottom-left"
    );
    assert_eq!(
        t.sample(Vec2::new(0.25, 0.75)),
        [1.0, 0.0, 0.0, 1.0],
        "top-left"
    );
    assert_eq!(
        t.sample(Vec2::new(0.75, 0.75)),
        [0.0, 1.0, 0.0, 1.0],
        "top-right"
    );
}

#[test]
fn texture_sampling_is_bilinear_and_wraps() {
    let t = texture_2x2();
    // Halfway between the top-left and top-right texel centres.
    let mid = t.sample(Vec2::new(0.5, 0.75));
    assert!((mid[0] - 0.5).abs() < 1e-6 && (mid[1] - 0.5).abs() < 1e-6);
    // Repeat addressing: shifting by whole units changes nothing.
    assert_eq!(
        t.sample(Vec2::new(2.25, -0.25)),
        t.sample(Vec2::new(0.25, 0.75))
    );
    // At s = 0 the left and right columns blend (wrap-around).
    let edge = t.sample(Vec2::new(0.0, 0.75));
    assert!((edge[0] - 0.5).abs() < 1e-6);
    assert_eq!(t.sample(Vec2::new(f32::NAN, 0.5)), [0.0; 4]);
}

#[test]
fn light_constructors_build_what_the_loader_builds() {
    let quad = "[[light]]\ntype = \"quad\"\ncenter = [0.3,4,-1]\nu = [1,0,0.2]\nv = [0,0.1,0.5]\nradiance = [1,2,3]\ntwo_sided = true";
    let loaded = &parse_ok(&with(quad)).lights[0];
    let built = Light::quad(
        Vec3::new(0.3, 4.0, -1.0),
        Vec3::new(1.0, 0.0, 0.2),
        Vec3::new(0.0, 0.1, 0.5),
        Vec3::new(1.0, 2.0, 3.0),
    )
    .unwrap()
    .with_two_sided(true);
    assert_eq!(&built, loaded);

    let polygon = "[[light]]\ntype = \"polygon\"\nvertices = [[0,2,0],[1,2,0.1],[1.2,2,1],[0,2,1]]\nradiance = [4,4,4]";
    let loaded = &parse_ok(&with(polygon)).lights[0];
    let vertices = vec![
        Vec3::new(0.0, 2.0, 0.0),
        Vec3::new(1.0, 2.0, 0.1),
        Vec3::new(1.2, 2.0, 1.0),
        Vec3::new(0.0, 2.0, 1.0),
    ];
    let built = Light::polygon(vertices, Vec3::splat(4.0)).unwrap();
    assert_eq!(&built, loaded);
}

#[test]
fn light_constructors_refuse_what_the_loader_refuses() {
    let (c, u) = (Vec3::ZERO, Vec3::X);
    assert!(matches!(
        Light::quad(c, u, 2.0 * u, Vec3::ONE),
        Err(LightError::ZeroArea { .. })
    ));
    assert!(matches!(
        Light::quad(c, u, Vec3::Z, Vec3::new(1.0, -0.5, 1.0)),
        Err(LightError::NegativeRadiance(_))
    ));
    let collinear = vec![Vec3::ZERO, Vec3::X, 2.0 * Vec3::X];
    assert!(matches!(
        Light::polygon(collinear, Vec3::ONE),
        Err(LightError::Polygon(_))
    ));
    let two = vec![Vec3::ZERO, Vec3::X];
    assert!(Light::polygon(two, Vec3::ONE).is_err());
}

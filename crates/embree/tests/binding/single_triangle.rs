//! Known answers on the simplest scene: one triangle.

use penumbra_embree::{Device, GeometryRole, INVALID_ID, Rays16, SceneBuilder, Vec3};

/// v0 = (0,0,0), v1 = (1,0,0), v2 = (0,1,0) at z = 0, counter-clockwise from +z.
fn triangle() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    (vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])
}

#[test]
fn ray_down_onto_triangle_hits_with_known_t_ids_and_barycentrics() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    let (p, i) = triangle();
    // A first, distant mesh so the triangle's geometry id is 1, not the default 0.
    let (fp, fi) = (
        vec![
            Vec3::new(50.0, 50.0, 0.0),
            Vec3::new(51.0, 50.0, 0.0),
            Vec3::new(50.0, 51.0, 0.0),
        ],
        vec![[0, 1, 2]],
    );
    assert_eq!(
        builder
            .add_triangles(&fp, &fi, GeometryRole::Occluder)
            .unwrap(),
        0
    );
    assert_eq!(
        builder
            .add_triangles(&p, &i, GeometryRole::Occluder)
            .unwrap(),
        1
    );
    let scene = builder.commit().unwrap();

    let hit = scene
        .intersect1(
            Vec3::new(0.2, 0.3, 2.0),
            Vec3::new(0.0, 0.0, -1.0),
            0.0,
            f32::INFINITY,
        )
        .expect("ray straight at the triangle must hit");
    assert!((hit.t - 2.0).abs() < 1e-6, "t = {}", hit.t);
    assert_eq!(hit.geom_id, 1);
    assert_eq!(hit.prim_id, 0);
    // Hit point = (1-u-v) v0 + u v1 + v v2 = (u, v, 0).
    assert!((hit.u - 0.2).abs() < 1e-6, "u = {}", hit.u);
    assert!((hit.v - 0.3).abs() < 1e-6, "v = {}", hit.v);
    // Embree's Ng = (v1 - v0) x (v2 - v0) = +z for this winding.
    assert!(hit.ng.normalize().dot(Vec3::Z) > 0.999, "ng = {:?}", hit.ng);
}

#[test]
fn ray_beside_triangle_misses() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    let (p, i) = triangle();
    builder
        .add_triangles(&p, &i, GeometryRole::Occluder)
        .unwrap();
    let scene = builder.commit().unwrap();

    let org = Vec3::new(0.8, 0.8, 2.0); // u + v > 1: outside the triangle
    assert_eq!(scene.intersect1(org, -Vec3::Z, 0.0, f32::INFINITY), None);
    assert!(!scene.occluded1(org, -Vec3::Z, 0.0, f32::INFINITY));
    let mut rays = Rays16::new();
    rays.set(3, org, -Vec3::Z, 0.0, f32::INFINITY);
    let hits = scene.intersect16(&rays, false);
    assert_eq!(hits.geom_id[3], INVALID_ID);
    assert_eq!(hits.t[3], f32::INFINITY);
    assert_eq!(scene.occluded16(&rays), 0);
}

#[test]
fn occluder_outside_tnear_tfar_interval_is_ignored() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    let (p, i) = triangle();
    builder
        .add_triangles(&p, &i, GeometryRole::Occluder)
        .unwrap();
    let scene = builder.commit().unwrap();
    let org = Vec3::new(0.2, 0.3, 2.0);
    let dir = -Vec3::Z; // triangle at t = 2

    assert!(scene.occluded1(org, dir, 0.0, 2.5));
    assert!(
        !scene.occluded1(org, dir, 0.0, 1.5),
        "beyond tfar must not occlude"
    );
    assert!(
        !scene.occluded1(org, dir, 2.5, 10.0),
        "before tnear must not occlude"
    );
    assert!(scene.intersect1(org, dir, 0.0, 1.5).is_none());
    assert!(scene.intersect1(org, dir, 2.5, 10.0).is_none());

    let mut rays = Rays16::new();
    rays.set(0, org, dir, 0.0, 2.5);
    rays.set(1, org, dir, 0.0, 1.5);
    rays.set(2, org, dir, 2.5, 10.0);
    assert_eq!(scene.occluded16(&rays), 0b001);
    let hits = scene.intersect16(&rays, false);
    assert!(hits.is_hit(0) && !hits.is_hit(1) && !hits.is_hit(2));
}

#[test]
fn inactive_lanes_are_never_traced() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    let (p, i) = triangle();
    builder
        .add_triangles(&p, &i, GeometryRole::Occluder)
        .unwrap();
    let scene = builder.commit().unwrap();
    let mut rays = Rays16::new();
    for lane in 0..16 {
        rays.set(lane, Vec3::new(0.2, 0.3, 2.0), -Vec3::Z, 0.0, f32::INFINITY);
    }
    rays.active = 0b1010_0000_0000_0101;
    let hits = scene.intersect16(&rays, true);
    for lane in 0..16 {
        assert_eq!(hits.is_hit(lane), rays.is_active(lane), "lane {lane}");
    }
    assert_eq!(scene.occluded16(&rays), rays.active);
}

fn version_parts(v: &str) -> Vec<u32> {
    let parts: Vec<u32> = v.split('.').map(|s| s.parse().unwrap()).collect();
    assert_eq!(parts.len(), 3, "{v}");
    parts
}

#[test]
fn device_reports_linked_embree_version() {
    let v = Device::version();
    let parts = version_parts(&v);
    assert!(parts[0] == 3 || parts[0] == 4, "{v}");
}

#[test]
fn linked_library_matches_the_headers_major_and_is_not_older() {
    let device = Device::new().unwrap();
    let library = device.library_version();
    let header = Device::header_version();
    let (l, h) = (version_parts(&library), version_parts(&header));
    assert_eq!(l[0], h[0], "library {library}, headers {header}");
    assert!(l >= h, "library {library} is older than headers {header}");
}

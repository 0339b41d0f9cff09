//! `CameraOnly` meshes (area lights) are seen by camera rays and never block
//! shadow rays, with ray masks and with the separate-scene fallback.

use crate::support::square;
use penumbra_embree::{
    Device, GeometryRole, Rays8, Rays16, Scene, SceneBuilder, ShadowStrategy, Vec3,
};

/// Light (CameraOnly) at z = 1, occluder at z = -1: a ray from z = 3 going
/// down meets the light first, then the occluder.
fn light_over_floor(device: &Device, strategy: ShadowStrategy) -> Scene<'_> {
    let mut builder = SceneBuilder::with_strategy(device, strategy).unwrap();
    let (lp, li) = square(1.0);
    let (fp, fi) = square(-1.0);
    assert_eq!(
        builder
            .add_triangles(&lp, &li, GeometryRole::CameraOnly)
            .unwrap(),
        0
    );
    assert_eq!(
        builder
            .add_triangles(&fp, &fi, GeometryRole::Occluder)
            .unwrap(),
        1
    );
    builder.commit().unwrap()
}

fn strategies(device: &Device) -> Vec<ShadowStrategy> {
    let mut s = vec![ShadowStrategy::SeparateScene];
    if device.ray_mask_supported() {
        s.push(ShadowStrategy::RayMask);
    }
    s
}

const ORG: Vec3 = Vec3::new(0.1, 0.2, 3.0);
const DOWN: Vec3 = Vec3::new(0.0, 0.0, -1.0);
/// The floor's distance along `DOWN`, and the rounding Embree's kernels
/// may leave on it (they differ by instruction set: 1 ulp seen with AVX2).
const FLOOR_T: f32 = 2.0;
const T_ULPS: f32 = 4.0 * f32::EPSILON;

fn hits_floor(geom_id: u32, t: f32) -> bool {
    geom_id == 0 && (t - FLOOR_T).abs() <= T_ULPS * FLOOR_T
}

#[test]
fn camera_rays_hit_camera_only_geometry() {
    let device = Device::new().unwrap();
    for strategy in strategies(&device) {
        let scene = light_over_floor(&device, strategy);
        let hit = scene.intersect1(ORG, DOWN, 0.0, f32::INFINITY).unwrap();
        assert!(hits_floor(hit.geom_id, hit.t), "{strategy:?}: {hit:?}");

        let mut rays = Rays16::new();
        rays.set(5, ORG, DOWN, 0.0, f32::INFINITY);
        let hits = scene.intersect16(&rays, true);
        let (g, t) = (hits.geom_id[5], hits.t[5]);
        assert!(hits_floor(g, t), "{strategy:?}: {g} at {t}");

        let mut rays8 = Rays8::new();
        rays8.set(2, ORG, DOWN, 0.0, f32::INFINITY);
        let hits8 = scene.intersect8(&rays8, false);
        let (g, t) = (hits8.geom_id[2], hits8.t[2]);
        assert!(hits_floor(g, t), "{strategy:?}: {g} at {t}");
    }
}

#[test]
fn camera_only_geometry_never_occludes_shadow_rays() {
    let device = Device::new().unwrap();
    for strategy in strategies(&device) {
        let scene = light_over_floor(&device, strategy);
        // Stops before the floor: only the light lies in [0, 3].
        assert!(!scene.occluded1(ORG, DOWN, 0.0, 3.0), "{strategy:?}");
        let mut rays = Rays16::new();
        rays.set(0, ORG, DOWN, 0.0, 3.0);
        rays.set(15, ORG, DOWN, 0.0, 3.0);
        assert_eq!(scene.occluded16(&rays), 0, "{strategy:?}");
        let mut rays8 = Rays8::new();
        rays8.set(7, ORG, DOWN, 0.0, 3.0);
        assert_eq!(scene.occluded8(&rays8), 0, "{strategy:?}");
    }
}

#[test]
fn occluders_behind_camera_only_geometry_still_occlude() {
    let device = Device::new().unwrap();
    for strategy in strategies(&device) {
        let scene = light_over_floor(&device, strategy);
        assert!(scene.occluded1(ORG, DOWN, 0.0, 5.0), "{strategy:?}");
        let mut rays = Rays16::new();
        rays.set(0, ORG, DOWN, 0.0, 3.0);
        rays.set(9, ORG, DOWN, 0.0, 5.0);
        assert_eq!(scene.occluded16(&rays), 1 << 9, "{strategy:?}");
        let mut rays8 = Rays8::new();
        rays8.set(1, ORG, DOWN, 0.0, 5.0);
        assert_eq!(scene.occluded8(&rays8), 1 << 1, "{strategy:?}");
    }
}

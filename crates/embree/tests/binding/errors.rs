//! Invalid input comes back as `Err`, never a panic or an Embree crash.

use penumbra_embree::{Device, EmbreeError, GeometryRole, SceneBuilder, Vec3};

fn tri() -> Vec<Vec3> {
    vec![Vec3::ZERO, Vec3::X, Vec3::Y]
}

#[test]
fn index_out_of_range_is_an_error() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    let err = builder
        .add_triangles(&tri(), &[[0, 1, 2], [0, 1, 3]], GeometryRole::Occluder)
        .unwrap_err();
    assert!(
        matches!(
            err,
            EmbreeError::IndexOutOfRange {
                triangle: 1,
                index: 3,
                vertex_count: 3
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().contains("vertex 3"), "{err}");
}

#[test]
fn non_finite_position_is_an_error() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    let mut p = tri();
    p[2].y = f32::NAN;
    let err = builder
        .add_triangles(&p, &[[0, 1, 2]], GeometryRole::Occluder)
        .unwrap_err();
    assert!(
        matches!(err, EmbreeError::NonFinitePosition { vertex: 2, .. }),
        "{err:?}"
    );
}

#[test]
fn failed_add_does_not_consume_a_geometry_id() {
    let device = Device::new().unwrap();
    let mut builder = SceneBuilder::new(&device).unwrap();
    assert!(
        builder
            .add_triangles(&tri(), &[[0, 1, 7]], GeometryRole::Occluder)
            .is_err()
    );
    assert_eq!(
        builder
            .add_triangles(&tri(), &[[0, 1, 2]], GeometryRole::Occluder)
            .unwrap(),
        0
    );
    let scene = builder.commit().unwrap();
    let hit = scene
        .intersect1(Vec3::new(0.1, 0.1, 1.0), -Vec3::Z, 0.0, f32::INFINITY)
        .unwrap();
    assert_eq!(hit.geom_id, 0);
}

#[test]
fn empty_scene_commits_and_misses_everything() {
    let device = Device::new().unwrap();
    let scene = SceneBuilder::new(&device).unwrap().commit().unwrap();
    assert!(
        scene
            .intersect1(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY)
            .is_none()
    );
    assert!(!scene.occluded1(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY));
}

#[test]
fn embree_error_display_names_the_code_and_message() {
    let err = EmbreeError::Embree {
        code: 2,
        code_name: "RTC_ERROR_INVALID_ARGUMENT",
        message: "invalid vertex buffer".into(),
        during: "rtcCommitScene",
    };
    let text = err.to_string();
    assert!(
        text.contains("RTC_ERROR_INVALID_ARGUMENT") && text.contains("invalid vertex buffer"),
        "{text}"
    );
}

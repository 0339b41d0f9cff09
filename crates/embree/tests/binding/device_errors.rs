//! Embree's own refusals come back as `EmbreeError` values, and a refused
//! call leaves the library usable.
use penumbra_embree::{Device, EmbreeError, GeometryRole, SceneBuilder, Vec3};

#[test]
fn a_config_string_embree_rejects_is_an_error() {
    let e = Device::with_config("threads=abc").expect_err("Embree refuses it");
    assert!(
        matches!(
            e,
            EmbreeError::NullHandle {
                call: "rtcNewDevice",
                ..
            }
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("rtcNewDevice"), "{e}");
}

#[test]
fn a_config_with_a_nul_byte_is_refused_before_embree() {
    let e = Device::with_config("verbose=0\0threads=1").expect_err("refused");
    assert!(matches!(e, EmbreeError::InvalidConfig), "{e:?}");
}

#[test]
fn a_valid_config_gives_a_working_device() {
    let device = Device::with_config("threads=1,verbose=0").expect("accepted");
    let mut b = SceneBuilder::new(&device).unwrap();
    let tri = [
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    b.add_triangles(&tri, &[[0, 1, 2]], GeometryRole::Occluder)
        .unwrap();
    let scene = b.commit().unwrap();
    assert!(scene.occluded1(Vec3::ZERO, Vec3::Z, 0.0, 2.0));
}

#[test]
fn after_a_refused_device_a_new_one_works() {
    assert!(Device::with_config("threads=abc").is_err());
    let device = Device::new().expect("Embree still starts");
    let scene = SceneBuilder::new(&device).unwrap().commit().unwrap();
    assert!(scene.intersect1(Vec3::ZERO, Vec3::Z, 0.0, 1.0).is_none());
}

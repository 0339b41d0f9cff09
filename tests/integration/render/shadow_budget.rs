//! Shadow rays per pixel, and the ratio where the estimates carry no energy.

use glam::Vec3;
use penumbra::embree::{self, Device};
use penumbra::render::estimate::ratio;
use penumbra::render::{Frame, Mode, PixelKind, RenderSettings, World};

const CAMERA_AND_BOX: &str = r#"
[camera]
eye    = [0.0, 3.0, -6.0]
target = [0.0, 0.0, 0.0]
fov_y  = 50.0

[[object]]
material = "m"
type = "box"
center = [0.0, 0.5, 0.0]
size = [1.0, 1.0, 1.0]
"#;

fn light(x: f32) -> String {
    format!(
        "\n[[light]]\ntype = \"quad\"\ncenter = [{x}, 3.0, 0.0]\nu = [0.4, 0.0, 0.0]\nv = [0.0, 0.0, 0.4]\nradiance = [4.0, 4.0, 4.0]\n"
    )
}

/// Shadow rays traced per surface pixel in one frame of `spp` samples.
fn rays_per_surface_pixel(text: &str, spp: u32) -> f64 {
    let scene = crate::support::parse(text);
    let camera = scene.camera;
    let device = Device::new().unwrap();
    let world = World::build(&device, scene).unwrap();
    let mut frame = Frame::new(96, 54);
    let settings = RenderSettings {
        mode: Mode::Ratio,
        spp,
        denoise: false,
        ..RenderSettings::default()
    };
    let t = embree::thread_pool(1)
        .unwrap()
        .install(|| frame.render(&world, &camera, &settings));
    let surface = frame
        .gbuf
        .iter()
        .filter(|g| g.kind == PixelKind::Surface)
        .count();
    t.shadow_rays as f64 / surface as f64
}

#[test]
fn shadow_rays_per_pixel_do_not_grow_with_the_number_of_lights() {
    let base = format!("{CAMERA_AND_BOX}{}", crate::support::FLOOR);
    let one = format!("{base}{}", light(0.0));
    let four = format!(
        "{base}{}{}{}{}",
        light(-1.5),
        light(-0.5),
        light(0.5),
        light(1.5)
    );
    for spp in [1, 4] {
        let (r1, r4) = (
            rays_per_surface_pixel(&one, spp),
            rays_per_surface_pixel(&four, spp),
        );
        println!("{spp} spp: {r1:.3} rays per surface pixel with 1 light, {r4:.3} with 4");
        assert!(
            r1 <= spp as f64 && r4 <= spp as f64,
            "1 light {r1}, 4 lights {r4}"
        );
        assert!(r4 > 0.5 * spp as f64, "the budget is spent: {r4}");
    }
}

#[test]
fn ratio_is_one_where_un_is_zero() {
    assert_eq!(ratio(Vec3::ZERO, Vec3::ZERO), Vec3::ONE);
    assert_eq!(
        ratio(Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.0, 0.0, 1e-30)),
        Vec3::new(0.5, 1.0, 1.0)
    );
}

#[test]
fn ratio_of_fully_shadowed_samples_is_zero() {
    assert_eq!(ratio(Vec3::ZERO, Vec3::splat(0.3)), Vec3::ZERO);
}

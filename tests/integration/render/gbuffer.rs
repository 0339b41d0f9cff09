//! What the camera rays put in the G-buffer.

use crate::support::{Job, render};
use glam::Vec3;
use penumbra::render::PixelKind;
use penumbra::scene::Scene;

const CAMERA_AND_LIGHT: &str = r#"
[camera]
eye    = [0.3, 2.0, -3.0]
target = [0.0, 0.0, 0.5]
fov_y  = 50.0

[[light]]
type = "quad"
center = [0.0, 3.0, 0.0]
u = [0.5, 0.0, 0.0]
v = [0.0, 0.0, 0.5]
radiance = [5.0, 5.0, 5.0]
"#;

fn plane_scene() -> Scene {
    crate::support::parse(&format!("{CAMERA_AND_LIGHT}{}", crate::support::FLOOR))
}

#[test]
fn depth_equals_the_analytic_distance_to_the_plane() {
    let scene = plane_scene();
    let job = Job {
        width: 64,
        height: 48,
        ..Job::default()
    };
    let frame = render(&scene, &job);
    let cam = scene.camera.frame(job.width, job.height);
    let mut checked = 0;
    for j in 0..job.height {
        for i in 0..job.width {
            let g = &frame.gbuf[(j * job.width + i) as usize];
            let d = cam.ray_dir(i, j, 0.5, 0.5);
            let t = -cam.eye.y / d.y;
            let hit = cam.eye + d * t;
            let on_plane = d.y < 0.0 && hit.x.abs() < 3.9 && hit.z.abs() < 3.9;
            if on_plane {
                assert_eq!(g.kind, PixelKind::Surface, "pixel ({i},{j})");
                assert!(
                    (g.depth - t).abs() <= 1e-4 * t,
                    "pixel ({i},{j}): depth {} vs {t}",
                    g.depth
                );
                checked += 1;
            } else if g.kind == PixelKind::Miss {
                assert_eq!(g.depth, 0.0);
            }
        }
    }
    assert!(checked > 1000, "only {checked} pixels on the plane");
}

#[test]
fn normals_face_the_camera() {
    let frame = render(&plane_scene(), &Job::default());
    for g in frame.gbuf.iter().filter(|g| g.kind == PixelKind::Surface) {
        assert!(g.ng.dot(g.wo) > 0.0 && (g.ng.length() - 1.0).abs() < 1e-4);
        assert!(g.ns.dot(g.ng) > 0.0);
    }
}

#[test]
fn a_light_seen_from_below_shows_its_radiance() {
    let mut scene = plane_scene();
    scene.camera.eye = Vec3::new(0.0, 1.0, 0.0);
    scene.camera.target = Vec3::new(0.0, 3.0, 0.01);
    let frame = render(&scene, &Job::default());
    let centre = &frame.gbuf[(45 * 160 + 80) as usize];
    assert_eq!(centre.kind, PixelKind::Light);
    assert_eq!(frame.color[45 * 160 + 80], Vec3::splat(5.0));
}

#[test]
fn a_light_seen_from_behind_is_black() {
    let mut scene = plane_scene();
    scene.lights[0].vertices.reverse();
    scene.lights[0].normal = -scene.lights[0].normal;
    scene.camera.eye = Vec3::new(0.0, 1.0, 0.0);
    scene.camera.target = Vec3::new(0.0, 3.0, 0.01);
    let frame = render(&scene, &Job::default());
    let k = 45 * 160 + 80;
    assert_eq!(frame.gbuf[k].kind, PixelKind::Light);
    assert_eq!(frame.color[k], Vec3::ZERO);
}

/// Exactly zero, not zero up to the projection's rounding: a motion vector
/// a few ulps off a whole pixel spreads the history's reprojection over four
/// taps instead of one.
#[test]
fn a_static_camera_has_exactly_zero_motion() {
    let frame = render(
        &plane_scene(),
        &Job {
            frames: 2,
            ..Job::default()
        },
    );
    for j in 0..90u32 {
        for i in 0..160u32 {
            let g = &frame.gbuf[(j * 160 + i) as usize];
            if g.kind == PixelKind::Surface {
                assert!(g.prev_valid);
                let centre = glam::Vec2::new(i as f32 + 0.5, j as f32 + 0.5);
                assert_eq!(g.prev_pixel, centre, "pixel ({i},{j}) moved");
            }
        }
    }
}

#[test]
fn motion_points_to_where_the_surface_was_in_the_previous_frame() {
    use penumbra::embree::{self, Device};
    use penumbra::render::{Frame, RenderSettings, World};
    let scene = plane_scene();
    let before = scene.camera;
    let mut after = before;
    after.eye += Vec3::new(0.2, 0.1, 0.15);
    let device = Device::new().unwrap();
    let world = World::build(&device, scene).unwrap();
    let mut frame = Frame::new(160, 90);
    // Unjittered rays: the check below casts the previous camera's ray
    // through prev_pixel (with TAA it is the motion of the pixel centre).
    let settings = RenderSettings {
        taa: false,
        ..RenderSettings::default()
    };
    embree::thread_pool(1).unwrap().install(|| {
        frame.render(&world, &before, &settings);
        frame.render(&world, &after, &settings);
    });
    let prev = before.frame(160, 90);
    let mut checked = 0;
    for g in frame
        .gbuf
        .iter()
        .filter(|g| g.kind == PixelKind::Surface && g.prev_valid)
    {
        // The previous camera's ray through prev_pixel must land on the same point.
        let (px, py) = (g.prev_pixel.x, g.prev_pixel.y);
        if !(0.0..160.0).contains(&px) || !(0.0..90.0).contains(&py) {
            continue;
        }
        let d = prev.ray_dir(0, 0, px, py);
        let p = prev.eye + d * (-prev.eye.y / d.y);
        assert!(
            (p - g.position).length() < 1e-3 * g.depth,
            "{p} vs {}",
            g.position
        );
        checked += 1;
    }
    assert!(checked > 5000, "only {checked} pixels checked");
}

//! The `U` stage's light culling (`render::estimate::analytic_u_band`) on
//! the shipped many-light hall: every pixel's `U` stays within the stated
//! tolerance of every light's sum, lights are really culled, tolerance 0
//! culls nothing, and the frame still traces at most one shadow ray per
//! surface pixel at 1 spp whatever the light count.

use crate::support::load;
use penumbra::color::luminance;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, PhaseTimes, PixelKind, RenderSettings, World};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 180;
/// The tolerance the test culls to (the shipped one is `LIGHT_TOLERANCE`).
const TOLERANCE: f32 = 0.02;
/// Rounding of `U` sums taken in another order.
const ROUNDING: f32 = 1e-5;
/// The culled frame must leave out the GGX lobe (or the whole light) in at
/// least this share of the (pixel, light) pairs, or the culling would be
/// idle on the scene it is for. Measured 0.33 at tolerance 0.02
/// and this size.
const MIN_SAVED_SHARE: f64 = 0.25;

fn render(settings: &RenderSettings) -> (Frame, PhaseTimes) {
    let scene = load("hall.toml");
    let camera = scene.camera;
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let mut frame = Frame::new(WIDTH, HEIGHT);
    let times = pool.install(|| frame.render(&world, &camera, settings));
    (frame, times)
}

fn unshadowed(light_tolerance: f32) -> (Frame, PhaseTimes) {
    render(&RenderSettings {
        mode: Mode::Unshadowed,
        light_tolerance,
        ..RenderSettings::default()
    })
}

#[test]
fn culled_u_stays_within_its_tolerance_of_every_light_at_every_pixel() {
    let (culled, times) = unshadowed(TOLERANCE);
    let (every, _) = unshadowed(0.0);
    for (k, (a, b)) in culled.u.iter().zip(&every.u).enumerate() {
        assert!(a.is_finite(), "U {a} at pixel {k}");
        let (a, b) = (luminance(*a), luminance(*b));
        assert!(
            (a - b).abs() <= TOLERANCE * a + ROUNDING * b,
            "U {a} against {b} with every light at pixel {k}"
        );
    }
    let [full, diffuse, culled_pairs] = times.u_pairs;
    let share = (diffuse + culled_pairs) as f64 / (full + diffuse + culled_pairs) as f64;
    println!("pairs without the GGX lobe or culled: {share:.3}");
    assert!(
        share >= MIN_SAVED_SHARE,
        "only {share:.2} of the pairs were spared the GGX lobe"
    );
}

#[test]
fn tolerance_zero_evaluates_every_light_at_every_surface_pixel() {
    let (frame, times) = unshadowed(0.0);
    let surface = frame
        .gbuf
        .iter()
        .filter(|g| g.kind == PixelKind::Surface)
        .count() as u64;
    assert_eq!(times.u_pairs, [surface * 24, 0, 0]);
}

#[test]
fn many_lights_still_trace_at_most_one_shadow_ray_per_surface_pixel() {
    let (frame, times) = render(&RenderSettings {
        settle: false,
        ..RenderSettings::default()
    });
    let surface = frame
        .gbuf
        .iter()
        .filter(|g| g.kind == PixelKind::Surface)
        .count() as u64;
    assert!(
        times.shadow_rays <= surface,
        "{} shadow rays for {surface} surface pixels",
        times.shadow_rays
    );
    assert!(frame.color.iter().all(|c| c.is_finite()));
}

#[test]
fn a_scene_of_two_lights_evaluates_both_everywhere() {
    let scene = load("room.toml");
    let camera = scene.camera;
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene).expect("scene builds");
    let mut frame = Frame::new(WIDTH, HEIGHT);
    let settings = RenderSettings {
        mode: Mode::Unshadowed,
        ..RenderSettings::default()
    };
    let times = frame.render(&world, &camera, &settings);
    assert_eq!(times.u_pairs[1..], [0, 0]);
}

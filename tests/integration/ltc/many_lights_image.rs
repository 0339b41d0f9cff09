//! U of a whole frame of the many-light hall, as the frame's `U` stage
//! computes it (light culling at the shipped tolerance, the shape
//! correction weighing each light's doubt against the pixel's whole `U`),
//! against the sum over its 24 lights of an adaptive `f64` quadrature of
//! the scene format's BRDF times each light (`support::ltc::reference`).
//! Prints the median and 95th percentile of the relative error over lit
//! surface pixels (`cargo test --release --test integration
//! ltc::many_lights_image -- --nocapture`).

use super::image_accuracy::{MEDIAN_GOAL, P95_GOAL, REFERENCE_TOL, lit_errors};
use crate::support::load;
use crate::support::ltc::{quantile, reference};
use glam::Vec3;
use penumbra::embree::{self, Device};
use penumbra::render::estimate::surface_point;
use penumbra::render::{Frame, Mode, PixelKind, RenderSettings, World};

// Held to the single-light images' goals (`image_accuracy`); culling may
// take up to the shipped 2 % tolerance on top of the LTC's own error.
const WIDTH: u32 = 48;
const HEIGHT: u32 = 27;

#[test]
fn the_halls_u_with_every_light_is_within_goal() {
    let scene = load("hall.toml");
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let settings = RenderSettings {
        mode: Mode::Unshadowed,
        taa: false,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(WIDTH, HEIGHT);
    pool.install(|| frame.render(&world, &scene.camera, &settings));
    let mut want = vec![Vec3::ZERO; frame.u.len()];
    for (k, g) in frame.gbuf.iter().enumerate() {
        if g.kind != PixelKind::Surface {
            continue;
        }
        let sp = surface_point(g);
        for light in &scene.lights {
            let (d, s) = reference(&sp, light, REFERENCE_TOL).lobes(&sp, light);
            want[k] += d + s;
        }
    }
    assert!(frame.u.iter().all(|u| u.is_finite()), "a non-finite U");
    let mut errors = lit_errors(&frame.u, &want);
    assert!(
        errors.len() as u32 > WIDTH * HEIGHT / 4,
        "{} lit pixels",
        errors.len()
    );
    let median = quantile(&mut errors, 0.5);
    let p95 = quantile(&mut errors, 0.95);
    println!(
        "hall, 24 lights: median {:.2} %, p95 {:.2} % ({} lit)",
        100.0 * median,
        100.0 * p95,
        errors.len()
    );
    assert!(median <= MEDIAN_GOAL, "median {median}");
    assert!(p95 <= P95_GOAL, "p95 {p95}");
}

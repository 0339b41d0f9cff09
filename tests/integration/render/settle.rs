//! Under a still camera, tiles whose visibility has settled draw no shadow
//! rays (`RenderSettings::settle`), and the frame stays what sampling every
//! tile gives; a moving camera samples every tile.

use crate::support::load;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, PhaseTimes, RenderSettings, World};
use penumbra::scene::Camera;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 90;
/// Frames rendered: past the 8 frames of history a tile needs to settle,
/// and past a refresh of every settled tile (one frame in 8).
const FRAMES: usize = 24;
/// The share of the rays the last 8 frames trace once room's tiles settle:
/// measured 0.76 at this size (8x8 tiles whose 8 neighbours are uniform
/// too are few in a small frame; about 0.5 at 1280x720).
const MAX_SETTLED_RAY_SHARE: f64 = 0.85;
/// How far the settled frame may drift from the every-tile frame (relMSE):
/// a settled tile keeps an exact 0 or 1, as sampling it would, unless a
/// sample it skipped would have unsettled it. Measured 0 here.
const MAX_SETTLED_REL_MSE: f64 = 1e-6;

fn run(settle: bool, cameras: &[Camera]) -> (Frame, Vec<PhaseTimes>) {
    let scene = load("room.toml");
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let settings = RenderSettings {
        settle,
        seed: 2,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(WIDTH, HEIGHT);
    let times = pool.install(|| {
        cameras
            .iter()
            .map(|c| frame.render(&world, c, &settings))
            .collect()
    });
    (frame, times)
}

fn rays(times: &[PhaseTimes]) -> u64 {
    times[FRAMES - 8..].iter().map(|t| t.shadow_rays).sum()
}

#[test]
fn under_a_still_camera_settled_tiles_trace_fewer_shadow_rays() {
    let camera = load("room.toml").camera;
    let (_, every) = run(false, &[camera; FRAMES]);
    let (_, settled) = run(true, &[camera; FRAMES]);
    let share = rays(&settled) as f64 / rays(&every) as f64;
    assert!(
        share < MAX_SETTLED_RAY_SHARE,
        "the last 8 frames traced {share:.2} of the rays"
    );
}

#[test]
fn a_settled_frame_stays_what_sampling_every_tile_gives() {
    let camera = load("room.toml").camera;
    let (every, _) = run(false, &[camera; FRAMES]);
    let (settled, _) = run(true, &[camera; FRAMES]);
    let e = crate::support::rel_mse(&settled, &every);
    assert!(
        e <= MAX_SETTLED_REL_MSE,
        "relMSE {e:.3e} against every tile"
    );
}

#[test]
fn a_moving_camera_samples_every_tile() {
    let camera = load("room.toml").camera;
    let orbit: Vec<Camera> = (0..FRAMES).map(|k| camera.orbit(0.5 * k as f32)).collect();
    let (_, every) = run(false, &orbit);
    let (_, settled) = run(true, &orbit);
    assert_eq!(rays(&settled), rays(&every));
}

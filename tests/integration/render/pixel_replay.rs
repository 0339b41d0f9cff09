//! The pixel replay explains a pixel exactly: the samples it lists, summed,
//! are the frame's own undenoised `U_N` and `S_N` at that pixel, bit for bit.

use crate::support::load;
use glam::Vec3;
use penumbra::embree::{self, Device};
use penumbra::render::replay::replay_pixel;
use penumbra::render::{Frame, Mode, PixelKind, RenderSettings, World};

const WIDTH: u32 = 48;
const HEIGHT: u32 = 27;
/// Several frames, so the replayed samples are not the sequence's first.
const FRAMES: u32 = 3;
const SPP: u32 = 3;

fn check_every_pixel(scene_name: &str, mode: Mode) {
    let scene = load(scene_name);
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let settings = RenderSettings {
        mode,
        spp: SPP,
        seed: 5,
        denoise: false,
        taa: false,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(WIDTH, HEIGHT);
    pool.install(|| {
        for _ in 0..FRAMES {
            frame.render(&world, &scene.camera, &settings);
        }
    });
    let (mut surfaces, mut traced) = (0u32, 0usize);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let k = (y * WIDTH + x) as usize;
            let r = replay_pixel(&world, &frame, &settings, x, y).expect("replays");
            if frame.gbuf[k].kind != PixelKind::Surface {
                // Lights and misses draw no samples.
                assert!(r.draws.is_empty(), "({x}, {y}) is no receiver");
                assert_eq!(frame.un[k], Vec3::ZERO, "U_N off surfaces at ({x}, {y})");
                continue;
            }
            let [d] = r.draws.as_slice() else {
                panic!(
                    "{scene_name} {mode}: ({x}, {y}) drew {} sets",
                    r.draws.len()
                );
            };
            assert_eq!(d.un, frame.un[k], "{scene_name} {mode}: U_N at ({x}, {y})");
            assert_eq!(d.sn, frame.sn[k], "{scene_name} {mode}: S_N at ({x}, {y})");
            surfaces += 1;
            assert_eq!(d.samples.len() as u32, SPP, "({x}, {y}): samples listed");
            traced += d.visible.iter().flatten().count();
        }
    }
    // The scenes' receivers fill a fair part of the frame.
    assert!(
        surfaces * 8 > WIDTH * HEIGHT,
        "{scene_name}: only {surfaces} surface pixels"
    );
    assert!(
        traced > surfaces as usize,
        "{scene_name}: only {traced} shadow rays"
    );
}

#[test]
fn the_replayed_samples_sum_to_the_frames_own_estimates_on_room() {
    check_every_pixel("room.toml", Mode::Ratio);
}

#[test]
fn the_replayed_samples_sum_to_the_frames_own_estimates_in_soft_shadow() {
    check_every_pixel("shadow-plane.toml", Mode::SoftShadow);
}

#[test]
fn a_pixel_outside_the_frame_is_refused() {
    let scene = load("shadow-plane.toml");
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let mut frame = Frame::new(8, 8);
    let settings = RenderSettings::default();
    frame.render(&world, &scene.camera, &settings);
    let e = replay_pixel(&world, &frame, &settings, 8, 0)
        .err()
        .expect("refused");
    assert!(e.contains("outside the 8x8 frame"), "{e}");
}

//! The temporal resolve under a still camera: jittered frames average each
//! pixel's area, the box filter `reference` uses (TAA).

use crate::support::{interior, load};
use glam::Vec3;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, RenderSettings, World};
use penumbra::report::stats::{rel_mse, rel_mse_masked};

/// `unshadowed` (noise-free `U`) after 1, 4 and 16 still frames with TAA,
/// against the box-filtered `U` of each pixel: `U` at 8x8 sub-pixel centres
/// (an unjittered render at 8x the size, averaged over 8x8 blocks).
#[test]
fn a_still_cameras_resolve_converges_to_the_box_filtered_pixel() {
    let scene = load("room.toml");
    let (w, h) = (160u32, 90u32);
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let settings = |taa| RenderSettings {
        mode: Mode::Unshadowed,
        taa,
        ..RenderSettings::default()
    };
    let boxed = crate::support::box_filtered_u(&world, &pool, &scene.camera, (w, h), 8);
    let mut frame = Frame::new(w, h);
    let (mut errors, mut whole) = (Vec::new(), Vec::new());
    let mut inside = Vec::new();
    for k in 1..=16 {
        pool.install(|| frame.render(&world, &scene.camera, &settings(true)));
        if k == 1 {
            inside = interior(&frame);
        }
        if [1, 4, 16].contains(&k) {
            errors.push(rel_mse_masked(&frame.color, &boxed, &inside));
            whole.push(rel_mse(&frame.color, &boxed));
        }
    }
    // Printed, not asserted: over the whole frame the few pixels on the
    // edges of the lights (radiance ~20x the surfaces') dominate, and 4
    // point samples of such an edge are far from its 64-sample coverage.
    println!(
        "room 160x90, unshadowed with TAA vs box-filtered U (8x8): relMSE after 1 / 4 / 16 frames, interior {:.3e} / {:.3e} / {:.3e}; whole frame {:.3e} / {:.3e} / {:.3e}",
        errors[0], errors[1], errors[2], whole[0], whole[1], whole[2]
    );
    // Frame 1 is the pixel centre; every later aligned block of 2^m frames
    // is a (0,m,2)-net over the pixel.
    assert!(errors[1] < 0.5 * errors[0], "4 frames: {errors:?}");
    assert!(errors[2] < 0.25 * errors[0], "16 frames: {errors:?}");
}

/// A still camera averages with weights 1/n: the resolve after n frames is
/// the mean of the n frames it was given (undenoised `stochastic`, whose
/// frame k is its own `emission + S_N`, read back from the buffers).
#[test]
fn a_still_cameras_resolve_is_the_plain_mean_of_its_frames() {
    let scene = load("shadow-plane.toml");
    let (w, h) = (64u32, 36u32);
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let settings = RenderSettings {
        mode: Mode::Stochastic,
        denoise: false,
        taa: true,
        ..RenderSettings::default()
    };
    let mut frame = Frame::new(w, h);
    let mut sum = vec![Vec3::ZERO; (w * h) as usize];
    for k in 1..=8 {
        pool.install(|| frame.render(&world, &scene.camera, &settings));
        // Undenoised stochastic: this frame's own estimate is emission + S_N.
        for (i, g) in frame.gbuf.iter().enumerate() {
            sum[i] += g.emission + frame.sn[i];
        }
        for (i, c) in frame.color.iter().enumerate() {
            let mean = sum[i] / k as f32;
            assert!(
                (*c - mean).abs().max_element() <= 1e-5 * mean.max_element().max(1.0),
                "frame {k}, pixel {i}: {c} vs mean {mean}"
            );
        }
    }
}

/// The per-frame jitter: frame 0 is the pixel centre, and the first 16
/// frames put one point in each cell of the pixel's 4x4 grid, near its
/// middle, so their mean is the pixel centre up to frame 0's 1/32 shift.
#[test]
fn the_first_16_jitters_start_at_the_centre_and_fill_a_4x4_grid() {
    use penumbra::sampling::sequence::frame_jitter;
    assert_eq!(frame_jitter(0), glam::Vec2::splat(0.5));
    let mut cells = [0u32; 16];
    let mut mean = glam::Vec2::ZERO;
    for k in 0..16 {
        let p = frame_jitter(k);
        assert!(p.min_element() >= 0.0 && p.max_element() < 1.0, "{p}");
        cells[(p.y * 4.0) as usize * 4 + (p.x * 4.0) as usize] += 1;
        mean += p / 16.0;
    }
    assert_eq!(cells, [1; 16]);
    assert!(
        (mean - glam::Vec2::splat(0.5)).abs().max_element() <= 1.0 / 512.0 + 1e-6,
        "{mean}"
    );
}

/// A still camera's resolve never rejects its history, so a light edit must
/// drop it: after the scene's lights go dark, the very next frame is black
/// (no trace of the old light in `U`'s resolve or the denoiser's history).
#[test]
fn a_light_edit_under_a_still_camera_leaves_no_trace_of_the_old_light() {
    let scene = load("shadow-plane.toml");
    let (w, h) = (64u32, 36u32);
    let device = Device::new().expect("Embree starts");
    let pool = embree::thread_pool(2).expect("thread pool");
    let settings = RenderSettings {
        mode: Mode::Ratio,
        taa: true,
        ..RenderSettings::default()
    };
    let lit = World::build(&device, scene.clone()).expect("scene builds");
    let mut frame = Frame::new(w, h);
    for _ in 0..6 {
        pool.install(|| frame.render(&lit, &scene.camera, &settings));
    }
    assert!(frame.color.iter().any(|c| c.max_element() > 0.0));
    let mut dark_scene = scene.clone();
    for light in &mut dark_scene.lights {
        light.radiance = Vec3::ZERO;
    }
    let dark = World::build(&device, dark_scene).expect("scene builds");
    pool.install(|| frame.render(&dark, &scene.camera, &settings));
    let bright = frame.color.iter().filter(|c| **c != Vec3::ZERO).count();
    assert_eq!(bright, 0, "pixels still lit after the lights went dark");
}

//! Frames rendered below the output's size and upscaled to it
//! (`render::upscaled`): a still camera's frames converge towards the
//! output's box-filtered pixels, far below what stretching the small frame
//! gives; no NaN at any scale or mode; the same bytes at any thread count;
//! no trace of an old view a few frames after the camera moves.

use crate::support::{Job, load, render};
use glam::Vec3;
use penumbra::embree::{self, Device};
use penumbra::render::{Frame, Mode, RenderSettings, Upscaled, World, scaled_size};
use penumbra::report::stats::{interior, rel_mse, rel_mse_masked};
use penumbra::scene::{Camera, Scene};

const WIDTH: u32 = 160;
const HEIGHT: u32 = 90;
const SCALE: f32 = 0.5;

/// The output after each of `cameras`, rendered at `scale`.
fn upscaled_frames(
    scene: &Scene,
    settings: &RenderSettings,
    threads: usize,
    scale: f32,
    cameras: &[Camera],
) -> Vec<Vec<Vec3>> {
    upscaled_frames_at(scene, settings, threads, (WIDTH, HEIGHT), scale, cameras)
}

/// [`upscaled_frames`] for an output of another size.
fn upscaled_frames_at(
    scene: &Scene,
    settings: &RenderSettings,
    threads: usize,
    (width, height): (u32, u32),
    scale: f32,
    cameras: &[Camera],
) -> Vec<Vec<Vec3>> {
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(threads).expect("thread pool");
    let (rw, rh) = scaled_size(width, height, scale);
    let mut frame = Frame::new(rw, rh);
    let mut out = Upscaled::new(width, height);
    pool.install(|| {
        cameras
            .iter()
            .map(|cam| {
                out.render(&mut frame, &world, cam, settings);
                out.color.clone()
            })
            .collect()
    })
}

/// The `reference` of `camera` at `size` with `spp` samples per pixel (in
/// frames of 8), rendered by the shared `support::render`.
fn reference_frame(scene: &Scene, camera: Camera, (width, height): (u32, u32), spp: u32) -> Frame {
    let scene = Scene {
        camera,
        ..scene.clone()
    };
    render(
        &scene,
        &Job {
            width,
            height,
            mode: Mode::Reference,
            spp: 8,
            frames: spp / 8,
            threads: 2,
            seed: 0x5eed,
            denoise: false,
        },
    )
}

fn unshadowed(taa: bool) -> RenderSettings {
    RenderSettings {
        mode: Mode::Unshadowed,
        taa,
        ..RenderSettings::default()
    }
}

/// After 16 still frames at half the size, the upscaled `U` is within this
/// fraction of the error (against the output's box-filtered `U`) that the
/// half-size frame stretched to the output (what a window does) has.
const UPSCALE_VS_STRETCH: f64 = 0.5;

#[test]
fn a_still_cameras_upscaled_frames_approach_the_box_filtered_output() {
    let scene = load("room.toml");
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let boxed = crate::support::box_filtered_u(&world, &pool, &scene.camera, (WIDTH, HEIGHT), 8);
    let mut full = Frame::new(WIDTH, HEIGHT);
    pool.install(|| full.render(&world, &scene.camera, &unshadowed(false)));
    let inside = interior(WIDTH, HEIGHT, &full.gbuf);

    let (rw, rh) = scaled_size(WIDTH, HEIGHT, SCALE);
    let mut small = Frame::new(rw, rh);
    pool.install(|| small.render(&world, &scene.camera, &unshadowed(false)));
    let stretched: Vec<Vec3> = (0..WIDTH * HEIGHT)
        .map(|k| {
            let (x, y) = (k % WIDTH * rw / WIDTH, k / WIDTH * rh / HEIGHT);
            small.color[(y * rw + x) as usize]
        })
        .collect();

    let frames = upscaled_frames(&scene, &unshadowed(true), 2, SCALE, &[scene.camera; 16]);
    let e = |c: &[Vec3]| rel_mse_masked(c, &boxed, &inside);
    let (e_stretch, e1, e16) = (e(&stretched), e(&frames[0]), e(&frames[15]));
    let e_full = e(&full.color);
    println!(
        "room {WIDTH}x{HEIGHT} from {rw}x{rh}, unshadowed vs box-filtered U, interior relMSE: \
         stretched {e_stretch:.3e}, upscaled after 1 frame {e1:.3e}, after 16 {e16:.3e}; \
         one unjittered frame at full size {e_full:.3e}; whole frame after 16 {:.3e}",
        rel_mse(&frames[15], &boxed)
    );
    assert!(
        e16 <= UPSCALE_VS_STRETCH * e_stretch,
        "after 16 frames {e16:.3e}, stretched {e_stretch:.3e}"
    );
    assert!(e16 < e1, "16 frames {e16:.3e} vs the first {e1:.3e}");
}

#[test]
fn upscaled_frames_are_the_same_bytes_at_any_thread_count() {
    let scene = load("room.toml");
    let settings = RenderSettings::default();
    let path: Vec<Camera> = [0.0, 1.5, 3.0, 3.0]
        .iter()
        .map(|d| scene.camera.orbit(*d))
        .collect();
    let one = upscaled_frames(&scene, &settings, 1, SCALE, &path);
    let two = upscaled_frames(&scene, &settings, 2, SCALE, &path);
    assert!(one == two, "1 and 2 threads differ");
}

#[test]
fn no_upscaled_pixel_is_ever_non_finite() {
    let scene = load("room.toml");
    let path: Vec<Camera> = [0.0, 4.0, 4.0]
        .iter()
        .map(|d| scene.camera.orbit(*d))
        .collect();
    for mode in Mode::ALL {
        for scale in [0.25, 0.6, 1.0] {
            for taa in [true, false] {
                let settings = RenderSettings {
                    mode,
                    taa,
                    ..RenderSettings::default()
                };
                for c in upscaled_frames(&scene, &settings, 2, scale, &path) {
                    assert!(
                        c.iter().all(|v| v.is_finite()),
                        "{mode}, scale {scale}, taa {taa}: a non-finite pixel"
                    );
                }
            }
        }
    }
}

/// After a cut from another view, the upscaled frames at the new view
/// approach an upscale that started there: `GHOST_FRAMES` frames after the
/// move the error against a long still upscale is within `GHOST_FACTOR` of
/// what a fresh start of as many frames has.
const GHOST_FRAMES: usize = 4;
const GHOST_FACTOR: f64 = 1.5;
const CONVERGED_FRAMES: usize = 32;

#[test]
fn a_camera_move_leaves_no_ghost_in_the_upscaled_output_beyond_a_few_frames() {
    let scene = load("room.toml");
    let before = scene.camera.orbit(-25.0);
    let after = scene.camera;
    let s = RenderSettings::default();
    let truth = upscaled_frames(&scene, &s, 2, SCALE, &[after; CONVERGED_FRAMES])
        .pop()
        .expect("frames");
    let mut path = vec![before; 8];
    path.extend(std::iter::repeat_n(after, GHOST_FRAMES + 1));
    let moved = upscaled_frames(&scene, &s, 2, SCALE, &path);
    let fresh = upscaled_frames(&scene, &s, 2, SCALE, &[after; GHOST_FRAMES + 1]);
    let (e_moved, e_fresh) = (
        rel_mse(&moved[8 + GHOST_FRAMES], &truth),
        rel_mse(&fresh[GHOST_FRAMES], &truth),
    );
    assert!(
        e_moved <= GHOST_FACTOR * e_fresh,
        "{GHOST_FRAMES} frames after the move relMSE {e_moved:.3e}, a fresh start {e_fresh:.3e}"
    );
}

/// The default frame (denoised ratio) of a still camera, upscaled from
/// each of `SCALES`, against a reference of the full-size output: its
/// relMSE falls with frames, and after `CONVERGE_FRAMES` frames it is
/// within `CONVERGE_BOUND` of the full-size frames' after as many samples
/// per output pixel (`CONVERGE_FRAMES` times the scale squared frames).
/// What is left above 1 is what averaging the denoised ratio of the small
/// frame a second time costs (docs/interactive.md). Measured on the
/// interior pixels (away from silhouettes and the lights' own pixels, whose
/// few samples at a small scale are outliers of a different kind).
const SCALES: [f32; 2] = [0.5, 0.25];
const CONVERGE_FRAMES: usize = 64;
const CONVERGE_BOUND: f64 = 1.5;
const REFERENCE_SPP: u32 = 128;
/// The output: at a quarter scale the render is 80x45, a size the
/// denoiser still works at.
const CONVERGE_SIZE: (u32, u32) = (320, 180);

#[test]
fn a_still_cameras_upscaled_default_frames_converge_towards_the_full_size_reference() {
    let scene = load("room.toml");
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let (w, h) = CONVERGE_SIZE;
    let reference = reference_frame(&scene, scene.camera, CONVERGE_SIZE, REFERENCE_SPP);
    let truth = reference.color;
    let inside = interior(w, h, &reference.gbuf);
    let settings = RenderSettings::default();
    let mut full = Frame::new(w, h);
    let full_errors: Vec<f64> = pool.install(|| {
        (0..CONVERGE_FRAMES)
            .map(|_| {
                full.render(&world, &scene.camera, &settings);
                rel_mse_masked(&full.color, &truth, &inside)
            })
            .collect()
    });
    let checkpoints = [1, 4, 16, CONVERGE_FRAMES];
    for scale in SCALES {
        let frames = upscaled_frames_at(
            &scene,
            &settings,
            2,
            CONVERGE_SIZE,
            scale,
            &[scene.camera; CONVERGE_FRAMES],
        );
        let e: Vec<f64> = checkpoints
            .iter()
            .map(|&k| rel_mse_masked(&frames[k - 1], &truth, &inside))
            .collect();
        let shown: Vec<String> = e.iter().map(|x| format!("{x:.3e}")).collect();
        let same_samples = ((CONVERGE_FRAMES as f32 * scale * scale).round() as usize).max(1);
        let e_full = full_errors[same_samples - 1];
        println!(
            "room {w}x{h}, default frame upscaled from scale {scale}, interior relMSE \
             against \
             {REFERENCE_SPP} spp after {checkpoints:?} frames: {shown:?}; full size after \
             {same_samples} frames (as many samples): {e_full:.3e}, after {CONVERGE_FRAMES}: \
             {:.3e}",
            full_errors[CONVERGE_FRAMES - 1]
        );
        for w in e.windows(2) {
            assert!(w[1] < w[0], "scale {scale}: relMSE rose {shown:?}");
        }
        let last = e[e.len() - 1];
        assert!(
            last <= CONVERGE_BOUND * e_full,
            "scale {scale}: after {CONVERGE_FRAMES} frames {last:.3e}, full size after \
             {same_samples} {e_full:.3e}"
        );
    }
}

/// Under a turning camera at a quarter scale, the lights' rims are the
/// output's, not the render's: after `TURN_FRAMES` frames of one degree
/// each, the upscaled frame's relMSE over every pixel against a reference
/// of the last camera is within `TURN_BOUND` of the full-size frame's on
/// the same path. (Without the output-resolution rays at the rims, a
/// light spills up to two output pixels onto the wall beside it, at
/// hundreds of times the wall's radiance, and the ratio is in the
/// hundreds: docs/interactive.md.)
const TURN_FRAMES: usize = 12;
const TURN_BOUND: f64 = 4.0;
const TURN_SIZE: (u32, u32) = (320, 180);
const TURN_REFERENCE_SPP: u32 = 32;

#[test]
fn under_a_turning_camera_no_light_spills_past_its_rim_in_the_upscaled_output() {
    let scene = load("room.toml");
    let device = Device::new().expect("Embree starts");
    let world = World::build(&device, scene.clone()).expect("scene builds");
    let pool = embree::thread_pool(2).expect("thread pool");
    let (w, h) = TURN_SIZE;
    let path: Vec<Camera> = (0..TURN_FRAMES)
        .map(|k| scene.camera.orbit(k as f32))
        .collect();
    let last = path[TURN_FRAMES - 1];
    let reference = reference_frame(&scene, last, TURN_SIZE, TURN_REFERENCE_SPP);
    let settings = RenderSettings::default();
    let mut full = Frame::new(w, h);
    pool.install(|| {
        for cam in &path {
            full.render(&world, cam, &settings);
        }
    });
    let e_full = rel_mse(&full.color, &reference.color);
    let quarter = upscaled_frames_at(&scene, &settings, 2, TURN_SIZE, 0.25, &path)
        .pop()
        .expect("frames");
    let e_quarter = rel_mse(&quarter, &reference.color);
    println!(
        "room {w}x{h}, {TURN_FRAMES} frames turning 1 degree each, relMSE against \
         {TURN_REFERENCE_SPP} spp: full size {e_full:.3e}, upscaled from a quarter \
         {e_quarter:.3e} ({:.2}x)",
        e_quarter / e_full
    );
    assert!(
        e_quarter <= TURN_BOUND * e_full,
        "upscaled from a quarter {e_quarter:.3e}, full size {e_full:.3e}"
    );
}

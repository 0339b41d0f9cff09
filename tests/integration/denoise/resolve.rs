//! The temporal resolve under a still camera: jittered frames average each
//! pixel's area, the box filter `reference` uses (TAA). Under a moving
//! camera it may take its taps from the denoiser's reprojection.

use crate::support::denoise::{self as synthetic, Rng, Surface};
use crate::support::{interior, load};
use glam::{Vec2, Vec3};
use penumbra::denoise::{CameraMotion, DenoiseSettings, Denoiser, Resolve, ResolveSettings};
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

/// Two synthetic frames for the moving resolve: a back plane with a nearer
/// one over its left part that slides right between them (a disocclusion
/// along its edge), a motion of a fraction of a pixel (every pixel reads
/// four taps), and the light tripled in the top right corner of the second
/// frame (history dropped there by the light test).
fn sliding_planes(w: u32, h: u32) -> (synthetic::Frame, synthetic::Frame) {
    let near = |edge: u32| {
        move |x: u32, _| {
            if x < edge {
                Surface::Back(2.0)
            } else {
                Surface::Back(4.0)
            }
        }
    };
    let first = synthetic::Frame::new(w, h, near(w / 3));
    let mut second = synthetic::Frame::new(w, h, near(w / 3 + 3));
    let shift = Vec2::new(-2.3, 1.6);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            second.prev_pixel[i] = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + shift;
            if x > 3 * w / 4 && y < h / 4 {
                second.u[i] = Vec3::splat(3.0);
            }
        }
    }
    (first, second)
}

/// The denoiser keeps which taps each pixel passed only when asked to.
#[test]
fn the_denoiser_keeps_its_taps_only_when_asked() {
    let (w, h) = (24u32, 16u32);
    let (first, _) = sliding_planes(w, h);
    let n = first.n();
    let mut d = Denoiser::new(w, h);
    let (mut un, mut sn) = (vec![Vec3::ONE; n], vec![Vec3::splat(0.5); n]);
    d.denoise(
        &first.guide(),
        &mut un,
        &mut sn,
        &DenoiseSettings::default(),
    );
    assert!(d.taps().is_none());
    d.keep_taps(true);
    d.denoise(
        &first.guide(),
        &mut un,
        &mut sn,
        &DenoiseSettings::default(),
    );
    assert_eq!(d.taps().map(<[u8]>::len), Some(n));
}

/// A moving camera's resolve that takes each pixel's taps from the
/// denoiser's reprojection (`Denoiser::taps`) writes the same bits as one
/// that tests its own history: both histories hold the same surfaces, so
/// their taps pass and fail alike. The frames have pixels whose four taps
/// all pass, some pass, and none pass.
#[test]
fn a_moving_resolve_on_the_denoisers_taps_gives_the_bits_of_its_own_tests() {
    let (w, h) = (48u32, 32u32);
    let (first, second) = sliding_planes(w, h);
    let n = first.n();
    let mut rng = Rng::new(7);
    let mut signal = || -> Vec<Vec3> {
        (0..n)
            .map(|_| Vec3::new(rng.f32(), rng.f32(), rng.f32()))
            .collect()
    };
    let inputs = [
        (signal(), signal(), signal(), signal()),
        (signal(), signal(), signal(), signal()),
    ];
    let mut d = Denoiser::new(w, h);
    d.keep_taps(true);
    let (mut own, mut reused) = (Resolve::new(w, h), Resolve::new(w, h));
    let mut taps = Vec::new();
    let mut out = Vec::new();
    for (k, (frame, (un, sn, factor, color))) in
        [&first, &second].into_iter().zip(&inputs).enumerate()
    {
        let guide = frame.guide();
        let (mut un, mut sn) = (un.clone(), sn.clone());
        d.denoise(&guide, &mut un, &mut sn, &DenoiseSettings::default());
        taps = d.taps().expect("taps kept").to_vec();
        let motion = if k == 0 {
            CameraMotion::Still
        } else {
            CameraMotion::Moved
        };
        out.clear();
        for (resolve, given) in [(&mut own, None), (&mut reused, Some(&taps[..]))] {
            let (mut f, mut c) = (factor.clone(), color.clone());
            let s = (&ResolveSettings::default(), &DenoiseSettings::default());
            resolve.resolve(&guide, (&mut f, &mut c), motion, s.0, s.1, given);
            out.push((f, c));
        }
        let bits = |v: &[Vec3]| {
            v.iter()
                .flat_map(|c| c.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&out[0].0), bits(&out[1].0), "factor, frame {k}");
        assert_eq!(bits(&out[0].1), bits(&out[1].1), "colour, frame {k}");
        assert_eq!(
            own.history_len(),
            reused.history_len(),
            "lengths, frame {k}"
        );
        assert_eq!(own.mixed(), reused.mixed(), "mixed, frame {k}");
    }
    let passed = |m: u32| taps.iter().filter(|&&t| t.count_ones() == m).count();
    assert!(
        passed(4) > 0 && passed(0) > 0,
        "all / none: {} / {}",
        passed(4),
        passed(0)
    );
    assert!(
        (1..4).map(passed).sum::<usize>() > 0,
        "no pixel with some of its taps"
    );
}

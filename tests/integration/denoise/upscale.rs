//! The temporal upscale on synthetic frames: what it keeps exactly, what it
//! never lets through, and what it does with its history.

use crate::support::denoise::Frame;
use glam::{Vec2, Vec3};
use penumbra::denoise::{CameraMotion, DenoiseSettings, ResolveSettings, Upscale};

const CENTRE: Vec2 = Vec2::splat(0.5);

fn run(
    up: &mut Upscale,
    f: &Frame,
    color: &[Vec3],
    jitter: Vec2,
    motion: Option<CameraMotion>,
) -> Vec<Vec3> {
    let (w, h) = up.size();
    let mut out = vec![Vec3::splat(-1.0); (w * h) as usize];
    up.resolve(
        &f.guide(),
        color,
        jitter,
        motion,
        &ResolveSettings::default(),
        &DenoiseSettings::default(),
        &[],
        &mut out,
    );
    out
}

/// `n` still frames of the constant `value` at the pixel centres.
fn still_frames(up: &mut Upscale, f: &Frame, value: Vec3, n: usize) {
    for _ in 0..n {
        run(
            up,
            f,
            &vec![value; f.n()],
            CENTRE,
            Some(CameraMotion::Still),
        );
    }
}

/// A frame at pixel `(x, y)` of `w` columns: a distinct value per pixel.
fn ramp(w: u32, h: u32) -> Vec<Vec3> {
    (0..w * h)
        .map(|k| Vec3::new((k % w) as f32, (k / w) as f32, 1.0 + (k % 7) as f32))
        .collect()
}

#[test]
fn at_scale_one_an_unjittered_first_frame_passes_through_unchanged() {
    let f = Frame::plane(24, 16);
    let color = ramp(24, 16);
    let mut up = Upscale::new(24, 16);
    let out = run(&mut up, &f, &color, CENTRE, Some(CameraMotion::Still));
    assert_eq!(out, color);
}

/// Relative tolerance of a constant through normalised weights (rounding).
const CONSTANT_TOL: f32 = 1e-6;

#[test]
fn a_constant_frame_upscales_to_the_constant_at_every_scale_jitter_and_motion() {
    let c = Vec3::new(0.3, 1.7, 12.5);
    for (rw, rh) in [(12, 8), (17, 11), (24, 16), (7, 5)] {
        let f = Frame::plane(rw, rh);
        let color = vec![c; (rw * rh) as usize];
        let mut up = Upscale::new(24, 16);
        for (k, jitter) in [CENTRE, Vec2::new(0.1, 0.8), Vec2::new(0.95, 0.05)]
            .into_iter()
            .enumerate()
        {
            let motion = [CameraMotion::Still, CameraMotion::Moved][k % 2];
            for out in [
                run(&mut up, &f, &color, jitter, Some(motion)),
                run(&mut up, &f, &color, jitter, None),
            ] {
                for v in out {
                    assert!(
                        ((v - c).abs() / c).max_element() <= CONSTANT_TOL,
                        "{rw}x{rh}, jitter {jitter}: {v} for {c}"
                    );
                }
            }
        }
    }
}

#[test]
fn non_finite_or_negative_samples_never_reach_the_output() {
    let f = Frame::plane(12, 8);
    let mut color = ramp(12, 8);
    color[5] = Vec3::new(f32::NAN, 1.0, 1.0);
    color[20] = Vec3::splat(f32::INFINITY);
    color[40] = Vec3::splat(-3.0);
    let mut up = Upscale::new(24, 16);
    for (k, motion) in [
        CameraMotion::Still,
        CameraMotion::Moved,
        CameraMotion::Still,
    ]
    .into_iter()
    .enumerate()
    {
        let jitter = Vec2::new(0.2 + 0.3 * k as f32, 0.7 - 0.2 * k as f32);
        for v in run(&mut up, &f, &color, jitter, Some(motion)) {
            assert!(v.is_finite() && v.min_element() >= 0.0, "{v}");
        }
    }
    let bad = run(&mut up, &f, &color, Vec2::splat(f32::NAN), None);
    assert!(bad.iter().all(|v| v.is_finite()));
}

/// A still camera accumulates: frames alternating between 0 and 2 settle
/// near 1 everywhere, where each frame alone is 0 or 2.
const ALTERNATING_TOL: f32 = 0.15;

#[test]
fn a_still_camera_averages_its_jittered_frames() {
    let f = Frame::plane(12, 8);
    let mut up = Upscale::new(24, 16);
    let mut out = Vec::new();
    for k in 0..32 {
        let v = if k % 2 == 0 { 0.0 } else { 2.0 };
        let color = vec![Vec3::splat(v); 96];
        // Each jitter twice, once per value, so neither value owns a
        // part of the pixel.
        let j = k / 2;
        let jitter = Vec2::new(
            ((j * 5) % 8) as f32 / 8.0 + 0.0625,
            ((j * 3) % 8) as f32 / 8.0 + 0.0625,
        );
        out = run(&mut up, &f, &color, jitter, Some(CameraMotion::Still));
    }
    for v in out {
        assert!((v.x - 1.0).abs() <= ALTERNATING_TOL, "{v}");
    }
}

#[test]
fn a_moving_cameras_history_is_cut_back_to_the_current_neighbourhood() {
    let f = Frame::plane(12, 8);
    let mut up = Upscale::new(24, 16);
    still_frames(&mut up, &f, Vec3::ONE, 8);
    // The same surface (the guides reproject every pixel onto itself), but
    // the current frame is dark everywhere: no trace of the old light.
    let out = run(
        &mut up,
        &f,
        &vec![Vec3::ZERO; 96],
        CENTRE,
        Some(CameraMotion::Moved),
    );
    assert!(out.iter().all(|v| *v == Vec3::ZERO));
}

#[test]
fn a_disoccluded_pixel_drops_its_history() {
    let near = Frame::plane(12, 8);
    let mut up = Upscale::new(24, 16);
    still_frames(&mut up, &near, Vec3::ONE, 8);
    // A surface at another depth now: every tap fails the depth test, so
    // the output is the current frame alone, clamp or not.
    let far = Frame::new(12, 8, |_, _| crate::support::denoise::Surface::Back(9.0));
    let color = vec![Vec3::splat(0.25); 96];
    let settings = ResolveSettings {
        clamp: false,
        ..ResolveSettings::default()
    };
    let mut out = vec![Vec3::ZERO; 24 * 16];
    up.resolve(
        &far.guide(),
        &color,
        CENTRE,
        Some(CameraMotion::Moved),
        &settings,
        &DenoiseSettings::default(),
        &[],
        &mut out,
    );
    assert!(
        out.iter()
            .all(|v| (*v - Vec3::splat(0.25)).abs().max_element() < 1e-6)
    );
}

#[test]
fn no_averaging_asked_for_drops_the_history() {
    let f = Frame::plane(12, 8);
    let mut up = Upscale::new(24, 16);
    still_frames(&mut up, &f, Vec3::ONE, 4);
    let out = run(&mut up, &f, &vec![Vec3::splat(3.0); 96], CENTRE, None);
    assert!(
        out.iter()
            .all(|v| (*v - Vec3::splat(3.0)).abs().max_element() < 1e-5)
    );
    assert!(up.history_len().iter().all(|w| *w <= 1.0));
}

#[test]
fn a_new_render_size_keeps_the_output_history() {
    let mut up = Upscale::new(24, 16);
    // One sample in each of the four output pixels of a render pixel.
    for k in 0..8 {
        let jitter = Vec2::new([0.25, 0.75][k % 2], [0.25, 0.75][(k / 2) % 2]);
        run(
            &mut up,
            &Frame::plane(12, 8),
            &vec![Vec3::ONE; 96],
            jitter,
            Some(CameraMotion::Still),
        );
    }
    let before: f32 = up.history_len().iter().sum();
    let out = run(
        &mut up,
        &Frame::plane(16, 11),
        &vec![Vec3::splat(2.0); 176],
        CENTRE,
        Some(CameraMotion::Still),
    );
    let after: f32 = up.history_len().iter().sum();
    assert!(after > before, "history weight {before} -> {after}");
    // Blended, not replaced: between the old value and the new one (a
    // pixel no new sample came near keeps the old).
    assert!(
        out.iter().all(|v| v.x >= 1.0 && v.x < 2.0),
        "{:?}",
        &out[..4]
    );
    assert!(out.iter().any(|v| v.x > 1.0));
}

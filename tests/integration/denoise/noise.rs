//! The denoised ratio converges on a static penumbra far faster than the raw one.

use crate::support::denoise::{Frame, Rng, luminance_ratio, sample, soft_edge};
use penumbra::denoise::{DenoiseSettings, Denoiser};

const W: u32 = 128;
const H: u32 = 64;

/// Ratio RMSE after 16 static frames, denoised.
const DENOISED_MAX_RMSE: f32 = 0.03;
/// Raw ratio RMSE over the denoised one after 16 static frames.
const DENOISED_MIN_GAIN: f32 = 10.0;
/// Ratio RMSE of one frame, spatial filter only.
const SPATIAL_ONLY_MAX_RMSE: f32 = 0.12;
/// Raw ratio RMSE over the spatially filtered one, one frame.
const SPATIAL_ONLY_MIN_GAIN: f32 = 3.0;

fn true_ratio(i: usize) -> f32 {
    soft_edge((i % W as usize) as f32, 24.0, 104.0)
}

fn rmse(un: &[glam::Vec3], sn: &[glam::Vec3]) -> f32 {
    let n = un.len();
    let se: f32 = (0..n)
        .map(|i| (luminance_ratio(sn[i], un[i]) - true_ratio(i)).powi(2))
        .sum();
    (se / n as f32).sqrt()
}

/// Runs `frames` static frames; returns (raw RMSE of the last frame, denoised RMSE).
fn run(frames: usize, settings: &DenoiseSettings) -> (f32, f32) {
    let f = Frame::plane(W, H);
    let mut d = Denoiser::new(W, H);
    let mut rng = Rng::new(7);
    let (mut raw, mut out) = (0.0, 0.0);
    for _ in 0..frames {
        let (mut un, mut sn) = sample(&mut rng, f.n(), true_ratio);
        raw = rmse(&un, &sn);
        d.denoise(&f.guide(), &mut un, &mut sn, settings);
        out = rmse(&un, &sn);
    }
    (raw, out)
}

#[test]
fn sixteen_static_frames_cut_most_of_the_ratio_error() {
    let (raw, out) = run(16, &DenoiseSettings::default());
    eprintln!("raw ratio RMSE {raw:.4}, denoised after 16 frames {out:.4}");
    assert!(
        out < DENOISED_MAX_RMSE,
        "denoised RMSE {out} >= {DENOISED_MAX_RMSE} (raw {raw})"
    );
    assert!(
        raw > DENOISED_MIN_GAIN * out,
        "raw {raw} not {DENOISED_MIN_GAIN}x denoised {out}"
    );
}

#[test]
fn spatial_filter_alone_cuts_single_frame_error() {
    let s = DenoiseSettings {
        temporal: false,
        ..DenoiseSettings::default()
    };
    let (raw, out) = run(1, &s);
    eprintln!("raw ratio RMSE {raw:.4}, spatial only {out:.4}");
    assert!(
        out < SPATIAL_ONLY_MAX_RMSE,
        "spatial-only RMSE {out} >= {SPATIAL_ONLY_MAX_RMSE} (raw {raw})"
    );
    assert!(
        raw > SPATIAL_ONLY_MIN_GAIN * out,
        "raw {raw} not {SPATIAL_ONLY_MIN_GAIN}x spatial-only {out}"
    );
}

#[test]
fn temporal_accumulation_alone_averages_frames() {
    let s = DenoiseSettings {
        spatial: false,
        ..DenoiseSettings::default()
    };
    let (raw, out) = run(16, &s);
    eprintln!("raw ratio RMSE {raw:.4}, temporal only after 16 frames {out:.4}");
    // 16 Bernoulli frames: sqrt(p(1-p)/16) per pixel, about raw / 4.
    assert!(
        out < raw / 3.0,
        "temporal-only {out} not 3x under raw {raw}"
    );
}

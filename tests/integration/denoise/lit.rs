//! Where S_N == U_N throughout a neighbourhood the denoised ratio is exactly 1:
//! unshadowed regions come out as exactly U.

use crate::support::denoise::{Frame, Rng, sample, soft_edge};
use penumbra::denoise::{DenoiseSettings, Denoiser};

const W: u32 = 128;
const H: u32 = 64;

/// Lit for x < 48, a penumbra beyond.
fn truth(i: usize) -> f32 {
    1.0 - soft_edge((i % W as usize) as f32, 48.0, 112.0)
}

fn run(settings: &DenoiseSettings) {
    let f = Frame::plane(W, H);
    let mut d = Denoiser::new(W, H);
    let mut rng = Rng::new(9);
    // The largest footprint is radius 2^max_levels - 1 = 15 (default 4 levels).
    let radius = (1u32 << settings.max_levels.max(settings.min_levels)) - 1;
    for frame in 0..8 {
        let (mut un, mut sn) = sample(&mut rng, f.n(), truth);
        d.denoise(&f.guide(), &mut un, &mut sn, settings);
        let mut checked = 0;
        for i in 0..f.n() {
            if (i as u32 % W) + radius < 48 {
                assert_eq!(
                    un[i], sn[i],
                    "frame {frame} pixel {i}: lit pixel not exactly lit"
                );
                checked += 1;
            }
        }
        assert!(checked > 0);
    }
}

#[test]
fn lit_neighbourhood_keeps_ratio_exactly_one() {
    run(&DenoiseSettings::default());
}

#[test]
fn lit_neighbourhood_keeps_ratio_exactly_one_when_filtered() {
    // Forced levels: the lit pixels are filtered, and still come out exact
    // because both signals get the same weights over the same values.
    run(&DenoiseSettings {
        min_levels: 4,
        ..DenoiseSettings::default()
    });
}

//! Tile classification: fully lit or fully shadowed frames skip the spatial
//! filter, noisy frames do not.

use crate::support::denoise::{Frame, Rng, sample};
use glam::Vec3;
use penumbra::denoise::{DenoiseSettings, Denoiser};

const W: u32 = 100; // not a multiple of 8: partial tiles too
const H: u32 = 60;

#[test]
fn fully_lit_frame_skips_every_tile() {
    let f = Frame::plane(W, H);
    let mut rng = Rng::new(8);
    let mut d = Denoiser::new(W, H);
    for _ in 0..3 {
        let (mut un, mut sn) = sample(&mut rng, f.n(), |_| 1.0);
        let st = d.denoise(&f.guide(), &mut un, &mut sn, &DenoiseSettings::default());
        assert_eq!(st.tiles_total, 13 * 8);
        assert_eq!(st.tiles_skipped, st.tiles_total);
    }
}

#[test]
fn fully_shadowed_frame_skips_every_tile() {
    let f = Frame::plane(W, H);
    let mut rng = Rng::new(8);
    let mut d = Denoiser::new(W, H);
    let (mut un, mut sn) = sample(&mut rng, f.n(), |_| 0.0);
    let st = d.denoise(&f.guide(), &mut un, &mut sn, &DenoiseSettings::default());
    assert_eq!(st.tiles_skipped, st.tiles_total);
    assert!(sn.iter().all(|s| *s == Vec3::ZERO));
}

#[test]
fn penumbra_frame_filters_its_tiles() {
    let f = Frame::plane(W, H);
    let mut rng = Rng::new(8);
    let mut d = Denoiser::new(W, H);
    let (mut un, mut sn) = sample(&mut rng, f.n(), |_| 0.5);
    let st = d.denoise(&f.guide(), &mut un, &mut sn, &DenoiseSettings::default());
    assert_eq!(st.tiles_skipped, 0);
    assert!(st.levels > 0);
}

#[test]
fn penumbra_band_skips_only_far_tiles() {
    // Penumbra in tile columns 5..7 (x in 40..56): tile columns 4..8 are
    // filtered (the penumbra and its neighbours), the rest skipped.
    let f = Frame::plane(W, H);
    let mut rng = Rng::new(8);
    let mut d = Denoiser::new(W, H);
    let truth = |i: usize| {
        if (40..56).contains(&(i % W as usize)) {
            0.5
        } else {
            1.0
        }
    };
    let (mut un, mut sn) = sample(&mut rng, f.n(), truth);
    let st = d.denoise(&f.guide(), &mut un, &mut sn, &DenoiseSettings::default());
    assert_eq!(st.tiles_skipped, (13 - 4) * 8);
}

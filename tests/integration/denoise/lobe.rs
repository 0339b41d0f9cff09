//! The specular lobe guide: a sharp change of the ratio seen in a narrow
//! glossy lobe (a shadow reflected in a near-mirror) is not averaged away by
//! the spatial filter, while on a diffuse receiver the same step is.

use crate::support::denoise::{Frame, Rng, luminance_ratio, sample};
use glam::Vec3;
use penumbra::denoise::{DenoiseSettings, Denoiser, GuideBuffers, Lobe};

const W: u32 = 96;
const H: u32 = 48;
const SPLIT: u32 = 48;
const LEFT: f32 = 0.2;
const RIGHT: f32 = 0.8;
/// How far a side's mean ratio next to the step may move from its true
/// value before it counts as bled.
const MAX_BLEED: f32 = 0.05;

/// The ratio's own edge-stopping separates 0.2 from 0.8 by itself once the
/// history is long; switched off so the lobe term is tested alone.
fn lobe_only() -> DenoiseSettings {
    DenoiseSettings {
        sigma_ratio: 1e6,
        ..DenoiseSettings::default()
    }
}

/// Lobes of the screen-filling plane (normal towards the eye at the origin)
/// with GGX width `alpha` and specular share `share`.
fn lobes(f: &Frame, alpha: f32, share: f32) -> Vec<Lobe> {
    f.pos
        .iter()
        .map(|p| Lobe::new(Vec3::Z, -p.normalize(), alpha, share))
        .collect()
}

/// Mean denoised ratio of the 3 columns on each side of the step after 16
/// static frames.
fn border_means(f: &Frame, lobe: &[Lobe]) -> (f32, f32) {
    let guide = GuideBuffers { lobe, ..f.guide() };
    let mut d = Denoiser::new(W, H);
    let mut rng = Rng::new(5);
    let truth = |i: usize| if (i as u32 % W) < SPLIT { LEFT } else { RIGHT };
    let (mut un, mut sn) = (Vec::new(), Vec::new());
    for _ in 0..16 {
        (un, sn) = sample(&mut rng, f.n(), truth);
        d.denoise(&guide, &mut un, &mut sn, &lobe_only());
    }
    let mean = |cols: std::ops::Range<u32>| {
        let (mut s, mut n) = (0.0, 0.0);
        for y in 0..H {
            for x in cols.clone() {
                let i = (y * W + x) as usize;
                s += luminance_ratio(sn[i], un[i]);
                n += 1.0;
            }
        }
        s / n
    };
    (mean(SPLIT - 3..SPLIT), mean(SPLIT..SPLIT + 3))
}

#[test]
fn a_ratio_step_seen_in_a_near_mirror_stays_sharp() {
    let f = Frame::plane(W, H);
    let (l, r) = border_means(&f, &lobes(&f, 0.003, 0.95));
    eprintln!("near-mirror: left {l:.3} (true {LEFT}), right {r:.3} (true {RIGHT})");
    assert!((l - LEFT).abs() < MAX_BLEED, "left side {l} bled");
    assert!((r - RIGHT).abs() < MAX_BLEED, "right side {r} bled");
}

#[test]
fn the_same_step_on_a_diffuse_receiver_is_blurred() {
    // The control: without a specular share the lobe term must not act,
    // and these settings do blur the step.
    let f = Frame::plane(W, H);
    let (l, r) = border_means(&f, &lobes(&f, 0.003, 0.0));
    eprintln!("diffuse: left {l:.3}, right {r:.3}");
    assert!(
        (l - LEFT).abs() > MAX_BLEED || (r - RIGHT).abs() > MAX_BLEED,
        "no blur without the lobe either; the near-mirror test proves nothing"
    );
}

#[test]
fn a_lobe_without_specular_share_constrains_nothing() {
    let lobe = Lobe::new(Vec3::Z, Vec3::new(0.3, 0.0, 1.0).normalize(), 0.01, 0.0);
    assert_eq!(lobe.sharpness, 0.0);
    let other = Lobe::new(Vec3::Z, Vec3::new(-0.3, 0.0, 1.0).normalize(), 0.01, 1.0);
    assert_eq!(lobe.separation2(&other), 0.0);
}

#[test]
fn a_narrower_lobe_separates_the_same_directions_more() {
    let wo = |x: f32| Vec3::new(x, 0.0, 1.0).normalize();
    let wide = Lobe::new(Vec3::Z, wo(0.0), 0.3, 1.0);
    let narrow = Lobe::new(Vec3::Z, wo(0.0), 0.03, 1.0);
    let tap = Lobe::new(Vec3::Z, wo(0.01), 0.3, 1.0);
    assert!(narrow.separation2(&tap) > 50.0 * wide.separation2(&tap));
}

#[test]
fn bad_inputs_give_a_finite_lobe() {
    for lobe in [
        Lobe::new(Vec3::Z, Vec3::Z, 0.0, f32::NAN),
        Lobe::new(Vec3::ZERO, Vec3::Z, 0.0, 1.0),
        Lobe::new(Vec3::Z, Vec3::Z, f32::NAN, 1.0),
    ] {
        assert!(
            lobe.dir.is_finite() && lobe.sharpness.is_finite(),
            "{lobe:?}"
        );
    }
}

/// On a near-mirror the lobe guide keeps every spatial neighbour out, so a
/// pixel's own ratio stands, unless its samples carry almost none of `U`
/// (a light sample far off the lobe: positive but negligible weight): then
/// its 0-or-1 ratio says nothing about the lobe, and the neighbours decide.
#[test]
fn on_a_near_mirror_a_pixel_whose_samples_carry_no_weight_takes_its_neighbours_ratio() {
    let f = Frame::plane(W, H);
    let lobe = lobes(&f, 0.0025, 1.0);
    let guide = GuideBuffers {
        lobe: &lobe,
        ..f.guide()
    };
    // One frame: every pixel shadowed with a full-weight sample (U_N = U),
    // except two lit ones, one with full weight and one with 1e-4 of it.
    let n = f.n();
    let (mut un, mut sn) = (vec![Vec3::ONE; n], vec![Vec3::ZERO; n]);
    let at = |x: u32, y: u32| (y * W + x) as usize;
    let (weak, strong) = (at(20, 20), at(70, 20));
    un[weak] = Vec3::splat(1e-4);
    sn[weak] = un[weak];
    sn[strong] = un[strong];
    Denoiser::new(W, H).denoise(&guide, &mut un, &mut sn, &DenoiseSettings::default());
    let (r_weak, r_strong) = (
        luminance_ratio(sn[weak], un[weak]),
        luminance_ratio(sn[strong], un[strong]),
    );
    assert!(r_weak < 0.05, "weightless lit sample kept ratio {r_weak}");
    assert!(
        r_strong > 0.95,
        "full-weight lit sample blurred to {r_strong}"
    );
}

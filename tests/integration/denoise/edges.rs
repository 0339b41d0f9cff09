//! Geometric edges stop the filter: the ratio of one surface does not bleed
//! into another at a different depth or orientation.

use crate::support::denoise::{Frame, Rng, Surface, luminance_ratio, sample};
use penumbra::denoise::{DenoiseSettings, Denoiser};

const W: u32 = 96;
const H: u32 = 48;
/// Right of the image centre so the crease wall (x = x0 > 0) faces the camera.
const SPLIT: u32 = 56;
const LEFT: f32 = 0.2;
const RIGHT: f32 = 0.8;
/// How far a side's mean ratio next to the edge may move from its true
/// value before it counts as bled.
const MAX_BLEED: f32 = 0.05;

/// Mean denoised ratio of the 3 columns on each side of the split after 16
/// static frames, true ratio LEFT on the left and RIGHT on the right.
fn border_means(f: &Frame, settings: &DenoiseSettings) -> (f32, f32) {
    let mut d = Denoiser::new(W, H);
    let mut rng = Rng::new(11);
    let truth = |i: usize| if (i as u32 % W) < SPLIT { LEFT } else { RIGHT };
    let (mut un, mut sn) = (Vec::new(), Vec::new());
    for _ in 0..16 {
        (un, sn) = sample(&mut rng, f.n(), truth);
        d.denoise(&f.guide(), &mut un, &mut sn, settings);
    }
    let mean = |cols: std::ops::Range<u32>| {
        let mut s = 0.0;
        let mut n = 0.0;
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

/// The ratio edge-stopping alone already separates 0.2 from 0.8 once the
/// history is long; switch it off to test the geometric weights by themselves.
fn geometry_only() -> DenoiseSettings {
    DenoiseSettings {
        sigma_ratio: 1e6,
        ..DenoiseSettings::default()
    }
}

/// Geometric edge-stopping switched off too: the control that shows these
/// scenes do bleed without it.
fn no_edges() -> DenoiseSettings {
    DenoiseSettings {
        sigma_plane: 1e6,
        normal_power: 0.0,
        ..geometry_only()
    }
}

fn depth_step() -> Frame {
    Frame::new(W, H, |x, _| {
        if x < SPLIT {
            Surface::Back(2.0)
        } else {
            Surface::Back(20.0)
        }
    })
}

fn crease() -> Frame {
    // The wall x = x0 meets the back plane z = -4 exactly at the split column's
    // left edge, so depth is continuous across the crease and only the
    // normal (and plane) tell the surfaces apart.
    let x0 = Frame::dir(W, H, SPLIT as f32 - 0.5, 0.0).x * 4.0;
    Frame::new(W, H, move |x, _| {
        if x < SPLIT {
            Surface::Back(4.0)
        } else {
            Surface::Wall(x0)
        }
    })
}

#[test]
fn depth_discontinuity_does_not_bleed() {
    let (l, r) = border_means(&depth_step(), &DenoiseSettings::default());
    eprintln!("depth step: left {l:.3} (true {LEFT}), right {r:.3} (true {RIGHT})");
    assert!((l - LEFT).abs() < MAX_BLEED, "left side {l} bled");
    assert!((r - RIGHT).abs() < MAX_BLEED, "right side {r} bled");
}

#[test]
fn normal_crease_does_not_bleed() {
    let (l, r) = border_means(&crease(), &DenoiseSettings::default());
    eprintln!("crease: left {l:.3} (true {LEFT}), right {r:.3} (true {RIGHT})");
    assert!((l - LEFT).abs() < MAX_BLEED, "left side {l} bled");
    assert!((r - RIGHT).abs() < MAX_BLEED, "right side {r} bled");
}

#[test]
fn geometric_weights_alone_stop_bleeding_at_a_depth_step() {
    let (l, r) = border_means(&depth_step(), &geometry_only());
    eprintln!("depth step, geometry only: left {l:.3}, right {r:.3}");
    assert!((l - LEFT).abs() < MAX_BLEED, "left side {l} bled");
    assert!((r - RIGHT).abs() < MAX_BLEED, "right side {r} bled");
}

#[test]
fn geometric_weights_alone_stop_bleeding_at_a_crease() {
    let (l, r) = border_means(&crease(), &geometry_only());
    eprintln!("crease, geometry only: left {l:.3}, right {r:.3}");
    assert!((l - LEFT).abs() < MAX_BLEED, "left side {l} bled");
    assert!((r - RIGHT).abs() < MAX_BLEED, "right side {r} bled");
}

#[test]
fn without_edge_weights_the_same_scenes_bleed() {
    for (name, f) in [("depth step", depth_step()), ("crease", crease())] {
        let (l, r) = border_means(&f, &no_edges());
        eprintln!("{name} without geometry weights: left {l:.3}, right {r:.3}");
        assert!(
            (l - LEFT).abs() > MAX_BLEED || (r - RIGHT).abs() > MAX_BLEED,
            "{name}: no bleed even without geometric weights; the geometry-only tests prove nothing"
        );
    }
}

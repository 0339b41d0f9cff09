//! U_N and S_N get identical weights: with S_N = k * U_N per pixel the output
//! keeps S_N = k * U_N, through temporal blending and spatial filtering, even
//! though every channel of U_N is independent noise.

use crate::support::denoise::{Frame, Rng, Surface};
use glam::{Vec2, Vec3};
use penumbra::denoise::{DenoiseSettings, Denoiser};

const W: u32 = 64;
const H: u32 = 48;
const K: f32 = 0.37;

fn check(un: &[Vec3], sn: &[Vec3], what: &str) {
    for (i, (u, s)) in un.iter().zip(sn).enumerate() {
        let want = *u * K;
        let err = (*s - want).abs().max_element();
        let tol = 1e-5 * want.max_element().max(1e-6);
        assert!(err <= tol, "{what}: pixel {i}: S_N {s} != k * U_N {want}");
    }
}

/// Two depths and a crease so the edge weights vary, U varies too, and a
/// sub-pixel camera drift so reprojection blends 2x2 taps.
fn run(settings: &DenoiseSettings, what: &str) {
    let x0 = Frame::dir(W, H, 39.5, 0.0).x * 4.0;
    let mut f = Frame::new(W, H, |x, y| match (x, y) {
        (_, y) if y < 12 => Surface::Back(9.0),
        (x, _) if x < 40 => Surface::Back(4.0),
        _ => Surface::Wall(x0),
    });
    let mut rng = Rng::new(3);
    for (i, u) in f.u.iter_mut().enumerate() {
        *u = Vec3::splat(1.0 + (i % 7) as f32 * 0.05);
    }
    let mut d = Denoiser::new(W, H);
    for frame in 0..6 {
        for (i, p) in f.prev_pixel.iter_mut().enumerate() {
            let (x, y) = ((i as u32 % W) as f32, (i as u32 / W) as f32);
            *p = Vec2::new(x + 0.5 + 0.3, y + 0.5 - 0.45);
        }
        let mut un: Vec<Vec3> = (0..f.n())
            .map(|_| Vec3::new(rng.f32() * 2.0, rng.f32() * 0.5, rng.f32() * 8.0))
            .collect();
        let mut sn: Vec<Vec3> = un.iter().map(|u| *u * K).collect();
        d.denoise(&f.guide(), &mut un, &mut sn, settings);
        check(&un, &sn, &format!("{what}, frame {frame}"));
    }
}

#[test]
fn proportional_inputs_stay_proportional_through_temporal_blend() {
    let s = DenoiseSettings {
        spatial: false,
        ..DenoiseSettings::default()
    };
    run(&s, "temporal only");
}

#[test]
fn proportional_inputs_stay_proportional_through_spatial_filter() {
    // The ratio is constant, so the adaptive footprint would be zero: force
    // the levels to make the spatial weights matter.
    let s = DenoiseSettings {
        temporal: false,
        min_levels: 4,
        ..DenoiseSettings::default()
    };
    run(&s, "spatial only");
}

#[test]
fn proportional_inputs_stay_proportional_through_both() {
    let s = DenoiseSettings {
        min_levels: 4,
        ..DenoiseSettings::default()
    };
    run(&s, "temporal + spatial");
}

#[test]
fn forced_filtering_really_mixes_neighbours() {
    // Control for the tests above: the forced levels change U_N, so the
    // proportionality is not just the identity passing values through.
    let f = Frame::plane(W, H);
    let mut rng = Rng::new(5);
    let mut un: Vec<Vec3> = (0..f.n()).map(|_| Vec3::splat(rng.f32())).collect();
    let orig = un.clone();
    let mut sn: Vec<Vec3> = un.iter().map(|u| *u * K).collect();
    let s = DenoiseSettings {
        temporal: false,
        min_levels: 4,
        ..DenoiseSettings::default()
    };
    Denoiser::new(W, H).denoise(&f.guide(), &mut un, &mut sn, &s);
    let changed = un
        .iter()
        .zip(&orig)
        .filter(|(a, b)| (**a - **b).abs().max_element() > 0.05)
        .count();
    assert!(changed > f.n() / 2, "only {changed} pixels changed");
}

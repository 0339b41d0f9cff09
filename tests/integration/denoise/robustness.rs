//! No NaN or infinity comes out, whatever comes in; pixels without a surface
//! pass through untouched.

use crate::support::denoise::{Frame, Rng, Surface};
use glam::Vec3;
use penumbra::denoise::{DenoiseSettings, Denoiser};

const W: u32 = 48;
const H: u32 = 40;

#[test]
fn zeros_huge_values_and_empty_pixels_give_finite_output() {
    // Sky (depth 0) in a band, the rest a plane.
    let f = Frame::new(W, H, |_, y| {
        if (10..14).contains(&y) {
            Surface::None
        } else {
            Surface::Back(3.0)
        }
    });
    let mut rng = Rng::new(4);
    let mut d = Denoiser::new(W, H);
    for frame in 0..6 {
        let mut un = Vec::new();
        let mut sn = Vec::new();
        for i in 0..f.n() {
            let (u, s) = match (i + frame) % 5 {
                0 => (Vec3::ZERO, Vec3::ZERO),
                1 => (Vec3::splat(1e30), Vec3::splat(1e30 * rng.f32())),
                2 => (Vec3::new(1e30, 0.0, 1e-30), Vec3::ZERO),
                3 => (Vec3::splat(rng.f32()), Vec3::ZERO),
                _ => {
                    let u = Vec3::splat(rng.f32() + 1e-3);
                    (u, u * rng.f32())
                }
            };
            un.push(u);
            sn.push(s);
        }
        for s in [
            DenoiseSettings::default(),
            DenoiseSettings {
                min_levels: 4,
                ..DenoiseSettings::default()
            },
        ] {
            let (mut u, mut sh) = (un.clone(), sn.clone());
            d.denoise(&f.guide(), &mut u, &mut sh, &s);
            for i in 0..f.n() {
                assert!(
                    u[i].is_finite() && sh[i].is_finite(),
                    "frame {frame} pixel {i}: {} {}",
                    u[i],
                    sh[i]
                );
            }
        }
    }
}

#[test]
fn depth_zero_pixels_pass_through_unchanged() {
    let f = Frame::new(W, H, |x, y| {
        if (x + y) % 3 == 0 {
            Surface::None
        } else {
            Surface::Back(3.0)
        }
    });
    let mut rng = Rng::new(6);
    let mut d = Denoiser::new(W, H);
    let s = DenoiseSettings {
        min_levels: 4,
        ..DenoiseSettings::default()
    };
    for _ in 0..4 {
        let un: Vec<Vec3> = (0..f.n()).map(|_| Vec3::splat(rng.f32() * 5.0)).collect();
        // Light pixels may carry anything, even values the filter would reject.
        let sn: Vec<Vec3> = un
            .iter()
            .map(|u| *u * 2.0 + Vec3::new(f32::NAN, 0.0, 0.0))
            .collect();
        let (mut u, mut sh) = (un.clone(), sn.clone());
        d.denoise(&f.guide(), &mut u, &mut sh, &s);
        for i in 0..f.n() {
            if f.depth[i] == 0.0 {
                assert_eq!(u[i], un[i]);
                assert_eq!(
                    sh[i].to_array().map(f32::to_bits),
                    sn[i].to_array().map(f32::to_bits)
                );
            } else {
                assert!(
                    u[i].is_finite(),
                    "surface pixel {i} took a bad value from a light pixel"
                );
            }
        }
    }
}

//! The band's draws run in lanes (`draw_lanes`) where the pixel replay
//! runs the scalar `draw`: for the replay to explain the frame, the lanes
//! must give the scalar code's bits. Random shading points (anywhere in
//! the scene, behind and in the plane of lights, normals below the view,
//! mirror to rough, black lobes) and random light choices, drawn both
//! ways: `U_N` and every queued shadow ray (origin, direction, length,
//! slot, weight, order) must be identical. The scenes cover rectangles,
//! a triangle, a pentagon and a hexagon (the fans), one- and two-sided.

use crate::support::{load, rng::SplitMix64};
use glam::Vec3;
use penumbra::embree::Device;
use penumbra::render::estimate::{
    BandDraw, Estimator, SampleScratch, SampleSink, SampleStream, draw_pixel_samples, draw_samples,
};
use penumbra::render::shadow::ShadowBatch;
use penumbra::render::{GSample, PixelKind, World};

fn unit(r: &mut SplitMix64) -> Vec3 {
    loop {
        let v = Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0));
        let l = v.length();
        if l > 0.05 && l <= 1.0 {
            return v / l;
        }
    }
}

fn colour(r: &mut SplitMix64) -> Vec3 {
    if r.f32() < 0.15 {
        Vec3::ZERO
    } else {
        Vec3::new(r.f32(), r.f32(), r.f32())
    }
}

/// A random surface sample around the scene's lights.
fn shading_point(r: &mut SplitMix64, world: &World) -> GSample {
    let lights = world.lights.declared();
    let light = &lights[(r.f32() * lights.len() as f32) as usize % lights.len()];
    let v0 = light.vertices[0];
    let position = match (r.f32() * 4.0) as u32 {
        // In the light's plane, or just off it on either side.
        0 => v0 + (light.vertices[2] - v0) * r.f32() + light.normal * r.range(-1e-3, 1e-3),
        // Far away: tiny solid angles.
        1 => v0 + unit(r) * r.range(50.0, 400.0),
        _ => v0 + unit(r) * r.range(0.05, 6.0),
    };
    let ns = unit(r);
    let wo = if r.f32() < 0.1 {
        // At and below the horizon.
        (unit(r) - ns * 2.0).normalize()
    } else {
        let w = unit(r);
        if w.dot(ns) < 0.0 { -w } else { w }
    };
    let roughness = match (r.f32() * 5.0) as u32 {
        0 => 0.0,
        1 => 1.0,
        _ => r.f32(),
    };
    GSample {
        kind: if r.f32() < 0.05 {
            PixelKind::Light
        } else {
            PixelKind::Surface
        },
        position,
        ng: ns,
        ns,
        wo,
        depth: r.range(0.1, 20.0),
        diffuse: colour(r),
        specular: colour(r),
        roughness,
        ..GSample::default()
    }
}

fn check_scene(name: &str, seed: u64, spp: u32) {
    check_world(name, seed, spp, false);
}

/// `two_sided`: every light made two-sided (no scene declares one).
fn check_world(name: &str, seed: u64, spp: u32, two_sided: bool) {
    let device = Device::new().expect("Embree starts");
    let mut scene = load(name);
    for l in &mut scene.lights {
        l.two_sided |= two_sided;
    }
    let world = World::build(&device, scene).expect("scene builds");
    let lights = world.lights.len();
    let mut r = SplitMix64::new(seed);
    const PIXELS: usize = 4001;
    let gbuf: Vec<GSample> = (0..PIXELS).map(|_| shading_point(&mut r, &world)).collect();
    let per_light: Vec<Vec3> = (0..PIXELS * lights)
        .map(|_| {
            if r.f32() < 0.2 {
                Vec3::ZERO
            } else {
                Vec3::splat(r.f32())
            }
        })
        .collect();
    let u: Vec<Vec3> = (0..PIXELS).map(|_| Vec3::splat(r.f32())).collect();
    let (base, first, seed) = (1000u32, 7u32, 11u32);
    let band = BandDraw {
        gbuf: &gbuf,
        per_light: &per_light,
        u: &u,
        estimator: Estimator::Mis,
        base,
        first,
        spp,
        seed,
    };
    // Every pixel but a few, each to its own slot (reversed, so slot and
    // band index differ).
    let drawn: Vec<(usize, usize)> = (0..PIXELS)
        .filter(|k| k % 97 != 5)
        .map(|k| (k, PIXELS - 1 - k))
        .collect();
    let mut un = vec![Vec3::ZERO; PIXELS];
    let mut batch = ShadowBatch::default();
    let mut scratch = SampleScratch::default();
    draw_samples(&world, &band, &drawn, &mut un, &mut batch, &mut scratch);

    let mut un_ref = vec![Vec3::ZERO; PIXELS];
    let mut batch_ref = ShadowBatch::default();
    for &(k, m) in &drawn {
        let stream = SampleStream {
            pixel: base + k as u32,
            first,
            count: spp,
            seed,
        };
        draw_pixel_samples(
            &world,
            &gbuf[k],
            &per_light[k * lights..(k + 1) * lights],
            u[k],
            Estimator::Mis,
            stream,
            &mut SampleSink {
                un: &mut un_ref[m],
                batch: &mut batch_ref,
                slot: m as u32,
                trace: None,
            },
        );
    }
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    for m in 0..PIXELS {
        assert_eq!(bits(un[m]), bits(un_ref[m]), "{name}: U_N of slot {m}");
    }
    assert_eq!(
        batch.rays.len(),
        batch_ref.rays.len(),
        "{name}: rays queued"
    );
    // Enough samples reach the light for the comparison to mean something
    // (most random points see the light below their horizon, or drop).
    assert!(
        batch.rays.len() > PIXELS / 10,
        "{name}: only {} rays",
        batch.rays.len()
    );
    for (i, (a, b)) in batch.rays.iter().zip(&batch_ref.rays).enumerate() {
        assert_eq!(bits(a.org), bits(b.org), "{name}: ray {i} origin");
        assert_eq!(bits(a.dir), bits(b.dir), "{name}: ray {i} direction");
        assert_eq!(a.tfar.to_bits(), b.tfar.to_bits(), "{name}: ray {i} length");
        assert_eq!(a.slot, b.slot, "{name}: ray {i} slot");
        assert_eq!(bits(a.weight), bits(b.weight), "{name}: ray {i} weight");
    }
}

#[test]
fn lanes_draw_the_scalar_samples_bit_for_bit_on_room() {
    check_scene("room.toml", 1, 1);
}

#[test]
fn lanes_draw_the_scalar_samples_bit_for_bit_at_several_samples_per_pixel() {
    check_scene("room.toml", 2, 3);
}

#[test]
fn lanes_draw_the_scalar_samples_bit_for_bit_on_shadow_plane() {
    check_scene("shadow-plane.toml", 3, 1);
}

#[test]
fn lanes_draw_the_scalar_samples_bit_for_bit_on_fans() {
    // A pentagon and a triangle, besides four quads.
    check_scene("default.toml", 4, 2);
}

#[test]
fn lanes_draw_the_scalar_samples_bit_for_bit_on_two_sided_lights() {
    check_world("room.toml", 5, 1, true);
    check_world("default.toml", 6, 1, true);
}

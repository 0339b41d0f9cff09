//! ns per light sample (rectangle and hexagon), per VNDF sample and per 2D
//! sequence point.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use penumbra::sampling::{sample_2d, sample_light, vndf_sample};
use penumbra::scene::Light;
use std::hint::black_box;

fn quad() -> Light {
    let (c, u, v) = (Vec3::new(0.0, 2.0, 0.0), Vec3::X * 0.5, Vec3::Z * 0.5);
    Light {
        vertices: vec![c - u - v, c + u - v, c + u + v, c - u + v],
        radiance: Vec3::ONE,
        two_sided: true,
        normal: Vec3::NEG_Y,
        area: 1.0,
        quad: Some((c, u, v)),
    }
}

fn hexagon() -> Light {
    let vertices = (0..6)
        .map(|i| {
            let t = i as f32 * std::f32::consts::TAU / 6.0;
            Vec3::new(0.6 * t.cos(), 2.0, 0.6 * t.sin())
        })
        .collect();
    Light {
        vertices,
        radiance: Vec3::ONE,
        two_sided: true,
        normal: Vec3::NEG_Y,
        area: 0.935,
        quad: None,
    }
}

fn bench(c: &mut Criterion) {
    let p = Vec3::new(0.3, 0.0, -0.2);
    let us: Vec<Vec2> = (0..256).map(|i| sample_2d(1, i, 0, 0)).collect();
    for (name, light) in [
        ("sample_light_rect", quad()),
        ("sample_light_hexagon", hexagon()),
    ] {
        let mut i = 0;
        c.bench_function(name, |b| {
            b.iter(|| {
                i = (i + 1) & 255;
                black_box(sample_light(black_box(&light), black_box(p), us[i]))
            })
        });
    }
    let wo = Vec3::new(0.5, 0.1, 0.8).normalize();
    let mut i = 0;
    c.bench_function("vndf_sample", |b| {
        b.iter(|| {
            i = (i + 1) & 255;
            black_box(vndf_sample(black_box(wo), black_box(0.3), us[i]))
        })
    });
    let mut i = 0u32;
    c.bench_function("sample_2d", |b| {
        b.iter(|| {
            i = i.wrapping_add(1);
            black_box(sample_2d(black_box(77), i, 3, 9))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);

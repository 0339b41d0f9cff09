//! ns per light sample (rectangle and hexagon): the one-shot wrappers, and the
//! per-pixel `LightSampler` split into setup, sample and pdf; per VNDF sample
//! and per 2D sequence point.

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use penumbra::sampling::{
    LightSampler, PreparedLight, light_pdf, sample_2d, sample_light, vndf_sample,
};
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
    for (name, light) in [("rect", quad()), ("hexagon", hexagon())] {
        let mut i = 0;
        c.bench_function(&format!("sample_light_{name}"), |b| {
            b.iter(|| {
                i = (i + 1) & 255;
                black_box(sample_light(black_box(&light), black_box(p), us[i]))
            })
        });
        let prepared = PreparedLight::new(&light);
        // Directions that hit the light (the costly case of the inside test).
        let sampler = LightSampler::new(&prepared, p).unwrap();
        let wis: Vec<Vec3> = us.iter().map(|u| sampler.sample(*u).unwrap().wi).collect();
        let mut i = 0;
        c.bench_function(&format!("light_pdf_{name}"), |b| {
            b.iter(|| {
                i = (i + 1) & 255;
                black_box(light_pdf(black_box(&light), black_box(p), wis[i]))
            })
        });
        c.bench_function(&format!("prepared_light_new_{name}"), |b| {
            b.iter(|| black_box(PreparedLight::new(black_box(&light))))
        });
        // Shading points vary so nothing is hoisted out of the loop.
        let ps: Vec<Vec3> = us
            .iter()
            .map(|u| p + Vec3::new(u.x - 0.5, 0.0, u.y - 0.5) * 0.2)
            .collect();
        let mut i = 0;
        c.bench_function(&format!("light_sampler_new_{name}"), |b| {
            b.iter(|| {
                i = (i + 1) & 255;
                black_box(LightSampler::new(black_box(&prepared), ps[i]))
            })
        });
        let mut i = 0;
        c.bench_function(&format!("light_sampler_sample_{name}"), |b| {
            b.iter(|| {
                i = (i + 1) & 255;
                black_box(black_box(&sampler).sample(us[i]))
            })
        });
        let mut i = 0;
        c.bench_function(&format!("light_sampler_pdf_{name}"), |b| {
            b.iter(|| {
                i = (i + 1) & 255;
                black_box(black_box(&sampler).pdf(wis[i]))
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

#[path = "support/quiet.rs"]
mod quiet;

criterion_group! {
    name = benches;
    config = quiet::criterion();
    targets = bench
}
criterion_main!(benches);

//! `LightSampler` (setup once per light and shading point) against the
//! one-shot wrappers, and its `sample` against its own `pdf`.

use crate::support::sampling::*;
use glam::{Vec2, Vec3};
use penumbra::sampling::{
    LightSampler, Pcg32, PreparedLight, intersect_light, light_pdf, sample_light,
};
use penumbra::scene::Light;

/// Rectangle, hexagon, non-rectangular parallelogram, triangle, a 4-gon
/// rectangle given by vertices only, and a tiny light (area fallback).
fn lights() -> Vec<(&'static str, Light)> {
    let face_down = |mut l: Light| {
        if l.normal.y > 0.0 {
            l.vertices.reverse();
            l.normal = -l.normal;
            l.quad = l.quad.map(|(c, u, v)| (c, v, u));
        }
        l
    };
    let rect = quad_light(
        Vec3::new(0.3, 1.0, -0.2),
        Vec3::new(0.8, 0.0, 0.0),
        Vec3::new(0.0, 0.1, 0.5).normalize() * 0.4,
        false,
    );
    let mut rect_vertices_only = rect.clone();
    rect_vertices_only.quad = None;
    vec![
        ("rect", face_down(rect)),
        ("rect by vertices", face_down(rect_vertices_only)),
        (
            "hexagon",
            face_down(polygon_light(
                regular_polygon(Vec3::new(-0.2, 1.2, 0.1), Vec3::Z, Vec3::X, 0.7, 6),
                false,
            )),
        ),
        (
            "parallelogram",
            face_down(quad_light(
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.6, 0.0, 0.0),
                Vec3::new(0.3, 0.0, 0.5),
                false,
            )),
        ),
        (
            "triangle",
            polygon_light(
                vec![
                    Vec3::new(-0.5, 1.0, -0.3),
                    Vec3::new(0.7, 0.9, -0.5),
                    Vec3::new(0.4, 1.1, 0.6),
                ],
                true,
            ),
        ),
        (
            "tiny",
            quad_light(
                Vec3::new(0.0, 30.0, 0.0),
                Vec3::X * 0.2,
                Vec3::Z * 0.1,
                true,
            ),
        ),
    ]
}

const P: Vec3 = Vec3::new(0.1, 0.0, 0.05);

#[test]
fn sampler_agrees_exactly_with_the_wrappers() {
    let mut rng = Pcg32::new(31, 0);
    for (name, l) in lights() {
        let prepared = PreparedLight::new(&l);
        let sampler = LightSampler::new(&prepared, P).expect(name);
        for _ in 0..2_000 {
            let u = rng.next_vec2();
            let s = sampler.sample(u);
            assert_eq!(s, sample_light(&l, P, u), "{name} {u}");
            let s = s.expect(name);
            assert_eq!(sampler.pdf(s.wi), light_pdf(&l, P, s.wi), "{name}");
            // Arbitrary directions, most of which miss.
            let wi = (rng.next_vec2() * 2.0 - 1.0).extend(rng.next_f32() - 0.5);
            if let Some(wi) = wi.try_normalize() {
                assert_eq!(sampler.pdf(wi), light_pdf(&l, P, wi), "{name} {wi}");
                assert_eq!(
                    sampler.pdf(wi).map(|(_, d)| d),
                    intersect_light(&l, P, wi),
                    "{name} {wi}"
                );
            }
        }
    }
}

#[test]
fn sampler_pdf_of_its_samples_is_the_sample_pdf() {
    let mut rng = Pcg32::new(32, 0);
    for (name, l) in lights() {
        let prepared = PreparedLight::new(&l);
        let sampler = LightSampler::new(&prepared, P).expect(name);
        for _ in 0..5_000 {
            let s = sampler.sample(rng.next_vec2()).expect(name);
            let (pdf, dist) = sampler.pdf(s.wi).expect(name);
            assert!((pdf / s.pdf - 1.0).abs() < 1e-3, "{name}: {pdf} vs {s:?}");
            assert!(
                (dist / s.dist - 1.0).abs() < 1e-4,
                "{name}: {dist} vs {s:?}"
            );
        }
    }
}

#[test]
fn sampler_solid_angle_matches_f64_reference_and_sample_pdf() {
    for (name, l) in lights() {
        let prepared = PreparedLight::new(&l);
        let sampler = LightSampler::new(&prepared, P).expect(name);
        let omega = sampler.solid_angle() as f64;
        let reference = light_solid_angle(&l, P);
        assert!(
            (omega / reference - 1.0).abs() < 1e-5,
            "{name}: {omega} vs {reference}"
        );
        if name != "tiny" {
            let s = sampler.sample(Vec2::new(0.3, 0.7)).unwrap();
            assert_eq!(s.pdf, 1.0 / sampler.solid_angle(), "{name}");
        }
    }
}

#[test]
fn sampler_is_none_exactly_where_the_wrappers_give_nothing() {
    let l = lights().remove(0).1;
    let prepared = PreparedLight::new(&l);
    // Behind the one-sided light, and exactly in an axis-aligned light's plane.
    let above = Vec3::new(0.3, 2.5, -0.2);
    assert!(LightSampler::new(&prepared, above).is_none());
    assert!(sample_light(&l, above, Vec2::splat(0.5)).is_none());
    let flat = quad_light(Vec3::new(0.0, 1.0, 0.0), Vec3::Z * 0.5, Vec3::X * 0.5, true);
    let flat_prepared = PreparedLight::new(&flat);
    assert!(LightSampler::new(&flat_prepared, Vec3::new(0.1, 1.0, 0.2)).is_none());
    assert!(light_pdf(&flat, Vec3::new(0.1, 1.0, 0.2), Vec3::X).is_none());
}

#[test]
fn sampler_is_small_and_copy() {
    fn copy<T: Copy>(_: &T) {}
    let l = lights().remove(0).1;
    let prepared = PreparedLight::new(&l);
    let sampler = LightSampler::new(&prepared, P).unwrap();
    copy(&sampler);
    copy(&prepared);
    assert!(std::mem::size_of::<LightSampler>() <= 128);
}

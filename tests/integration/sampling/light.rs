use crate::support::sampling::*;
use glam::{DVec3, Vec2, Vec3};
use penumbra::sampling::spherical_rect::SphericalRect;
use penumbra::sampling::spherical_tri;
use penumbra::sampling::{
    Pcg32, PreparedLight, SOLID_ANGLE_AREA_FALLBACK, intersect_light, light_pdf, sample_light,
    sample_light_area_uniform,
};
use penumbra::scene::Light;

/// A unit-ish rectangle (uses the spherical-rectangle sampler).
fn rect() -> Light {
    quad_light(
        Vec3::new(0.3, 1.0, -0.2),
        Vec3::new(0.8, 0.0, 0.0),
        Vec3::new(0.0, 0.1, 0.5).normalize() * 0.4,
        false,
    )
}

/// A regular hexagon facing down (the triangle-fan sampler).
fn hexagon() -> Light {
    polygon_light(
        regular_polygon(Vec3::new(-0.2, 1.2, 0.1), Vec3::Z, Vec3::X, 0.7, 6),
        false,
    )
}

/// A parallelogram that is not a rectangle (must go to the fan).
fn parallelogram() -> Light {
    quad_light(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.6, 0.0, 0.0),
        Vec3::new(0.3, 0.0, 0.5),
        false,
    )
    .flip_to_face_down()
}

trait FaceDown {
    fn flip_to_face_down(self) -> Light;
}
impl FaceDown for Light {
    /// Reverses the winding so the light emits toward -y (toward p below it).
    fn flip_to_face_down(mut self) -> Light {
        if self.normal.y > 0.0 {
            self.vertices.reverse();
            self.normal = -self.normal;
            if let Some((c, u, v)) = self.quad {
                self.quad = Some((c, v, u));
            }
        }
        self
    }
}

fn triangle() -> Light {
    let two_sided = polygon_light(
        vec![
            Vec3::new(-0.5, 1.0, -0.3),
            Vec3::new(0.4, 1.1, 0.6),
            Vec3::new(0.7, 0.9, -0.5),
        ],
        true,
    );
    two_sided.flip_to_face_down()
}

fn lights() -> Vec<(&'static str, Light)> {
    vec![
        ("rect", rect().flip_to_face_down()),
        ("hexagon", hexagon().flip_to_face_down()),
        ("parallelogram", parallelogram()),
        ("triangle", triangle()),
    ]
}

const P: Vec3 = Vec3::new(0.1, 0.0, 0.05);

#[test]
fn test_lights_face_the_shading_point() {
    for (name, l) in lights() {
        assert!((P - l.vertices[0]).dot(l.normal) > 0.0, "{name}");
    }
}

#[test]
fn sampled_directions_always_hit_the_light() {
    let mut rng = Pcg32::new(1, 0);
    for (name, l) in lights() {
        for _ in 0..20_000 {
            let s = sample_light(&l, P, rng.next_vec2()).expect(name);
            let t = intersect_light(&l, P, s.wi).unwrap_or_else(|| panic!("{name}: {s:?}"));
            assert!(
                (t - s.dist).abs() <= 1e-4 * s.dist,
                "{name}: {t} vs {}",
                s.dist
            );
        }
    }
}

#[test]
fn pdf_times_solid_angle_is_one() {
    let mut rng = Pcg32::new(2, 0);
    for (name, l) in lights() {
        let omega = light_solid_angle(&l, P);
        for _ in 0..100 {
            let s = sample_light(&l, P, rng.next_vec2()).unwrap();
            let r = s.pdf as f64 * omega;
            assert!((r - 1.0).abs() < 1e-4, "{name}: {r}");
        }
    }
}

#[test]
fn rect_construction_solid_angle_matches_reference() {
    let l = rect().flip_to_face_down();
    let (c, u, v) = l.quad.unwrap();
    let r = SphericalRect::new(c - u - v - P, 2.0 * u, 2.0 * v).unwrap();
    let reference = light_solid_angle(&l, P);
    assert!((r.solid_angle() as f64 / reference - 1.0).abs() < 1e-5);
}

#[test]
fn triangle_solid_angle_is_accurate_for_tiny_distant_triangles() {
    // A 1e-3-sized triangle at distance 1 (~4e-7 sr) seen from far off origin.
    let o = Vec3::new(1e3, -2e3, 5e2);
    let (a, b, c) = (
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(1e-3, 0.0, 1.0),
        Vec3::new(0.0, 1e-3, 1.0),
    );
    let f32_value = spherical_tri::solid_angle(a, b, c);
    let reference = tri_solid_angle(a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    assert!((f32_value as f64 / reference - 1.0).abs() < 1e-4);
    // Same triangle through world positions far from the origin, relative to p.
    let rel = |x: Vec3| (x + o) - o;
    let far = spherical_tri::solid_angle(rel(a), rel(b), rel(c));
    assert!(
        (far as f64 / reference - 1.0).abs() < 0.05,
        "{far} vs {reference}"
    );
}

#[test]
fn monte_carlo_area_estimate_of_solid_angle_matches_analytic() {
    // Uniform area samples: E[cos_light / d²] · area = Ω.
    let mut rng = Pcg32::new(3, 0);
    for (name, l) in lights() {
        let xs: Vec<f64> = (0..200_000)
            .map(|_| {
                let q = sample_light_area_uniform(&l, rng.next_vec2()) - P;
                let d2 = q.length_squared() as f64;
                (q.normalize().dot(l.normal).abs() as f64) / d2 * l.area as f64
            })
            .collect();
        let (m, se) = mean_se(&xs);
        let omega = light_solid_angle(&l, P);
        assert!(
            (m - omega).abs() < 5.0 * se,
            "{name}: {m} ± {se} vs {omega}"
        );
    }
}

#[test]
fn area_uniform_samples_lie_on_the_light_with_centroid_mean() {
    let mut rng = Pcg32::new(4, 0);
    for (name, l) in lights() {
        let n = 100_000;
        let mut mean = DVec3::ZERO;
        for _ in 0..n {
            let q = sample_light_area_uniform(&l, rng.next_vec2());
            let below = l.normal * 1e-3;
            assert!(
                intersect_light(&l, q + below, -l.normal).is_some(),
                "{name}"
            );
            mean += q.as_dvec3();
        }
        mean /= n as f64;
        // Area centroid of the polygon (fan of triangles).
        let v: Vec<DVec3> = l.vertices.iter().map(|x| x.as_dvec3()).collect();
        let (mut c, mut a) = (DVec3::ZERO, 0.0);
        for i in 1..v.len() - 1 {
            let ai = (v[i] - v[0]).cross(v[i + 1] - v[0]).length();
            c += ai * (v[0] + v[i] + v[i + 1]) / 3.0;
            a += ai;
        }
        assert!(
            (mean - c / a).length() < 5e-3,
            "{name}: {mean} vs {}",
            c / a
        );
    }
}

/// Bins: fan triangle k of the light, then an m×m barycentric grid of
/// up/down sub-triangles. Returns (bin corners, classifier).
fn subtriangles(l: &Light, m: usize) -> Vec<[Vec3; 3]> {
    let v = &l.vertices;
    let mut out = Vec::new();
    for k in 1..v.len() - 1 {
        let (a, e1, e2) = (v[0], v[k] - v[0], v[k + 1] - v[0]);
        let at = |i: usize, j: usize| a + e1 * (i as f32 / m as f32) + e2 * (j as f32 / m as f32);
        for i in 0..m {
            for j in 0..m - i {
                out.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                if i + j + 1 < m {
                    out.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
    }
    out
}

/// Smallest edge function of q for triangle t: >= 0 inside.
fn inside(t: &[Vec3; 3], q: Vec3, n: Vec3) -> f32 {
    (0..3)
        .map(|i| (t[(i + 1) % 3] - t[i]).cross(q - t[i]).dot(n))
        .fold(f32::INFINITY, f32::min)
}

#[test]
fn samples_are_uniform_in_solid_angle_chi_square() {
    // A light close to p, so solid angle and area differ strongly per bin.
    let p = Vec3::new(0.3, 0.6, 0.1);
    let mut rng = Pcg32::new(5, 0);
    for (name, l) in lights() {
        let bins = subtriangles(&l, 5);
        let omega = light_solid_angle(&l, p);
        let n = 200_000;
        let mut counts = vec![0f64; bins.len()];
        for _ in 0..n {
            let s = sample_light(&l, p, rng.next_vec2()).unwrap();
            let q = p + s.wi * s.dist;
            // Project onto the plane to avoid edge-rounding misses.
            let q = q - l.normal * (q - l.vertices[0]).dot(l.normal);
            // The bin q is most inside of (rounding may put it on an edge).
            let k = (0..bins.len())
                .max_by(|&i, &j| {
                    inside(&bins[i], q, l.normal).total_cmp(&inside(&bins[j], q, l.normal))
                })
                .unwrap();
            let margin = inside(&bins[k], q, l.normal);
            assert!(margin > -1e-5, "{name}: {q} in no bin ({margin})");
            counts[k] += 1.0;
        }
        let expected: Vec<f64> = bins
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|x| (x - p).as_dvec3());
                tri_solid_angle(a, b, c) / omega * n as f64
            })
            .collect();
        let chi2 = chi_square(&counts, &expected);
        let bound = chi_square_bound(bins.len() - 1);
        assert!(chi2 < bound, "{name}: chi2 {chi2} > {bound}");
    }
}

#[test]
fn light_pdf_matches_sample_light_pdf_and_distance() {
    let mut rng = Pcg32::new(6, 0);
    // Includes a tiny light (area-sampling fallback).
    let tiny = quad_light(
        Vec3::new(0.0, 30.0, 0.0),
        Vec3::X * 0.2,
        Vec3::Z * 0.1,
        true,
    );
    let mut all = lights();
    all.push(("tiny", tiny));
    for (name, l) in all {
        for _ in 0..5_000 {
            let s = sample_light(&l, P, rng.next_vec2()).unwrap();
            let (pdf, dist) = light_pdf(&l, P, s.wi).expect(name);
            assert!(
                (pdf / s.pdf - 1.0).abs() < 1e-3,
                "{name}: {pdf} vs {}",
                s.pdf
            );
            assert!((dist / s.dist - 1.0).abs() < 1e-4, "{name}");
        }
    }
}

#[test]
fn directions_that_miss_have_no_pdf() {
    for (name, l) in lights() {
        for wi in [Vec3::NEG_Y, Vec3::X, Vec3::new(1.0, 1.0, 0.0).normalize()] {
            assert!(light_pdf(&l, P, wi).is_none(), "{name} {wi}");
            assert!(intersect_light(&l, P, wi).is_none(), "{name} {wi}");
        }
    }
}

#[test]
fn one_sided_light_is_invisible_from_behind_and_two_sided_is_not() {
    let l = rect().flip_to_face_down();
    let above = Vec3::new(0.3, 2.5, -0.2);
    assert!(sample_light(&l, above, Vec2::splat(0.5)).is_none());
    assert!(intersect_light(&l, above, Vec3::NEG_Y).is_none());
    assert!(light_pdf(&l, above, Vec3::NEG_Y).is_none());
    let two = Light {
        two_sided: true,
        ..l.clone()
    };
    let s = sample_light(&two, above, Vec2::splat(0.5)).unwrap();
    assert!(s.wi.y < 0.0);
    assert!(intersect_light(&two, above, Vec3::NEG_Y).is_some());
}

#[test]
fn expected_cosine_over_pdf_matches_quadrature() {
    // E[max(0, n·wi)/pdf] = ∫_light max(0, n·wi) dω, for a rect and for a
    // non-rectangular parallelogram (fan), with a tilted receiver normal.
    let n = Vec3::new(0.3, 1.0, -0.2).normalize();
    let mut rng = Pcg32::new(7, 0);
    for (name, l) in [
        ("rect", rect().flip_to_face_down()),
        ("para", parallelogram()),
    ] {
        let xs: Vec<f64> = (0..200_000)
            .map(|_| match sample_light(&l, P, rng.next_vec2()) {
                Some(s) => (s.wi.dot(n).max(0.0) / s.pdf) as f64,
                None => 0.0,
            })
            .collect();
        let (m, se) = mean_se(&xs);
        let nd = n.as_dvec3();
        let reference = quad_integral(&l, P, 600, |wi| wi.dot(nd).max(0.0));
        assert!(
            (m - reference).abs() < 5.0 * se + 1e-4 * reference,
            "{name}: {m} ± {se} vs {reference}"
        );
    }
}

#[test]
fn area_fallback_is_unbiased_for_expected_inverse_pdf() {
    // A light just under the threshold, at grazing-ish incidence.
    let l = quad_light(
        Vec3::new(0.0, 5.0, 3.0),
        Vec3::new(0.05, 0.0, 0.0),
        Vec3::new(0.0, 0.03, 0.04),
        true,
    );
    let omega = light_solid_angle(&l, Vec3::ZERO);
    assert!(
        omega < SOLID_ANGLE_AREA_FALLBACK as f64 && omega > 1e-5,
        "{omega}"
    );
    let mut rng = Pcg32::new(8, 0);
    let xs: Vec<f64> = (0..100_000)
        .map(|_| 1.0 / sample_light(&l, Vec3::ZERO, rng.next_vec2()).unwrap().pdf as f64)
        .collect();
    let (m, se) = mean_se(&xs);
    assert!(se > 0.0, "area sampling pdf varies over the light");
    assert!((m - omega).abs() < 5.0 * se, "{m} ± {se} vs {omega}");
}

fn check_finite(name: &str, l: &Light, p: Vec3) -> usize {
    let mut rng = Pcg32::new(9, 0);
    let mut some = 0;
    for _ in 0..2_000 {
        if let Some(s) = sample_light(l, p, rng.next_vec2()) {
            assert!(s.pdf.is_finite() && s.pdf > 0.0, "{name}: {s:?}");
            assert!(s.dist.is_finite() && s.dist > 0.0, "{name}: {s:?}");
            assert!((s.wi.length() - 1.0).abs() < 1e-5, "{name}: {s:?}");
            if let Some((pdf, d)) = light_pdf(l, p, s.wi) {
                assert!(pdf.is_finite() && pdf > 0.0 && d.is_finite(), "{name}");
            }
            some += 1;
        }
    }
    some
}

#[test]
fn tiny_light_of_a_microsteradian_samples_finitely() {
    let l = quad_light(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::X * 5e-4,
        Vec3::Z * 5e-4,
        true,
    );
    let omega = light_solid_angle(&l, Vec3::ZERO);
    assert!((omega - 1e-6).abs() < 1e-8, "{omega}");
    assert_eq!(check_finite("tiny", &l, Vec3::ZERO), 2_000);
}

#[test]
fn huge_close_light_samples_finitely_and_consistently() {
    let l = quad_light(
        Vec3::new(0.0, 1e-3, 0.0),
        Vec3::X * 1e3,
        Vec3::Z * 1e3,
        true,
    );
    assert_eq!(check_finite("huge", &l, Vec3::ZERO), 2_000);
    let omega = light_solid_angle(&l, Vec3::ZERO);
    let s = sample_light(&l, Vec3::ZERO, Vec2::new(0.3, 0.8)).unwrap();
    assert!(
        (s.pdf as f64 * omega - 1.0).abs() < 1e-4,
        "{} {omega}",
        s.pdf
    );
}

#[test]
fn light_far_from_origin_keeps_precision() {
    let o = Vec3::new(1e4, -1e4, 1e4);
    let near = hexagon().flip_to_face_down();
    let far = polygon_light(near.vertices.iter().map(|v| *v + o).collect(), false);
    assert_eq!(check_finite("far", &far, P + o), 2_000);
    let omega = light_solid_angle(&near, P);
    let s = sample_light(&far, P + o, Vec2::new(0.4, 0.6)).unwrap();
    // World coordinates of 1e4 carry ~1e-3 absolute error: per mille accuracy.
    assert!(
        (s.pdf as f64 * omega - 1.0).abs() < 5e-3,
        "{}",
        s.pdf as f64 * omega
    );
}

#[test]
fn points_exactly_in_the_light_plane_get_none() {
    // Axis-aligned, so the plane test is exact.
    let l = quad_light(
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::Z * 0.5,
        Vec3::X * 0.5,
        false,
    );
    for p in [Vec3::new(0.1, 1.0, 0.2), Vec3::new(5.0, 1.0, 0.0)] {
        for u in [Vec2::ZERO, Vec2::splat(0.5), Vec2::new(0.99, 0.01)] {
            assert!(sample_light(&l, p, u).is_none(), "{p}");
        }
        assert!(light_pdf(&l, p, Vec3::X).is_none());
    }
}

#[test]
fn edge_on_and_grazing_points_give_none_or_finite_samples() {
    let l = rect().flip_to_face_down();
    let (c, u, _) = l.quad.unwrap();
    // In the (tilted) plane up to rounding, inside and beside the light, and
    // slightly off it on both sides.
    for base in [c, c + 5.0 * u, c + 1.01 * u] {
        for off in [0.0, -1e-6, 1e-6, 1e-3, -1e-3] {
            check_finite("edge-on", &l, base + off * l.normal);
        }
    }
}

/// A small convex quad (no `quad` frame, so the triangle fan) about 2° across,
/// the case proptest found: in `f32` the spherical-triangle sampler put
/// this sample 4e-4 outside the edge v2–v3 (0.7 % of its length), a light
/// sample that misses its light. Every sample of a grid must land on it.
#[test]
fn fan_samples_of_a_small_polygon_land_on_the_polygon() {
    let v = vec![
        Vec3::new(0.247_528_88, -0.216_142_46, 0.828_990_9),
        Vec3::new(0.451_797_28, -0.323_029_16, 0.789_334_95),
        Vec3::new(0.320_526_63, -0.268_871_58, 0.884_078_6),
        Vec3::new(0.269_433_38, -0.242_606_64, 0.896_239_76),
    ];
    let l = polygon_light(v, false);
    let p = Vec3::new(0.000_944_618_1, 0.0, 0.0);
    let n = 64;
    for i in 0..n {
        for j in 0..n {
            let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            let s = sample_light(&l, p, u).expect("a sample");
            assert!(
                intersect_light(&l, p, s.wi).is_some(),
                "u {u} misses: {s:?}"
            );
        }
    }
    let s = sample_light(&l, p, Vec2::new(0.961_508_3, 0.452_347_2)).expect("a sample");
    assert!(intersect_light(&l, p, s.wi).is_some(), "{s:?}");
}

/// GGX alpha of a sharp lobe (roughness 0.12) and of a rough one (0.7).
const SHARP_ALPHA: f32 = 0.0144;
const ROUGH_ALPHA: f32 = 0.49;

/// A point below the test lights, farther than `P` (outside every light's
/// bounding sphere).
const FAR: Vec3 = Vec3::new(0.1, -2.0, 0.05);

/// A view whose mirror direction about +Y is `mirror`.
fn view_mirroring(mirror: Vec3) -> Vec3 {
    let m = mirror.normalize();
    (2.0 * m.dot(Vec3::Y) * Vec3::Y - m).normalize()
}

#[test]
fn a_sharp_lobe_pointing_at_a_light_is_not_off_it() {
    for (name, l) in lights() {
        let prepared = PreparedLight::new(&l);
        let centre = l.vertices.iter().copied().sum::<Vec3>() / l.vertices.len() as f32;
        let wo = view_mirroring(centre - FAR);
        assert!(
            !prepared.lobe_misses(FAR, Vec3::Y, wo, SHARP_ALPHA),
            "{name}"
        );
    }
}

#[test]
fn a_sharp_lobe_pointing_away_from_a_light_is_off_it() {
    // The mirror direction near the horizon, away from every test light
    // (all above the point): tens of lobe widths off.
    let wo = view_mirroring(Vec3::new(-1.0, 0.05, -1.0));
    for (name, l) in lights() {
        assert!(
            PreparedLight::new(&l).lobe_misses(FAR, Vec3::Y, wo, SHARP_ALPHA),
            "{name}"
        );
    }
}

#[test]
fn a_rough_lobe_or_a_point_inside_the_lights_sphere_is_never_off() {
    let wo = view_mirroring(Vec3::new(-1.0, 0.05, -1.0));
    for (name, l) in lights() {
        let prepared = PreparedLight::new(&l);
        assert!(!prepared.lobe_misses(P, Vec3::Y, wo, ROUGH_ALPHA), "{name}");
        let centre = l.vertices.iter().copied().sum::<Vec3>() / l.vertices.len() as f32;
        let near = centre - 1e-3 * l.normal;
        assert!(
            !prepared.lobe_misses(near, Vec3::Y, wo, SHARP_ALPHA),
            "{name}"
        );
    }
}

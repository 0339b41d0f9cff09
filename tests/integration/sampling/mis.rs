use crate::support::sampling::*;
use glam::{DVec3, Vec3};
use penumbra::sampling::{
    Pcg32, balance_heuristic, brdf_pdf, intersect_light, light_pdf, power_heuristic, sample_brdf,
    sample_light, spec_lobe_probability,
};
use penumbra::scene::Light;

/// One light sample + one BRDF sample, balance heuristic, of
/// ∫_light f(wi) L cos dω with L = 1; returns per-pixel estimates.
fn mis_estimates(
    light: &Light,
    p: Vec3,
    n: Vec3,
    wo: Vec3,
    kd: f64,
    alpha: f32,
    count: usize,
) -> Vec<f64> {
    let p_spec = spec_lobe_probability(Vec3::splat(kd as f32), Vec3::ONE, n.dot(wo));
    let f = |wi: Vec3| {
        let (nd, wod, wid) = (n.as_dvec3(), wo.as_dvec3(), wi.as_dvec3());
        let spec = if p_spec > 0.0 {
            f_spec(nd, wod, wid, alpha as f64)
        } else {
            0.0
        };
        (kd / std::f64::consts::PI + spec) * wid.dot(nd).max(0.0)
    };
    let mut rng = Pcg32::new(21, 0);
    (0..count)
        .map(|_| {
            let mut est = 0.0;
            if let Some(s) = sample_light(light, p, rng.next_vec2()) {
                let pb = brdf_pdf(n, wo, s.wi, alpha, p_spec);
                est += f(s.wi) / s.pdf as f64 * balance_heuristic(s.pdf, pb) as f64;
            }
            if let Some(b) = sample_brdf(n, wo, alpha, p_spec, rng.next_f32(), rng.next_vec2())
                && intersect_light(light, p, b.wi).is_some()
            {
                let (pl, _) = light_pdf(light, p, b.wi).expect("hit implies a pdf");
                est += f(b.wi) / b.pdf as f64 * balance_heuristic(b.pdf, pl) as f64;
            }
            est
        })
        .collect()
}

fn check(name: &str, light: &Light, p: Vec3, n: Vec3, wo: Vec3, kd: f64, alpha: f32) {
    let (m, se) = mean_se(&mis_estimates(light, p, n, wo, kd, alpha, 200_000));
    let p_spec = spec_lobe_probability(Vec3::splat(kd as f32), Vec3::ONE, n.dot(wo));
    let (nd, wod) = (n.as_dvec3(), wo.as_dvec3());
    let reference = quad_integral(light, p, 1000, |wi: DVec3| {
        let spec = if p_spec > 0.0 {
            f_spec(nd, wod, wi, alpha as f64)
        } else {
            0.0
        };
        (kd / std::f64::consts::PI + spec) * wi.dot(nd).max(0.0)
    });
    assert!(reference > 0.0);
    assert!(
        (m - reference).abs() < 5.0 * se + 1e-3 * reference,
        "{name}: {m} ± {se} vs {reference}"
    );
}

fn light() -> Light {
    // Faces -y, above and to the side of the shading point.
    quad_light(
        Vec3::new(0.5, 1.0, 0.0),
        Vec3::X * 0.4,
        Vec3::Z * 0.6,
        false,
    )
}

#[test]
fn mis_light_plus_brdf_sample_is_unbiased_for_a_diffuse_surface() {
    let l = light();
    assert!(l.normal.y < 0.0);
    check(
        "diffuse",
        &l,
        Vec3::ZERO,
        Vec3::Y,
        Vec3::new(-0.3, 1.0, 0.1).normalize(),
        0.8,
        0.5,
    );
}

#[test]
fn mis_light_plus_brdf_sample_is_unbiased_for_a_glossy_surface() {
    let l = light();
    // Viewer mirrored from the light so the specular lobe points at it.
    let wo = Vec3::new(-0.5, 1.0, 0.0).normalize();
    check("glossy", &l, Vec3::ZERO, Vec3::Y, wo, 0.1, 0.09);
    check("glossy rough", &l, Vec3::ZERO, Vec3::Y, wo, 0.0, 0.4);
}

#[test]
fn heuristics_weights_sum_to_one_and_handle_zero_and_infinity() {
    for (a, b) in [(1.0f32, 1.0f32), (0.3, 7.0), (1e-20, 1e20), (5.0, 0.0)] {
        assert!((balance_heuristic(a, b) + balance_heuristic(b, a) - 1.0).abs() < 1e-6);
        assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
    }
    assert_eq!(balance_heuristic(0.0, 0.0), 0.0);
    assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    assert_eq!(balance_heuristic(f32::INFINITY, 3.0), 1.0);
    assert_eq!(power_heuristic(3.0, f32::INFINITY), 0.0);
    assert!(
        (power_heuristic(1e30, 1e30) - 0.5).abs() < 1e-6,
        "no overflow"
    );
    assert!((balance_heuristic(1.0, 3.0) - 0.25).abs() < 1e-7);
    assert!((power_heuristic(1.0, 3.0) - 0.1).abs() < 1e-7);
}

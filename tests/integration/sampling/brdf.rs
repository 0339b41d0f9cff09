use crate::support::sampling::*;
use glam::{DVec3, Vec2, Vec3};
use penumbra::sampling::{
    Pcg32, brdf_pdf, cosine_hemisphere, onb, sample_brdf, spec_lobe_probability, vndf_pdf,
    vndf_sample,
};
use std::f64::consts::PI;

fn view(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// Midpoint quadrature over the sphere (or upper hemisphere) in (cos θ, φ).
fn sphere_integral(upper_only: bool, nz: usize, nphi: usize, g: impl Fn(Vec3) -> f64) -> f64 {
    let z0 = if upper_only { 0.0 } else { -1.0 };
    let dz = (1.0 - z0) / nz as f64;
    let dphi = 2.0 * PI / nphi as f64;
    let mut sum = 0.0;
    for i in 0..nz {
        let z = z0 + (i as f64 + 0.5) * dz;
        let r = (1.0 - z * z).sqrt();
        for j in 0..nphi {
            let phi = (j as f64 + 0.5) * dphi;
            let w = DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3();
            sum += g(w) * dz * dphi;
        }
    }
    sum
}

fn reflect(wo: Vec3, h: Vec3) -> Vec3 {
    2.0 * wo.dot(h) * h - wo
}

#[test]
fn vndf_estimator_of_specular_albedo_matches_quadrature() {
    let mut rng = Pcg32::new(11, 0);
    for alpha in [0.2f32, 0.5, 1.0] {
        for theta in [0.0f32, 45.0, 80.0] {
            let wo = view(theta);
            let xs: Vec<f64> = (0..100_000)
                .map(|_| {
                    let wi = reflect(wo, vndf_sample(wo, alpha, rng.next_vec2()));
                    let pdf = vndf_pdf(wo, wi, alpha) as f64;
                    let f = f_spec(DVec3::Z, wo.as_dvec3(), wi.as_dvec3(), alpha as f64);
                    if wi.z > 0.0 {
                        f * wi.z as f64 / pdf
                    } else {
                        0.0
                    }
                })
                .collect();
            let (m, se) = mean_se(&xs);
            let reference = sphere_integral(true, 1500, 1500, |wi| {
                f_spec(DVec3::Z, wo.as_dvec3(), wi.as_dvec3(), alpha as f64) * wi.z as f64
            });
            assert!(
                (m - reference).abs() < 5.0 * se + 2e-3 * reference,
                "alpha {alpha} theta {theta}: {m} ± {se} vs {reference}"
            );
        }
    }
}

#[test]
fn vndf_pdf_integrates_to_one_over_sphere_and_less_over_hemisphere_at_grazing() {
    for alpha in [0.3f32, 1.0] {
        for theta in [0.0f32, 60.0, 85.0] {
            let wo = view(theta);
            let sphere = sphere_integral(false, 2000, 1000, |wi| vndf_pdf(wo, wi, alpha) as f64);
            let hemi = sphere_integral(true, 1000, 1000, |wi| vndf_pdf(wo, wi, alpha) as f64);
            assert!(
                (sphere - 1.0).abs() < 5e-3,
                "alpha {alpha} theta {theta}: {sphere}"
            );
            assert!(hemi <= 1.0 + 5e-3, "alpha {alpha} theta {theta}: {hemi}");
            if alpha == 1.0 && theta == 85.0 {
                assert!(hemi < 0.95, "rays below the horizon: {hemi}");
            }
        }
    }
}

#[test]
fn vndf_sample_histogram_matches_pdf() {
    let (alpha, wo) = (0.5f32, view(60.0));
    let (nz, nphi) = (12usize, 16usize);
    let n = 400_000;
    let mut counts = vec![0f64; nz * nphi + 1]; // last bin: below the horizon
    let mut rng = Pcg32::new(12, 0);
    for _ in 0..n {
        let wi = reflect(wo, vndf_sample(wo, alpha, rng.next_vec2()));
        if wi.z <= 0.0 {
            counts[nz * nphi] += 1.0;
            continue;
        }
        let iz = ((wi.z * nz as f32) as usize).min(nz - 1);
        let phi = wi.y.atan2(wi.x).rem_euclid(std::f32::consts::TAU);
        let ip = ((phi / std::f32::consts::TAU * nphi as f32) as usize).min(nphi - 1);
        counts[iz * nphi + ip] += 1.0;
    }
    // Expected mass per bin by sub-quadrature of the pdf.
    let sub = 24;
    let mut expected = vec![0f64; nz * nphi + 1];
    for iz in 0..nz {
        for ip in 0..nphi {
            let mut mass = 0.0;
            for a in 0..sub {
                for b in 0..sub {
                    let z = (iz as f64 + (a as f64 + 0.5) / sub as f64) / nz as f64;
                    let phi = (ip as f64 + (b as f64 + 0.5) / sub as f64) / nphi as f64 * 2.0 * PI;
                    let r = (1.0 - z * z).sqrt();
                    let w = DVec3::new(r * phi.cos(), r * phi.sin(), z).as_vec3();
                    mass += vndf_pdf(wo, w, alpha) as f64;
                }
            }
            let cell = (1.0 / nz as f64) * (2.0 * PI / nphi as f64) / (sub * sub) as f64;
            expected[iz * nphi + ip] = mass * cell * n as f64;
        }
    }
    expected[nz * nphi] = n as f64 - expected[..nz * nphi].iter().sum::<f64>();
    let chi2 = chi_square(&counts, &expected);
    let bound = chi_square_bound(counts.len() - 1);
    assert!(chi2 < bound, "chi2 {chi2} > {bound}");
}

#[test]
fn cosine_hemisphere_expected_inverse_pdf_is_two_pi() {
    let mut rng = Pcg32::new(13, 0);
    let xs: Vec<f64> = (0..200_000)
        .map(|_| {
            let w = cosine_hemisphere(rng.next_vec2());
            assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0);
            // Integrand 1 on the hemisphere; pdf = cos/π.
            if w.z > 0.0 { PI / w.z as f64 } else { 0.0 }
        })
        .collect();
    // 1/pdf has infinite variance at the horizon; use z² uniformity instead
    // for a tight check and keep this one loose.
    let (m, _) = mean_se(&xs);
    assert!((m / (2.0 * PI) - 1.0).abs() < 0.05, "{m}");
    let mut rng = Pcg32::new(14, 0);
    let mut bins = [0u32; 10];
    for _ in 0..100_000 {
        let z = cosine_hemisphere(rng.next_vec2()).z;
        bins[((z * z * 10.0) as usize).min(9)] += 1;
    }
    for b in bins {
        assert!((b as i32 - 10_000).abs() < 500, "z² not uniform: {bins:?}");
    }
}

#[test]
fn sample_brdf_pdf_equals_brdf_pdf_and_directions_are_above_the_normal() {
    let mut rng = Pcg32::new(15, 0);
    for _ in 0..20_000 {
        let n = Vec3::new(
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
            rng.next_f32() - 0.5,
        )
        .normalize();
        let wo =
            (n + Vec3::new(rng.next_f32() - 0.5, rng.next_f32(), rng.next_f32() - 0.5)).normalize();
        let alpha = rng.next_f32().max(0.01);
        let p_spec = rng.next_f32();
        if let Some(s) = sample_brdf(n, wo, alpha, p_spec, rng.next_f32(), rng.next_vec2()) {
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            assert!(s.wi.dot(n) > 0.0);
            let pdf = brdf_pdf(n, wo, s.wi, alpha, p_spec);
            assert!((pdf / s.pdf - 1.0).abs() < 1e-3, "{pdf} vs {}", s.pdf);
        }
    }
}

#[test]
fn onb_is_orthonormal_and_right_handed_everywhere() {
    let mut rng = Pcg32::new(16, 0);
    let mut normals = vec![
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::X,
        Vec3::new(0.0, 1e-8, -1.0).normalize(),
    ];
    for _ in 0..10_000 {
        normals.push(
            Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            )
            .normalize(),
        );
    }
    for n in normals {
        let (t, b) = onb(n);
        assert!(
            (t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5,
            "{n}"
        );
        assert!(
            t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5,
            "{n}"
        );
        assert!((t.cross(b) - n).length() < 1e-5, "{n}");
    }
}

#[test]
fn lobe_probability_is_zero_or_one_for_a_missing_lobe() {
    assert_eq!(
        spec_lobe_probability(Vec3::splat(0.8), Vec3::ZERO, 0.5),
        0.0
    );
    assert_eq!(
        spec_lobe_probability(Vec3::ZERO, Vec3::splat(0.04), 0.5),
        1.0
    );
    let p = spec_lobe_probability(Vec3::splat(0.5), Vec3::splat(0.04), 0.9);
    assert!(p > 0.0 && p < 0.5, "{p}");
    // Fresnel grows toward grazing, so does the specular share.
    assert!(spec_lobe_probability(Vec3::splat(0.5), Vec3::splat(0.04), 0.05) > p);
    assert_eq!(spec_lobe_probability(Vec3::ZERO, Vec3::ZERO, 0.5), 0.0);
}

#[test]
fn wo_below_the_horizon_gives_no_brdf_sample() {
    assert!(sample_brdf(Vec3::Z, Vec3::NEG_Z, 0.5, 0.5, 0.2, Vec2::splat(0.5)).is_none());
    assert_eq!(
        brdf_pdf(Vec3::Z, Vec3::new(0.0, 0.6, -0.8), Vec3::Z, 0.5, 1.0),
        0.0
    );
}

#[test]
fn tiny_alpha_vndf_is_finite() {
    let wo = view(30.0);
    let mut rng = Pcg32::new(17, 0);
    for alpha in [0.0f32, 1e-6, 1e-4] {
        for _ in 0..1000 {
            let wi = reflect(wo, vndf_sample(wo, alpha, rng.next_vec2()));
            let pdf = vndf_pdf(wo, wi, alpha);
            assert!(
                wi.is_finite() && pdf.is_finite() && pdf > 0.0,
                "{alpha}: {wi} {pdf}"
            );
        }
    }
}

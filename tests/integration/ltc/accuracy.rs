//! Accuracy of the analytic U against brute-force area quadrature of the
//! same BRDF x light (`support::ltc`). Prints the error distribution:
//! `cargo test --release --test integration ltc::accuracy -- --nocapture`
//! (with `PENUMBRA_LTC_DUMP=1`, also every case: roughness, view, the light's
//! share of the lobe, the F0 = 1 error and the worst channel's error).

use crate::support::ltc::{
    facing_square, lobe_total, polygon_light, quad_light, quantile, reference, rel,
};
use glam::{Quat, Vec3};
use penumbra::scene::Light;
use penumbra::shading::{SurfacePoint, unshadowed_lobes};
use rayon::prelude::*;

const ROUGHNESS: [f32; 7] = [0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0];
const VIEW_DEG: [f32; 8] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0];
/// The accuracy goal: median relative error of the specular U for
/// roughness >= 0.2 (lights holding >= 1% of the lobe), asserted for the
/// worst of the three F0 channels and for F0 = 1 alone.
const TARGET_MEDIAN: f32 = 0.01;
/// Measured with the committed table and shape correction (roughness >= 0.2,
/// lights holding >= 1% of the lobe), rounded up; regression guards:
/// relative error of the F0 = 1 specular (max); of the worst of the three F0
/// channels (p90, max); error of lights holding < 1% of the lobe as a
/// fraction of the whole lobe. The worst case (a 2x2 light overhead,
/// roughness 0.2, view 89 degrees, holding 1.6% of the lobe: the grazing
/// lobe's far tail, which no transformed cosine follows and which the
/// correction's four nodes do not resolve, so it is left uncorrected) is
/// printed.
const MEASURED_METAL_MAX: f32 = 0.45;
const MEASURED_FRESNEL_P90: f32 = 0.1;
const MEASURED_FRESNEL_MAX: f32 = 0.85;
const MEASURED_MINOR_OF_LOBE: f32 = 0.003;
/// The reference's own bound: its estimated relative error (sum of the
/// adaptive quadrature's per-triangle error estimates) stays below this.
const REFERENCE_BOUND: f64 = 1e-2;

/// Specular F0 per channel: metal, half, dielectric (tests the Fresnel split).
const F0: Vec3 = Vec3::new(1.0, 0.5, 0.04);

/// A shading frame tilted away from the world axes, and an off-origin point,
/// so the frame construction is exercised too.
fn world() -> (Quat, Vec3) {
    (
        Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1),
        Vec3::new(1.0, 2.0, -0.5),
    )
}

/// Light placements in the local frame (n = +Z, view in +X): (name, light).
fn placements(view_deg: f32) -> Vec<(&'static str, Light)> {
    let t = view_deg.to_radians();
    let mirror = Vec3::new(-t.sin(), 0.0, t.cos());
    let l = Vec3::splat(1.0);
    let off = Quat::from_rotation_z(0.8) * Vec3::new(-0.6, 0.0, 0.8).normalize();
    vec![
        (
            "overhead 2x2 at height 2",
            facing_square(Vec3::new(0.0, 0.0, 2.0), -Vec3::Z, 1.0, l),
        ),
        (
            "1x1 on the mirror direction at 3",
            facing_square(mirror * 3.0, -mirror, 0.5, l),
        ),
        (
            "1x1 off the mirror direction",
            facing_square(off * 3.0, -off, 0.5, l),
        ),
        (
            "triangle to the side",
            polygon_light(
                &[
                    Vec3::new(-0.5, 2.0, 0.5),
                    Vec3::new(0.5, 2.0, 0.8),
                    Vec3::new(0.0, 2.0, 1.8),
                ],
                l,
                true,
            ),
        ),
        (
            "wall straddling the horizon, mirror side",
            quad_light(
                Vec3::new(-2.0, 0.0, 0.0),
                Vec3::new(0.0, 1.5, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
                l,
                false,
            ),
        ),
        (
            "20x20 ceiling at height 1",
            facing_square(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z, 10.0, l),
        ),
        (
            "long strip low over the mirror side",
            quad_light(
                Vec3::new(-4.0, 0.0, 0.5),
                Vec3::new(0.0, 2.0, 0.0),
                Vec3::new(0.3, 0.0, 0.0),
                l,
                true,
            ),
        ),
    ]
}

fn to_world(light: &Light, q: Quat, p: Vec3) -> Light {
    let v: Vec<Vec3> = light.vertices.iter().map(|v| q * *v + p).collect();
    polygon_light(&v, light.radiance, light.two_sided)
}

struct Case {
    roughness: f32,
    view: f32,
    place: &'static str,
    diffuse_err: f32,
    spec_err: f32,
    /// Relative error of each channel (F0 = 1, 0.5, 0.04).
    chan_err: [f32; 3],
    /// Relative error of the F0 = 1 channel alone (no Fresnel split).
    metal_err: f32,
    /// Specular U (F0 = 1) of this light over the whole lobe's.
    share: f32,
    /// |error| of the F0 = 1 specular over the whole lobe's value.
    spec_err_of_lobe: f32,
    ref_err: f64,
    evals: usize,
}

#[test]
fn ggx_and_lambert_match_brute_force_over_the_grid() {
    let (q, p) = world();
    let mut jobs = Vec::new();
    for &r in &ROUGHNESS {
        for &v in &VIEW_DEG {
            for (k, _) in placements(v).iter().enumerate() {
                jobs.push((r, v, k));
            }
        }
    }
    let cases: Vec<Case> = jobs
        .par_iter()
        .map(|&(roughness, view, k)| {
            let (place, local) = placements(view).swap_remove(k);
            let light = to_world(&local, q, p);
            let t = view.to_radians();
            let wo_local = Vec3::new(t.sin(), 0.0, t.cos());
            let sp = SurfacePoint {
                p,
                n: q * Vec3::Z,
                wo: q * wo_local,
                diffuse: Vec3::splat(0.5),
                specular: F0,
                roughness,
            };
            let (d, s) = unshadowed_lobes(&sp, &light);
            let r = reference(&sp, &light, 1e-5);
            let (rd, rs) = r.lobes(&sp, &light);
            let total = lobe_total(roughness, wo_local);
            let share = rs.x / total;
            let spec_err = (0..3).map(|c| rel(s[c], rs[c])).fold(0.0, f32::max);
            Case {
                roughness,
                view,
                place,
                diffuse_err: rel(d.x, rd.x),
                spec_err,
                chan_err: [0, 1, 2].map(|c| rel(s[c], rs[c])),
                metal_err: rel(s.x, rs.x),
                share,
                spec_err_of_lobe: (s.x - rs.x).abs() / total,
                ref_err: r.est_rel_err,
                evals: r.evals,
            }
        })
        .collect();

    if std::env::var_os("PENUMBRA_LTC_DUMP").is_some() {
        for c in &cases {
            println!(
                "DUMP r={} v={} share={:.4} metal={:.4} spec={:.4} {}",
                c.roughness, c.view, c.share, c.metal_err, c.spec_err, c.place
            );
        }
    }
    let worst_ref = cases.iter().map(|c| c.ref_err).fold(0.0, f64::max);
    let evals: usize = cases.iter().map(|c| c.evals).sum();
    println!(
        "reference quadrature: {evals} evaluations, worst estimated relative error {worst_ref:.1e}"
    );

    // Lambert: exact up to the quadrature's tolerance.
    let worst_d = cases
        .iter()
        .max_by(|a, b| a.diffuse_err.total_cmp(&b.diffuse_err))
        .unwrap();
    println!(
        "Lambert: worst relative error {:.2e} ({} cases; roughness {}, view {} deg, {})",
        worst_d.diffuse_err,
        cases.len(),
        worst_d.roughness,
        worst_d.view,
        worst_d.place
    );

    // GGX: relative error where the light holds >= 1% of the lobe; elsewhere
    // the error as a fraction of the whole lobe.
    let significant: Vec<&Case> = cases.iter().filter(|c| c.share >= 0.01).collect();
    let minor: Vec<&Case> = cases.iter().filter(|c| c.share < 0.01).collect();
    let report = |name: &str, set: &[&Case]| -> (f32, f32, f32) {
        let mut e: Vec<f32> = set.iter().map(|c| c.spec_err).collect();
        let (med, p90, max) = (
            quantile(&mut e, 0.5),
            quantile(&mut e, 0.9),
            quantile(&mut e, 1.0),
        );
        let w = set
            .iter()
            .max_by(|a, b| a.spec_err.total_cmp(&b.spec_err))
            .unwrap();
        println!(
            "GGX {name}: {} cases, relative error median {:.4}, p90 {:.4}, max {:.4} (roughness {}, view {} deg, {}, light holds {:.1}% of the lobe)",
            set.len(),
            med,
            p90,
            max,
            w.roughness,
            w.view,
            w.place,
            100.0 * w.share
        );
        (med, p90, max)
    };
    report("all significant, F0 = (1, 0.5, 0.04)", &significant);
    let rough: Vec<&Case> = significant
        .iter()
        .copied()
        .filter(|c| c.roughness >= 0.2)
        .collect();
    let rough_stats = report("roughness >= 0.2, F0 = (1, 0.5, 0.04)", &rough);
    let mut metal: Vec<f32> = rough.iter().map(|c| c.metal_err).collect();
    let (metal_med, metal_p90, metal_max) = (
        quantile(&mut metal, 0.5),
        quantile(&mut metal, 0.9),
        quantile(&mut metal, 1.0),
    );
    let wm = rough
        .iter()
        .max_by(|a, b| a.metal_err.total_cmp(&b.metal_err))
        .unwrap();
    println!(
        "GGX roughness >= 0.2, F0 = 1 only (LTC shape + magnitude, no Fresnel split): median {metal_med:.4}, p90 {metal_p90:.4}, max {metal_max:.4} (roughness {}, view {} deg, {})",
        wm.roughness, wm.view, wm.place
    );
    let mut per_f0 = String::new();
    for (c, f0) in [1.0, 0.5, 0.04].iter().enumerate() {
        let mut e: Vec<f32> = rough.iter().map(|k| k.chan_err[c]).collect();
        per_f0 += &format!(
            " F0={f0}: median {:.4}, p90 {:.4}, max {:.4};",
            quantile(&mut e, 0.5),
            quantile(&mut e, 0.9),
            quantile(&mut e, 1.0)
        );
    }
    println!("GGX roughness >= 0.2 per channel:{per_f0}");
    if rough_stats.0 > TARGET_MEDIAN || metal_med > TARGET_MEDIAN {
        println!(
            "NOTE: the 1% median target for roughness >= 0.2 is NOT met (F0 = 1 median {metal_med:.4}, worst-channel median {:.4}).",
            rough_stats.0
        );
    }
    let mut per_r = String::new();
    for &r in &ROUGHNESS {
        let mut e: Vec<f32> = significant
            .iter()
            .filter(|c| c.roughness == r)
            .map(|c| c.spec_err)
            .collect();
        per_r += &format!(
            " r={r}: med {:.4} max {:.4};",
            quantile(&mut e, 0.5),
            quantile(&mut e, 1.0)
        );
    }
    println!("GGX per roughness:{per_r}");
    let mut per_r = String::new();
    for &r in &ROUGHNESS {
        let mut e: Vec<f32> = significant
            .iter()
            .filter(|c| c.roughness == r)
            .map(|c| c.metal_err)
            .collect();
        per_r += &format!(
            " r={r}: med {:.4} max {:.4};",
            quantile(&mut e, 0.5),
            quantile(&mut e, 1.0)
        );
    }
    println!("GGX F0=1 only per roughness:{per_r}");
    let worst_minor = minor.iter().map(|c| c.spec_err_of_lobe).fold(0.0, f32::max);
    println!(
        "GGX minor lights (< 1% of the lobe, {} cases): worst |error| / lobe {:.4}",
        minor.len(),
        worst_minor
    );

    assert!(
        worst_ref <= REFERENCE_BOUND,
        "reference quadrature estimated error {worst_ref}"
    );
    assert!(
        worst_d.diffuse_err <= 1e-4,
        "Lambert error {}",
        worst_d.diffuse_err
    );
    assert!(
        metal_med <= TARGET_MEDIAN,
        "F0 = 1 median {metal_med} above the 1% target"
    );
    assert!(
        rough_stats.0 <= TARGET_MEDIAN,
        "worst-channel median {} above the 1% target",
        rough_stats.0
    );
    // Measured bounds (regression guards) of the tails:
    assert!(metal_max <= MEASURED_METAL_MAX, "F0 = 1 max {metal_max}");
    assert!(
        rough_stats.1 <= MEASURED_FRESNEL_P90,
        "p90 with Fresnel split {}",
        rough_stats.1
    );
    assert!(
        rough_stats.2 <= MEASURED_FRESNEL_MAX,
        "max with Fresnel split {}",
        rough_stats.2
    );
    assert!(
        worst_minor <= MEASURED_MINOR_OF_LOBE,
        "minor lights: {worst_minor} of the lobe"
    );
}

//! The seed paper's claims, stated as tests: the ratio estimator is
//! consistent, noise-free where lit, right on glossy receivers where a plain
//! soft-shadow answer is wrong, and less noisy than full Monte Carlo.

use crate::support::{Job, interior, load, rel_mse, rel_mse_where, render};
use penumbra::render::{Mode, PixelKind};

const W: u32 = 128;
const H: u32 = 72;

/// relMSE between two seeds of `reference` at 1024 spp on shadow-plane.
const REFERENCE_SEEDS_MAX_REL_MSE: f64 = 1e-3;
/// Least-squares slope of log relMSE against log spp over 1..64 spp: pure
/// noise falls with slope -1.
const RATIO_MAX_CONVERGENCE_SLOPE: f64 = -0.7;
/// relMSE of the undenoised ratio at 256 spp on shadow-plane: the LTC fit's
/// error on the near-mirror strip.
const RATIO_AT_256_SPP_MAX_REL_MSE: f64 = 4e-3;
/// soft-shadow's relMSE over the ratio's on the glossy and mirror strips.
const GLOSSY_MIN_SOFT_SHADOW_PENALTY: f64 = 5.0;
/// relMSE of the ratio, and of soft-shadow, on the diffuse strip.
const DIFFUSE_RATIO_MAX_REL_MSE: f64 = 2e-3;
const DIFFUSE_SOFT_SHADOW_MAX_REL_MSE: f64 = 5e-3;
/// soft-shadow's relMSE over the ratio's on room's shadowed glossy floor,
/// against `reference` and against pixel centres (3.8x and 76x measured at
/// 128x72 with these seeds; soft-shadow = ratio gives 1x).
const ROOM_MIN_SOFT_SHADOW_PENALTY_VS_REFERENCE: f64 = 3.0;
const ROOM_MIN_SOFT_SHADOW_PENALTY_VS_CENTRES: f64 = 30.0;

fn job(mode: Mode, spp: u32, seed: u32) -> Job {
    Job {
        width: W,
        height: H,
        mode,
        spp,
        seed,
        threads: 2,
        ..Job::default()
    }
}

#[test]
fn reference_converges_two_seeds_agree() {
    let scene = load("shadow-plane.toml");
    let a = render(&scene, &job(Mode::Reference, 1024, 1));
    let b = render(&scene, &job(Mode::Reference, 1024, 2));
    let inside = interior(&render(&scene, &job(Mode::Unshadowed, 1, 0)));
    let e = rel_mse_where(&a, &b, |k| inside[k]);
    // Penumbrae on the glossy strip dominate: there a sample's visibility is
    // a coin with p ~ 0.15, so 1024 samples leave ~15 % noise in a few pixels.
    println!("reference seed 1 vs seed 2 at 1024 spp: relMSE {e:.2e}");
    assert!(e < REFERENCE_SEEDS_MAX_REL_MSE, "relMSE {e}");
}

#[test]
fn undenoised_ratio_converges_to_reference() {
    let scene = load("shadow-plane.toml");
    let reference = render(&scene, &job(Mode::Reference, 2048, 7));
    let mut points = Vec::new();
    for spp in [1u32, 4, 16, 64, 256] {
        let f = render(&scene, &job(Mode::Ratio, spp, 3));
        let inside = interior(&f);
        let e = rel_mse_where(&f, &reference, |k| inside[k]);
        println!("ratio {spp:>3} spp: relMSE {e:.3e}");
        points.push(((spp as f64).ln(), e.ln()));
    }
    // Least-squares slope of log(relMSE) against log(spp) over 1..64 spp,
    // where noise dominates the (LTC and pixel-filter) bias.
    let fit = &points[..4];
    let (mx, my) = (
        fit.iter().map(|p| p.0).sum::<f64>() / 4.0,
        fit.iter().map(|p| p.1).sum::<f64>() / 4.0,
    );
    let slope = fit.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / fit.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    println!("slope of log relMSE vs log spp (1..64): {slope:.2}");
    assert!(
        slope < RATIO_MAX_CONVERGENCE_SLOPE,
        "relMSE does not fall with spp: slope {slope}"
    );
    let at256 = points[4].1.exp();
    // The floor is the LTC fit's error on the near-mirror strip: the ratio
    // converges to U_ltc * S / U, so a few percent of U bias remain there.
    assert!(
        at256 < RATIO_AT_256_SPP_MAX_REL_MSE,
        "relMSE at 256 spp: {at256}"
    );
}

#[test]
fn ratio_equals_unshadowed_without_occluders() {
    let mut scene = load("shadow-plane.toml");
    // Drop the occluder bar; the three receivers cannot shadow each other.
    scene
        .meshes
        .retain(|m| scene.materials[m.material as usize].name != "occluder");
    let ratio = render(&scene, &job(Mode::Ratio, 1, 0));
    let unshadowed = render(&scene, &job(Mode::Unshadowed, 1, 0));
    assert_eq!(
        crate::support::color_bytes(&ratio),
        crate::support::color_bytes(&unshadowed)
    );
}

#[test]
fn ratio_is_exactly_u_where_every_sample_is_unoccluded() {
    let scene = load("shadow-plane.toml");
    let f = render(&scene, &job(Mode::Ratio, 4, 0));
    let mut lit = 0;
    for k in 0..f.pixel_count() {
        if f.gbuf[k].kind == PixelKind::Surface && f.sn[k] == f.un[k] {
            assert_eq!(f.color[k], f.u[k], "pixel {k}");
            lit += 1;
        }
    }
    // Not vacuous: a good share of the frame is fully lit.
    assert!(lit > 1000, "only {lit} fully lit pixels");
}

#[test]
fn soft_shadow_is_wrong_on_glossy_receivers_and_ratio_is_not() {
    let scene = load("shadow-plane.toml");
    let reference = render(&scene, &job(Mode::Reference, 2048, 11));
    let ratio = render(&scene, &job(Mode::Ratio, 256, 5));
    let soft = render(&scene, &job(Mode::SoftShadow, 256, 5));
    let inside = interior(&ratio);
    let material = |name: &str| scene.materials.iter().position(|m| m.name == name).unwrap() as u32;
    let errors: Vec<_> = [("diffuse", false), ("glossy", true), ("mirror", true)]
        .into_iter()
        .map(|(name, glossy)| {
            let id = material(name);
            let on = |k: usize| {
                inside[k]
                    && ratio.gbuf[k].kind == PixelKind::Surface
                    && ratio.gbuf[k].material == id
            };
            let e_ratio = rel_mse_where(&ratio, &reference, on);
            let e_soft = rel_mse_where(&soft, &reference, on);
            println!("{name:>8}: relMSE ratio {e_ratio:.2e}, soft-shadow {e_soft:.2e}");
            (name, glossy, e_ratio, e_soft)
        })
        .collect();
    for (name, glossy, e_ratio, e_soft) in errors {
        if glossy {
            assert!(
                e_soft > GLOSSY_MIN_SOFT_SHADOW_PENALTY * e_ratio,
                "{name}: soft-shadow {e_soft} vs ratio {e_ratio}"
            );
        } else {
            assert!(
                e_ratio < DIFFUSE_RATIO_MAX_REL_MSE && e_soft < DIFFUSE_SOFT_SHADOW_MAX_REL_MSE,
                "{name}: ratio {e_ratio}, soft-shadow {e_soft}"
            );
        }
    }
}

/// The polished floor where a shadow falls (`report::stats::shadowed_glossy`:
/// `tiles` pixels of roughness below 0.3 with their 8 neighbours, away from
/// edges, where `probe`'s area-visibility S_N is below its U_N).
fn shadowed_glossy_floor(
    scene: &penumbra::scene::Scene,
    probe: &penumbra::render::Frame,
) -> Vec<bool> {
    let tiles = scene
        .materials
        .iter()
        .position(|m| m.name == "tiles")
        .unwrap() as u32;
    penumbra::report::stats::shadowed_glossy(probe, tiles, 0.3)
}

#[test]
fn soft_shadow_is_wrong_on_the_glossy_floor_of_room_and_ratio_is_not() {
    let scene = load("room.toml");
    // Two truths: `reference` (jittered, box-filtered pixels) and the same
    // MIS estimator converged at pixel centres, where `ratio` and
    // `soft-shadow` sample too. Against the first, every pixel-centred mode
    // also carries the box filter's blur of the sharp reflections on the
    // polished floor; the second leaves only the estimators' own error.
    let reference = render(&scene, &job(Mode::Reference, 1024, 17));
    let centred = render(&scene, &job(Mode::Stochastic, 1024, 17));
    // An independent soft-shadow frame says where the light is blocked.
    let mask = shadowed_glossy_floor(&scene, &render(&scene, &job(Mode::SoftShadow, 32, 9)));
    let n = mask.iter().filter(|&&m| m).count();
    let ratio = render(&scene, &job(Mode::Ratio, 256, 5));
    let soft = render(&scene, &job(Mode::SoftShadow, 256, 5));
    let mut factors = Vec::new();
    for (truth, name) in [(&reference, "reference"), (&centred, "stochastic 1024 spp")] {
        let e_ratio = rel_mse_where(&ratio, truth, |k| mask[k]);
        let e_soft = rel_mse_where(&soft, truth, |k| mask[k]);
        println!(
            "room, shadowed glossy floor ({n} px), 256 spp, undenoised, against {name}: relMSE ratio {e_ratio:.2e}, soft-shadow {e_soft:.2e} ({:.1}x)",
            e_soft / e_ratio
        );
        factors.push(e_soft / e_ratio);
    }
    // The figure needs the shadow to fall on the glossy floor in view: 1423
    // pixels (15 % of the frame) here; a room whose polished tiles are few and
    // mostly lit has 108 and fails here.
    assert!(n > 500, "only {n} shadowed glossy floor pixels");
    assert!(
        factors[0] > ROOM_MIN_SOFT_SHADOW_PENALTY_VS_REFERENCE,
        "against reference: {}x",
        factors[0]
    );
    assert!(
        factors[1] > ROOM_MIN_SOFT_SHADOW_PENALTY_VS_CENTRES,
        "against pixel centres: {}x",
        factors[1]
    );
}

#[test]
fn at_one_spp_ratio_beats_stochastic_on_room() {
    let scene = load("room.toml");
    let reference = render(&scene, &job(Mode::Reference, 512, 13));
    let ratio = rel_mse(&render(&scene, &job(Mode::Ratio, 1, 1)), &reference);
    let stochastic = rel_mse(&render(&scene, &job(Mode::Stochastic, 1, 1)), &reference);
    println!("room, 1 spp, undenoised: relMSE ratio {ratio:.3e}, stochastic {stochastic:.3e}");
    assert!(
        ratio < stochastic,
        "ratio {ratio} vs stochastic {stochastic}"
    );
}

#[test]
fn no_aov_has_nan_or_inf_on_any_shipped_scene() {
    use penumbra::output::Aov;
    for name in [
        "default.toml",
        "shadow-plane.toml",
        "room.toml",
        "many-tris.toml",
    ] {
        let scene = load(name);
        for mode in Mode::ALL {
            let f = render(&scene, &job(mode, 2, 0));
            assert!(
                f.color.iter().all(|c| c.is_finite()),
                "{name} {mode}: colour"
            );
            for aov in Aov::ALL {
                let values = aov.values(&f);
                assert!(
                    values.iter().all(|v| v.is_finite()),
                    "{name} {mode}: {}",
                    aov.name()
                );
            }
        }
    }
}

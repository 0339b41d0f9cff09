//! docs/scene-format.md: `specular = [0, 0, 0]` means *no specular lobe*. Schlick's
//! Fresnel `F0 + (1 - F0)(1 - wo.h)^5` would still be > 0 at grazing views
//! with F0 = 0; the Monte Carlo estimators (stochastic, reference) must not
//! pick that term up, or they disagree with `U` and with any independent
//! renderer on every Lambert-only surface seen at a grazing angle.

use crate::support::{Job, parse, render};
use glam::Vec3;
use penumbra::render::{Mode, PixelKind};
use penumbra::shading::brdf::eval_local;

#[test]
fn zero_specular_brdf_is_exactly_lambert_at_grazing_views() {
    let diffuse = Vec3::new(0.8, 0.5, 0.2);
    let wo = Vec3::new(89.5f32.to_radians().sin(), 0.0, 89.5f32.to_radians().cos());
    for (x, y) in [(-0.9, 0.1), (-0.5, 0.3), (0.2, -0.7), (0.0, 0.0)] {
        let wi = Vec3::new(x, y, 1.0).normalize();
        for roughness in [0.05, 0.5, 1.0] {
            let f = eval_local(wi, wo, diffuse, Vec3::ZERO, roughness);
            assert_eq!(
                f,
                diffuse / std::f32::consts::PI,
                "wi {wi} roughness {roughness}"
            );
        }
    }
}

/// A Lambert-only floor seen at grazing angles, lit by a quad light facing the
/// camera over its far end (the room's ceiling lit by its wall light is this case): with
/// nothing to shadow, converged `stochastic` equals the exact form factor of
/// `unshadowed`. With the grazing Schlick term the far pixels came out ~10 %
/// too bright (relMSE ~1e-2 there).
#[test]
fn stochastic_converges_to_the_exact_lambert_u_on_a_grazing_lambert_floor() {
    let scene = parse(
        r#"
[camera]
eye    = [0.0, 0.3, -6.0]
target = [0.0, 0.0, 4.0]
fov_y  = 40.0

[[material]]
name      = "matte"
diffuse   = [0.8, 0.8, 0.8]
specular  = [0.0, 0.0, 0.0]
roughness = 1.0

[[object]]
material = "matte"
type     = "quad"
center   = [0.0, 0.0, 0.0]
u        = [0.0, 0.0, 6.0]
v        = [6.0, 0.0, 0.0]

[[light]]
type     = "quad"
center   = [0.0, 0.6, 6.5]
u        = [0.0, 0.5, 0.0]
v        = [1.5, 0.0, 0.0]
radiance = [6.0, 6.0, 6.0]
"#,
    );
    let job = |mode, spp| Job {
        width: 64,
        height: 36,
        mode,
        spp,
        seed: 5,
        threads: 2,
        ..Job::default()
    };
    let u = render(&scene, &job(Mode::Unshadowed, 1));
    let s = render(&scene, &job(Mode::Stochastic, 4096));
    let (mut sum, mut n) = (0.0f64, 0usize);
    for k in 0..u.pixel_count() {
        if u.gbuf[k].kind != PixelKind::Surface || u.color[k].x <= 0.0 {
            continue;
        }
        let e = (s.color[k].x - u.color[k].x) as f64 / u.color[k].x as f64;
        sum += e * e;
        n += 1;
    }
    let rel_mse = sum / n as f64;
    println!("{n} floor pixels: relMSE of 4096-spp stochastic against U {rel_mse:.2e}");
    assert!(n > 500, "only {n} lit floor pixels");
    assert!(rel_mse < 1e-4, "relMSE {rel_mse}");
}

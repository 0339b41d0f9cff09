//! The bounds of the `U` stage's light culling (`shading::light_bound`):
//! over random tiles of shading points (a small patch of a surface, normals
//! bent as a normal map bends them, views toward one eye, mixed roughness
//! and albedo, now and then a view under the shading horizon) and random
//! lights near and far, each light's bound is at least the `U` the renderer
//! computes for it at every point of the tile, lobe by lobe, per tile and
//! per point; the bounds are not vacuous; the wide `f32` Lambert kernel
//! keeps to its rounding bound.

use crate::support::rng::XorShift64 as Rng;
use glam::{Quat, Vec3, vec3};
use penumbra::color::luminance;
use penumbra::scene::Light;
use penumbra::shading::brdf::alpha_from_roughness;
use penumbra::shading::far_light::{WidePoints, form_factor_rounding, form_factors, ggx_bounds};
use penumbra::shading::light_bound::{LightExtent, PointGroup};
use penumbra::shading::u_batch::{
    BatchLight, LANES, LaneLobes, PIXEL_TOL, PixelBatch, RADIANCE_TOL, lobes_batch,
};
use penumbra::shading::{ShadingLight, SurfacePoint, unshadowed_lobes_prepared};

/// Tiles and lights drawn.
const TILES: usize = 300;
const LIGHTS_PER_TILE: usize = 12;
/// Points of a tile (8 x 8 pixels).
const POINTS: usize = 64;
/// Rounding allowance of a bound against the computed `U` (relative), and
/// the batch's stated `f32` accuracy on top of it (`u_batch::PIXEL_TOL`,
/// `RADIANCE_TOL`): a lobe the bound says is nearly 0 may come out of the
/// lanes as rounding noise of that size.
const ROUNDING: f32 = 1e-4;
/// At least this share of the drawn (tile, light) pairs must get a finite
/// bound below the plain `L * (kd + F0-free albedo 1)` one, or the test
/// would pass on bounds that never cull.
const MIN_USEFUL_SHARE: f64 = 0.5;

fn quad(c: Vec3, q: Quat, half: (f32, f32), radiance: Vec3, two_sided: bool) -> Light {
    let (u, v) = (q * vec3(half.0, 0.0, 0.0), q * vec3(0.0, half.1, 0.0));
    Light {
        vertices: vec![c - u - v, c + u - v, c + u + v, c - u + v],
        radiance,
        two_sided,
        normal: q * Vec3::Z,
        area: 4.0 * half.0 * half.1,
        quad: Some((c, u, v)),
    }
}

/// A tile: points on a patch of the plane through `o` with normal `n`,
/// shading normals bent by up to `bend` radians, seen from `eye`.
fn tile(rng: &mut Rng) -> Vec<SurfacePoint> {
    let o = vec3(
        rng.range(-5.0, 5.0),
        rng.range(-1.0, 1.0),
        rng.range(-5.0, 5.0),
    );
    let n = rng.direction();
    let (t, b) = n.any_orthonormal_pair();
    let size = rng.pick(&[0.01, 0.05, 0.2, 0.6]);
    let bend = rng.pick(&[0.0, 0.1, 0.4]);
    let eye = o + (n + 0.8 * rng.direction()).normalize() * rng.range(0.5, 10.0);
    let rough = (rng.range(0.02, 1.0), rng.range(0.0, 0.3));
    let ks = rng.pick(&[0.0, 0.04, 0.5, 1.0]);
    (0..POINTS)
        .map(|k| {
            let (x, y) = ((k % 8) as f32 / 7.0 - 0.5, (k / 8) as f32 / 7.0 - 0.5);
            let p = o + size * (x * t + y * b);
            let wo = (eye - p).normalize();
            let mut ns = (n + bend * rng.range(0.0, 1.0) * rng.direction()).normalize();
            // Mostly facing the view; now and then bent past it, as a
            // normal map bends a normal (the view under its horizon).
            if ns.dot(wo) < 0.0 && rng.f32() < 0.8 {
                ns = -ns;
            }
            SurfacePoint {
                p,
                n: ns,
                wo,
                diffuse: Vec3::splat(rng.range(0.0, 0.9)),
                specular: Vec3::splat(ks * rng.range(0.5, 1.0)),
                roughness: (rough.0 + rough.1 * rng.range(-1.0, 1.0)).clamp(0.0, 1.0),
            }
        })
        .collect()
}

fn light(rng: &mut Rng, near: Vec3) -> Light {
    let q = Quat::from_euler(
        glam::EulerRot::XYZ,
        rng.range(-3.1, 3.1),
        rng.range(-3.1, 3.1),
        rng.range(-3.1, 3.1),
    );
    let dist = rng.pick(&[0.5, 1.5, 4.0, 12.0, 40.0]) * rng.range(0.7, 1.3);
    let half = (rng.range(0.05, 0.8), rng.range(0.05, 0.8));
    let radiance = vec3(
        rng.range(0.5, 20.0),
        rng.range(0.5, 20.0),
        rng.range(0.5, 20.0),
    );
    quad(
        near + dist * rng.direction(),
        q,
        half,
        radiance,
        rng.f32() < 0.2,
    )
}

/// Luminance of each lobe of `light` at every point, as the `U` stage computes it.
fn lobes(points: &[SurfacePoint], light: &Light) -> Vec<(f32, f32)> {
    let bl = BatchLight::new(light);
    let mut out = Vec::new();
    let mut lanes = LaneLobes::default();
    for chunk in points.chunks(LANES) {
        let pts: [Option<SurfacePoint>; LANES] = std::array::from_fn(|l| chunk.get(l).copied());
        lobes_batch(&PixelBatch::new(&pts), &bl, &mut lanes);
        for l in 0..chunk.len() {
            let (d, s) = lanes.lane(l);
            out.push((luminance(d), luminance(s)));
        }
    }
    out
}

#[test]
fn a_light_bound_holds_at_every_point_of_its_tile() {
    let mut rng = Rng::new(0x11b0);
    let (mut pairs, mut useful) = (0usize, 0usize);
    let mut tightest = [0.0f32; 2];
    for _ in 0..TILES {
        let points = tile(&mut rng);
        let group = PointGroup::new(&points).expect("a tile has points");
        for _ in 0..LIGHTS_PER_TILE {
            let l = light(&mut rng, points[0].p);
            let bound = group.bound(&LightExtent::new(&l));
            pairs += 1;
            if bound.total() < luminance(l.radiance) * 1.9 {
                useful += 1;
            }
            for (k, (d, s)) in lobes(&points, &l).into_iter().enumerate() {
                if bound.diffuse > 0.0 && bound.diffuse.is_finite() {
                    tightest[0] = tightest[0].max(d / bound.diffuse);
                }
                if bound.specular > 0.0 && bound.specular.is_finite() {
                    tightest[1] = tightest[1].max(s / bound.specular);
                }
                assert!(
                    d <= bound.diffuse * (1.0 + ROUNDING) + 1e-12,
                    "Lambert {d:e} over its bound {:e} at point {k} of a tile, light {l:?}",
                    bound.diffuse
                );
                assert!(
                    s <= bound.specular * (1.0 + ROUNDING) + 1e-12,
                    "GGX {s:e} over its bound {:e} at point {k} of a tile, light {l:?}",
                    bound.specular
                );
            }
        }
    }
    println!(
        "largest U / bound: Lambert {:.3}, GGX {:.3}",
        tightest[0], tightest[1]
    );
    let share = useful as f64 / pairs as f64;
    assert!(
        share >= MIN_USEFUL_SHARE,
        "only {share:.2} of the bounds are below the light's plain bound"
    );
}

#[test]
fn a_light_that_faces_away_from_a_tile_bounds_to_zero() {
    let points: Vec<SurfacePoint> = (0..POINTS)
        .map(|k| SurfacePoint {
            p: vec3((k % 8) as f32 * 0.01, 0.0, (k / 8) as f32 * 0.01),
            n: Vec3::Y,
            wo: vec3(0.0, 1.0, -1.0).normalize(),
            diffuse: Vec3::splat(0.5),
            specular: Vec3::splat(0.04),
            roughness: 0.3,
        })
        .collect();
    let group = PointGroup::new(&points).expect("a tile has points");
    // Above the tile, emitting upwards (away from it).
    let up = quad(
        vec3(0.0, 3.0, 0.0),
        Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        (0.5, 0.5),
        Vec3::ONE,
        false,
    );
    assert!(up.normal.y > 0.99);
    let bound = group.bound(&LightExtent::new(&up));
    assert_eq!((bound.diffuse, bound.specular), (0.0, 0.0));
    // Below the tile's horizon, facing it.
    let below = quad(
        vec3(0.0, -3.0, 0.0),
        Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        (0.5, 0.5),
        Vec3::ONE,
        false,
    );
    let bound = group.bound(&LightExtent::new(&below));
    assert_eq!((bound.diffuse, bound.specular), (0.0, 0.0));
}

fn wide_points(points: &[SurfacePoint]) -> WidePoints {
    let mut wide = WidePoints::default();
    for sp in points {
        let alpha = alpha_from_roughness(sp.roughness);
        wide.push(sp.p, sp.n, sp.wo, alpha, sp.specular.max_element());
    }
    wide.finish();
    wide
}

#[test]
fn a_light_bound_per_point_holds_for_its_ggx_lobe_near_or_far() {
    let mut rng = Rng::new(0x6c1);
    let (mut far_cases, mut tightest, mut useful) = (0usize, 0.0f32, 0usize);
    for _ in 0..TILES {
        let points = tile(&mut rng);
        let group = PointGroup::new(&points).expect("a tile has points");
        let wide = wide_points(&points);
        let mut bound = vec![0.0; points.len()];
        for _ in 0..LIGHTS_PER_TILE {
            let l = light(&mut rng, points[0].p);
            let extent = LightExtent::new(&l);
            if group.far_view(&extent).is_some() {
                far_cases += 1;
            }
            ggx_bounds(&wide, &extent, &mut bound);
            let tile_bound = group.bound(&extent).specular;
            let radiance = luminance(l.radiance);
            let noise = RADIANCE_TOL * l.radiance.max_element();
            for (k, (d, s)) in lobes(&points, &l).into_iter().enumerate() {
                let b = bound[k] * radiance;
                assert!(
                    s <= b * (1.0 + ROUNDING) + PIXEL_TOL * (d + s) + noise + 1e-12,
                    "GGX {s:e} over its per-point bound {b:e} at point {k}, light {l:?}"
                );
                if b > 0.0 {
                    tightest = tightest.max(s / b);
                }
                if b < tile_bound {
                    useful += 1;
                }
            }
        }
    }
    assert!(far_cases >= TILES, "only {far_cases} far cases drawn");
    assert!(useful > 0, "the per-point bound is never below the tile's");
    println!("largest GGX / per-point bound: {tightest:.3}");
}

#[test]
fn the_wide_lambert_kernel_gives_the_form_factor_to_its_rounding_bound() {
    let mut rng = Rng::new(0x1a3b);
    let (mut far_cases, mut worst) = (0usize, 0.0f32);
    for _ in 0..TILES {
        let points = tile(&mut rng);
        let group = PointGroup::new(&points).expect("a tile has points");
        let wide = wide_points(&points);
        let mut ff = vec![0.0; points.len()];
        for _ in 0..LIGHTS_PER_TILE {
            let l = light(&mut rng, points[0].p);
            let Some(view) = group.far_view(&LightExtent::new(&l)) else {
                continue;
            };
            far_cases += 1;
            form_factors(&wide, &l.vertices, &mut ff);
            let bound = form_factor_rounding(l.vertices.len(), view.near, view.scale);
            let scalar = ShadingLight::new(&l);
            for (k, sp) in points.iter().enumerate() {
                let plain = SurfacePoint {
                    diffuse: Vec3::ONE,
                    specular: Vec3::ZERO,
                    ..*sp
                };
                let exact = unshadowed_lobes_prepared(&plain, &scalar).0.x / l.radiance.x;
                let err = (ff[k] - exact).abs();
                worst = worst.max(err / bound);
                assert!(
                    err <= bound,
                    "form factor {} against {exact} (bound {bound:e}) at point {k}, light {l:?}",
                    ff[k]
                );
            }
        }
    }
    assert!(far_cases >= TILES, "only {far_cases} far cases drawn");
    println!("worst error / rounding bound: {worst:.3}");
}

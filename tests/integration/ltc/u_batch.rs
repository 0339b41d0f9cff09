//! The batched U (`shading::u_batch`, `f32` lanes) against the `f64`
//! scalar path, lane by lane, over random shading points and lights
//! (triangles to octagons, one- and two-sided, near, far, tiny, huge,
//! straddling the horizon, far from the origin).
//!
//! Stated tolerance (`u_batch::PIXEL_TOL`, `RADIANCE_TOL`), per channel:
//! `U` (both lobes) and each lobe within 1e-3 of the pixel's whole `U`
//! plus 1e-8 of the light's radiance. The batch sends a lane to the scalar
//! path only where the point lies (nearly) in the light's plane or its LTC
//! map is too ill-conditioned for `f32` (`u_batch::MAX_CONDITION`).

use crate::support::rng::XorShift64 as Rng;
use glam::{Quat, Vec3, vec3};
use penumbra::scene::Light;
use penumbra::shading::u_batch::{
    BatchLight, LANES, LaneCounts, LaneLobes, PIXEL_TOL, PixelBatch, RADIANCE_TOL, lobes_batch,
};
use penumbra::shading::{ShadingLight, SurfacePoint, unshadowed_lobes_prepared};

/// A regular convex `n`-gon of radius `r` around `c`, turned by `q`.
fn polygon_light(c: Vec3, r: f32, n: usize, q: Quat, two_sided: bool) -> Light {
    let vertices: Vec<Vec3> = (0..n)
        .map(|k| {
            let a = k as f32 * std::f32::consts::TAU / n as f32;
            c + q * vec3(r * a.cos(), r * a.sin(), 0.0)
        })
        .collect();
    Light {
        vertices,
        radiance: vec3(3.0, 2.0, 1.0),
        two_sided,
        normal: q * Vec3::Z,
        area: 0.5 * n as f32 * r * r * (std::f32::consts::TAU / n as f32).sin(),
        quad: None,
    }
}

/// A random light from one of several families (see the module comment).
fn random_light(rng: &mut Rng, origin: Vec3) -> Light {
    let q = Quat::from_euler(
        glam::EulerRot::XYZ,
        rng.range(-3.1, 3.1),
        rng.range(-3.1, 3.1),
        rng.range(-3.1, 3.1),
    );
    let n = 3 + (rng.f32() * 6.0) as usize;
    let two_sided = rng.f32() < 0.3;
    let dir = rng.direction();
    let (dist, r) = match (rng.f32() * 6.0) as u32 {
        0 => (rng.range(0.5, 3.0), rng.range(0.05, 1.5)), // ordinary
        1 => (rng.range(0.2, 1.0), rng.range(0.5, 3.0)),  // near and large
        2 => (rng.range(1.0, 10.0), rng.range(1e-3, 1e-2)), // small
        3 => (rng.range(100.0, 1e4), rng.range(0.1, 10.0)), // distant
        4 => (rng.range(0.5, 3.0), rng.range(1e-4, 1e-3)), // tiny (1e-8..1e-6 sr)
        _ => (rng.range(0.01, 0.2), rng.range(1.0, 100.0)), // almost the hemisphere
    };
    polygon_light(origin + dir * dist, r, n.min(8), q, two_sided)
}

fn random_point(rng: &mut Rng, origin: Vec3) -> SurfacePoint {
    let n = rng.direction();
    // Views from the normal to past grazing (shading normals).
    let wo = (n * rng.range(-0.05, 1.0) + rng.direction()).normalize_or(n);
    let spec = match (rng.f32() * 4.0) as u32 {
        0 => Vec3::ZERO,
        1 => Vec3::ONE,
        2 => Vec3::splat(0.04),
        _ => vec3(rng.f32(), rng.f32(), rng.f32()),
    };
    SurfacePoint {
        p: origin + vec3(rng.f32(), rng.f32(), rng.f32()) * 0.1,
        n,
        wo,
        diffuse: if rng.f32() < 0.2 {
            Vec3::ZERO
        } else {
            vec3(rng.f32(), rng.f32(), rng.f32())
        },
        specular: spec,
        roughness: if rng.f32() < 0.1 {
            0.0
        } else {
            rng.f32().powf(0.7)
        },
    }
}

/// Largest deviation of the batch from the scalar path, per channel, as a
/// share of what the stated tolerance allows: `U = diffuse + specular` and
/// each lobe against `PIXEL_TOL` of the larger `U` plus `RADIANCE_TOL` of
/// the light's radiance `radiance`. At most 1 passes.
fn deviation(batch: (Vec3, Vec3), scalar: (Vec3, Vec3), radiance: Vec3) -> f32 {
    let mut worst: f32 = 0.0;
    for c in 0..3 {
        let (bd, bs, sd, ss) = (batch.0[c], batch.1[c], scalar.0[c], scalar.1[c]);
        assert!(bd.is_finite() && bd >= 0.0 && bs.is_finite() && bs >= 0.0);
        let allowed = PIXEL_TOL * (bd + bs).max(sd + ss) + RADIANCE_TOL * radiance[c];
        if allowed == 0.0 {
            assert_eq!((bd, bs), (sd, ss), "a dark channel must match exactly");
            continue;
        }
        let off = ((bd + bs) - (sd + ss))
            .abs()
            .max((bd - sd).abs())
            .max((bs - ss).abs());
        worst = worst.max(off / allowed);
    }
    worst
}

/// Runs `groups` random batches around `origin`; returns the worst
/// deviation and how the lanes went.
fn compare(seed: u64, groups: usize, origin: Vec3) -> (f32, LaneCounts) {
    let mut rng = Rng::new(seed);
    let mut worst: f32 = 0.0;
    let mut counts = LaneCounts::default();
    for _ in 0..groups {
        let light = random_light(&mut rng, origin);
        let (bl, sl) = (BatchLight::new(&light), ShadingLight::new(&light));
        // Some lanes empty, as at the end of a row.
        let points: [Option<SurfacePoint>; LANES] = std::array::from_fn(|_| {
            let p = random_point(&mut rng, origin);
            (rng.f32() > 0.05).then_some(p)
        });
        let batch = PixelBatch::new(&points);
        let mut out = LaneLobes::default();
        let c = lobes_batch(&batch, &bl, &mut out);
        counts.fast += c.fast;
        counts.scalar += c.scalar;
        for (l, p) in points.iter().enumerate() {
            let got = out.lane(l);
            let want = match p {
                Some(sp) => unshadowed_lobes_prepared(sp, &sl),
                None => (Vec3::ZERO, Vec3::ZERO),
            };
            let d = deviation(got, want, light.radiance);
            assert!(
                d <= 1.0,
                "deviation {d} of the tolerance: batch {got:?}, scalar {want:?}, point {p:?}, light {light:?}"
            );
            worst = worst.max(d);
        }
    }
    (worst, counts)
}

#[test]
fn batch_equals_scalar_path_within_tolerance() {
    let (worst, counts) = compare(0x2545_f491_4f6c_dd1d, 4000, Vec3::ZERO);
    eprintln!(
        "u_batch vs scalar: worst deviation {worst:.2e} of the tolerance; lanes fast {} / scalar {}",
        counts.fast, counts.scalar
    );
}

#[test]
fn batch_equals_scalar_path_far_from_the_origin() {
    let (worst, counts) = compare(0x9e37_79b9_7f4a_7c15, 1000, vec3(1e4, -1e4, 1e4));
    eprintln!(
        "u_batch vs scalar at 1e4: worst {worst:.2e} of the tolerance; lanes fast {} / scalar {}",
        counts.fast, counts.scalar
    );
}

#[test]
fn ordinary_lights_take_the_fast_path() {
    // A quad overhead, points on the floor below it with random views and
    // roughness 0.2-1, F0 0.04: no point lies in the light's plane and no
    // LTC map is ill-conditioned, so every lane stays in the batch
    // (otherwise the equality tests above would prove little).
    let mut rng = Rng::new(7);
    let light = polygon_light(
        vec3(0.0, 0.0, 2.0),
        0.7,
        4,
        Quat::from_rotation_x(std::f32::consts::PI),
        false,
    );
    let counts = lane_counts(&light, 100, || {
        let p = vec3(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0);
        let eye = vec3(
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(0.5, 3.0),
        );
        SurfacePoint {
            p,
            n: Vec3::Z,
            wo: (eye - p).normalize(),
            diffuse: Vec3::splat(0.5),
            specular: Vec3::splat(0.04),
            roughness: rng.range(0.2, 1.0),
        }
    });
    assert_eq!(counts.scalar, 0, "{counts:?}");
}

#[test]
fn sharp_lobes_at_oblique_views_take_the_scalar_path_and_rough_ones_do_not() {
    // The light of `ordinary_lights_take_the_fast_path`, a point seen at
    // 80 degrees: roughness 0.05's LTC map squeezes the view's plane past
    // `MAX_CONDITION`, roughness 0.5's does not.
    let light = polygon_light(
        vec3(0.0, 0.0, 2.0),
        0.7,
        4,
        Quat::from_rotation_x(std::f32::consts::PI),
        false,
    );
    let view = vec3(80f32.to_radians().sin(), 0.0, 80f32.to_radians().cos());
    let point = |roughness| SurfacePoint {
        p: vec3(0.3, 0.0, 0.0),
        n: Vec3::Z,
        wo: view,
        diffuse: Vec3::splat(0.5),
        specular: Vec3::ONE,
        roughness,
    };
    let sharp = lane_counts(&light, 1, || point(0.05));
    assert_eq!(sharp.scalar, LANES as u64, "{sharp:?}");
    let rough = lane_counts(&light, 1, || point(0.5));
    assert_eq!(rough.scalar, 0, "{rough:?}");
}

/// How the lanes of `batches` full batches of points made by `point` went
/// under `light`.
fn lane_counts(
    light: &Light,
    batches: usize,
    mut point: impl FnMut() -> SurfacePoint,
) -> LaneCounts {
    let bl = BatchLight::new(light);
    let mut counts = LaneCounts::default();
    for _ in 0..batches {
        let points: [Option<SurfacePoint>; LANES] = std::array::from_fn(|_| Some(point()));
        let c = lobes_batch(&PixelBatch::new(&points), &bl, &mut LaneLobes::default());
        counts.fast += c.fast;
        counts.scalar += c.scalar;
    }
    counts
}

#[test]
fn lights_straddling_the_horizons_of_a_floor_take_the_fast_path() {
    // A wall light whose bottom edge is 0.3 above a floor whose shading
    // normals wobble by up to ~0.3 rad: it straddles the horizon of a large
    // share of the points (a quarter here). Those lanes are clipped in the
    // batch; on the scalar path each would cost about four vector lanes'
    // time.
    let mut rng = Rng::new(5);
    let light = polygon_light(
        vec3(0.0, 2.0, 1.0),
        0.7,
        4,
        Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        false,
    );
    let mut straddling = 0;
    let counts = lane_counts(&light, 200, || {
        let p = vec3(rng.range(-2.0, 2.0), rng.range(-1.0, 1.5), 0.0);
        let n = (Vec3::Z + 0.3 * rng.direction()).normalize();
        let low = light.vertices.iter().any(|v| n.dot(*v - p) < 0.0);
        let high = light.vertices.iter().any(|v| n.dot(*v - p) > 0.0);
        straddling += usize::from(low && high);
        let eye = vec3(rng.range(-3.0, 3.0), -4.0, rng.range(0.5, 3.0));
        SurfacePoint {
            p,
            n,
            wo: (eye - p).normalize(),
            diffuse: Vec3::splat(0.5),
            specular: Vec3::splat(0.04),
            roughness: rng.range(0.05, 1.0),
        }
    });
    assert!(straddling >= 150, "only {straddling} straddling lanes");
    assert!(counts.scalar * 100 <= counts.fast, "{counts:?}");
}

/// A 1x1 quad 1 above the origin tilted by 0.3 rad, two-sided, and a point
/// at the origin facing up: the light straddles the point's horizon.
fn straddling_case() -> (Light, SurfacePoint) {
    let light = polygon_light(
        vec3(0.0, 1.0, 0.0),
        0.5,
        4,
        Quat::from_rotation_x(0.3),
        true,
    );
    let sp = SurfacePoint {
        p: Vec3::ZERO,
        n: Vec3::Z,
        wo: vec3(0.3, 0.0, 1.0).normalize(),
        diffuse: Vec3::splat(0.5),
        specular: Vec3::splat(0.04),
        roughness: 0.3,
    };
    (light, sp)
}

#[test]
fn a_light_straddling_the_horizon_is_clipped_on_the_fast_path() {
    let (light, sp) = straddling_case();
    let (bl, sl) = (BatchLight::new(&light), ShadingLight::new(&light));
    let mut out = LaneLobes::default();
    let c = lobes_batch(&PixelBatch::new(&[Some(sp)]), &bl, &mut out);
    assert_eq!(c, LaneCounts { fast: 1, scalar: 0 });
    let (got, want) = (out.lane(0), unshadowed_lobes_prepared(&sp, &sl));
    assert!(want.0.x > 0.0 && want.1.x > 0.0, "{want:?}");
    let d = deviation(got, want, light.radiance);
    assert!(
        d <= 1.0,
        "deviation {d} of the tolerance: batch {got:?}, scalar {want:?}"
    );
    assert!((1..LANES).all(|l| out.lane(l) == (Vec3::ZERO, Vec3::ZERO)));
}

#[test]
fn a_lane_gets_the_same_bits_whether_or_not_a_neighbour_straddles() {
    // A batch with a straddling lane integrates every lane's polygon in one
    // more slot (a repeated vertex); the other lanes' answers must not move.
    let (light, straddling) = straddling_case();
    let bl = BatchLight::new(&light);
    let mut rng = Rng::new(11);
    for _ in 0..50 {
        let p = vec3(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5), -2.0);
        let eye = vec3(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), 2.0);
        let plain = SurfacePoint {
            p,
            n: (Vec3::Z + 0.3 * rng.direction()).normalize(),
            wo: (eye - p).normalize(),
            diffuse: Vec3::splat(0.5),
            specular: vec3(0.04, 0.5, 1.0),
            // Rough enough for the lanes (`u_batch::MAX_CONDITION`).
            roughness: rng.range(0.2, 1.0),
        };
        let [mut alone, mut mixed] = [LaneLobes::default(); 2];
        let c = lobes_batch(&PixelBatch::new(&[Some(plain)]), &bl, &mut alone);
        assert_eq!(c, LaneCounts { fast: 1, scalar: 0 });
        lobes_batch(
            &PixelBatch::new(&[Some(plain), Some(straddling)]),
            &bl,
            &mut mixed,
        );
        assert!(alone.lane(0).0.x > 0.0, "{:?}", alone.lane(0));
        assert_eq!(alone.lane(0), mixed.lane(0), "{plain:?}");
    }
}

#[test]
fn vertices_on_the_horizon_match_the_scalar_path() {
    // With the normal along +Z a vertex at the point's height lies exactly
    // on its horizon (z = 0 in the local frame): vertices on it with the
    // rest above (no clip), with one below (a clip through a vertex), and
    // an edge on it with the rest below (nothing left).
    let quad = |zs: [f32; 4]| {
        let xy = [(-0.5, 0.5), (0.5, 0.5), (0.5, 1.5), (-0.5, 1.5)];
        two_sided_light((0..4).map(|k| vec3(xy[k].0, xy[k].1, zs[k])).collect())
    };
    for zs in [
        [0.0, 0.5, 0.5, 0.5],
        [0.0, 0.0, 0.5, 0.5],
        [0.0, -0.5, 0.5, 0.5],
        [0.5, 0.0, -0.5, 0.0],
        [0.0, -0.5, 0.0, 0.5],
        [0.0, 0.0, -0.5, -0.5],
    ] {
        check_lanes(&quad(zs), &FLAT_LANES.map(flat_lane));
    }
}

#[test]
fn near_degenerate_lights_across_the_horizon_match_the_scalar_path() {
    // Clips of polygons that barely have an area, or barely cross: a sliver
    // quad 1e-5 wide standing across the horizon, a triangle 1e-6 from
    // collinear, and quads with vertices 1e-12 below or above it. (As
    // measured, the first two leave the batch on their rounding bound, the
    // other two are clipped in it: both ways must agree with the scalar
    // path.)
    let lights = [
        vec![
            vec3(0.0, 1.0, -0.5),
            vec3(1e-5, 1.0, -0.5),
            vec3(1e-5, 1.0, 0.5),
            vec3(0.0, 1.0, 0.5),
        ],
        vec![
            vec3(-1.0, 1.0, -0.5),
            vec3(1.0, 1.0, 0.5),
            vec3(0.0, 1.0, 1e-6),
        ],
        vec![
            vec3(-0.5, 0.5, -1e-12),
            vec3(0.5, 0.5, 0.5),
            vec3(0.5, 1.5, 0.5),
            vec3(-0.5, 1.5, 0.5),
        ],
        vec![
            vec3(-0.5, 0.5, -1e-12),
            vec3(0.5, 0.5, 1e-12),
            vec3(0.5, 1.5, 0.5),
            vec3(-0.5, 1.5, -1e-12),
        ],
    ];
    for vertices in lights {
        check_lanes(&two_sided_light(vertices), &FLAT_LANES.map(flat_lane));
    }
}

/// A two-sided light of radiance 1 through `vertices` (its normal from the
/// first three).
fn two_sided_light(vertices: Vec<Vec3>) -> Light {
    let normal = (vertices[1] - vertices[0])
        .cross(vertices[2] - vertices[0])
        .normalize();
    Light {
        vertices,
        radiance: Vec3::ONE,
        two_sided: true,
        normal,
        area: 1.0,
        quad: None,
    }
}

/// Views and roughness of four points at the origin with normal +Z.
const FLAT_LANES: [(Vec3, f32); 4] = [
    (vec3(0.2, -0.4, 1.0), 0.3),
    (vec3(-0.5, 0.1, 0.3), 0.7),
    (vec3(0.0, 0.0, 1.0), 0.05),
    (vec3(0.9, 0.9, 0.1), 1.0),
];

fn flat_lane((view, roughness): (Vec3, f32)) -> SurfacePoint {
    lane(Vec3::ZERO, Vec3::Z, view, roughness)
}

/// Hard cases for one light, `LANES` to a batch, against the scalar path
/// lane by lane (finite, >= 0, within `TOL`).
fn check_lanes(light: &Light, points: &[SurfacePoint]) {
    let (bl, sl) = (BatchLight::new(light), ShadingLight::new(light));
    for group in points.chunks(LANES) {
        let lanes: Vec<Option<SurfacePoint>> = group.iter().copied().map(Some).collect();
        let mut out = LaneLobes::default();
        lobes_batch(&PixelBatch::new(&lanes), &bl, &mut out);
        for (l, sp) in group.iter().enumerate() {
            let (got, want) = (out.lane(l), unshadowed_lobes_prepared(sp, &sl));
            let d = deviation(got, want, light.radiance);
            assert!(
                d <= 1.0,
                "lane {l}: deviation {d} of the tolerance, batch {got:?}, scalar {want:?}, {sp:?}"
            );
        }
    }
}

/// A point at `p` with normal `n`, seen from `view` (need not be unit).
fn lane(p: Vec3, n: Vec3, view: Vec3, roughness: f32) -> SurfacePoint {
    SurfacePoint {
        p,
        n,
        wo: view.normalize(),
        diffuse: vec3(0.5, 0.4, 0.3),
        specular: vec3(0.04, 0.5, 1.0),
        roughness,
    }
}

#[test]
fn hard_cases_mixed_into_batches_equal_the_scalar_path() {
    // A 1x1 quad 1 above the origin, facing down; one- and two-sided.
    for two_sided in [false, true] {
        let light = polygon_light(
            vec3(0.0, 0.0, 1.0),
            0.7,
            4,
            Quat::from_rotation_x(std::f32::consts::PI),
            two_sided,
        );
        let up = Vec3::Z;
        let points = [
            lane(Vec3::ZERO, up, vec3(0.3, 0.1, 1.0), 0.5),
            // Grazing view, and slightly below the horizon (shading normals).
            lane(Vec3::ZERO, up, vec3(1.0, 0.0, 1e-3), 0.3),
            lane(Vec3::ZERO, up, vec3(1.0, 0.2, -0.02), 0.3),
            // Roughness 0 and 1.
            lane(vec3(0.2, 0.0, 0.0), up, vec3(-0.5, 0.0, 1.0), 0.0),
            lane(vec3(0.2, 0.0, 0.0), up, vec3(-0.5, 0.0, 1.0), 1.0),
            // The light straddles this point's horizon.
            lane(
                vec3(0.9, 0.0, 0.5),
                vec3(-1.0, 0.0, 0.3).normalize(),
                vec3(-1.0, 0.0, 1.0),
                0.4,
            ),
            // Nearly in the light's plane, and just behind it (two-sided: lit).
            lane(vec3(2.0, 0.0, 1.0 - 1e-6), up, vec3(0.0, 0.0, 1.0), 0.4),
            lane(vec3(0.1, 0.0, 1.5), -up, vec3(0.2, 0.0, -1.0), 0.4),
        ];
        check_lanes(&light, &points);
    }
    // A tiny light (about 1e-6 sr) and one almost filling the hemisphere,
    // from the same mixed lanes.
    for (r, h) in [(5e-4, 1.0), (100.0, 0.05)] {
        let light = polygon_light(
            vec3(0.3, -0.2, h),
            r,
            6,
            Quat::from_rotation_x(std::f32::consts::PI),
            false,
        );
        let points: [SurfacePoint; 8] = std::array::from_fn(|l| {
            let t = l as f32 / 8.0;
            lane(
                vec3(t * 0.1, 0.0, 0.0),
                vec3(0.3 * t - 0.1, 0.0, 1.0).normalize(),
                vec3(1.0 - t, 0.3, 0.05 + t),
                [0.0, 0.05, 0.2, 0.5, 1.0, 0.3, 0.7, 0.1][l],
            )
        });
        check_lanes(&light, &points);
    }
}

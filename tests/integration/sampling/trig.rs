//! The samplers' inlined trigonometry against the C library's.

use penumbra::sampling::Pcg32;
use penumbra::sampling::trig::{atan2, sin_cos, sin_cos_f32};

/// Ulps of `b` that `a` is from it (relative), with an absolute floor at
/// the scale of f64's rounding of `scale`.
fn within(a: f64, b: f64, ulps: f64, scale: f64) -> bool {
    (a - b).abs() <= ulps * f64::EPSILON * b.abs().max(scale * 1e-3)
}

#[test]
fn atan2_matches_the_library_in_every_quadrant_and_scale() {
    let mut rng = Pcg32::new(7, 1);
    let mut worst = 0.0f64;
    for _ in 0..200_000 {
        let e = (rng.next_f32() as f64 - 0.5) * 40.0;
        let y = (rng.next_f32() as f64 * 2.0 - 1.0) * 2f64.powf(e);
        let x = (rng.next_f32() as f64 * 2.0 - 1.0) * 2f64.powf(-e * 0.7);
        let (a, b) = (atan2(y, x), y.atan2(x));
        worst = worst.max((a - b).abs() / b.abs().max(f64::MIN_POSITIVE) / f64::EPSILON);
        assert!(within(a, b, 4.0, 0.0), "atan2({y}, {x}): {a} vs {b}");
    }
    assert!(worst > 0.0, "the comparison ran");
    for (y, x) in [
        (0.0, 1.0),
        (0.0, -1.0),
        (-0.0, -1.0),
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 0.0),
        (0.0, -0.0),
        (1.0, f64::INFINITY),
        (f64::INFINITY, 1.0),
        (1.0, 1.0),
        (1e-300, 1.0),
        (1.0, 1e-300),
    ] {
        assert_eq!(atan2(y, x), y.atan2(x), "atan2({y}, {x})");
    }
    assert!(atan2(f64::NAN, 1.0).is_nan() && atan2(1.0, f64::NAN).is_nan());
}

#[test]
fn sin_cos_matches_the_library_over_the_samplers_range() {
    let mut rng = Pcg32::new(9, 2);
    for i in 0..200_000 {
        // Up to 4π (a sphere's solid angle), and tiny angles.
        let x = if i % 4 == 0 {
            (rng.next_f32() as f64 - 0.5) * 1e-6
        } else {
            (rng.next_f32() as f64 * 2.0 - 1.0) * 4.0 * std::f64::consts::PI
        };
        let ((s, c), (rs, rc)) = (sin_cos(x), x.sin_cos());
        assert!(within(s, rs, 4.0, 1e-13), "sin({x}): {s} vs {rs}");
        assert!(within(c, rc, 4.0, 1e-13), "cos({x}): {c} vs {rc}");
    }
    assert_eq!(sin_cos(0.0), (0.0, 1.0));
    let (s, c) = sin_cos(f64::NAN);
    assert!(s.is_nan() && c.is_nan());
    assert!(sin_cos(f64::INFINITY).0.is_nan());
}

#[test]
fn sin_cos_f32_is_within_an_ulp_of_the_library_and_correctly_rounded() {
    let mut rng = Pcg32::new(11, 3);
    let mut not_nearest = 0;
    let n = 100_000;
    let ulp = |a: f32, b: f32| (a.to_bits() as i64 - b.to_bits() as i64).abs();
    for _ in 0..n {
        let x = rng.next_f32() * 4.0 * std::f32::consts::PI;
        let ((s, c), (rs, rc)) = (sin_cos_f32(x), x.sin_cos());
        assert!(
            ulp(s, rs) <= 1 && ulp(c, rc) <= 1,
            "{x}: ({s}, {c}) vs ({rs}, {rc})"
        );
        // The f64 library value rounded to f32 is the nearest f32 but for
        // double-rounding ties.
        let (ns, nc) = ((x as f64).sin() as f32, (x as f64).cos() as f32);
        not_nearest += (s != ns || c != nc) as u32;
    }
    assert!(
        not_nearest * 10_000 < n,
        "{not_nearest} of {n} not the nearest f32"
    );
}

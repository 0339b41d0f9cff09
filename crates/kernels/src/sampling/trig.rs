//! Inverse and direct trigonometry for the light samplers, inlined in place
//! of the C library's calls: each sampler setup needs one to four `atan2`
//! and each sample one `sin_cos`, and a libm call costs several times the
//! polynomial below. The polynomials are Cephes' (Moshier, "Methods and
//! Programs for Mathematical Functions"): rational `atan` good to ~1e-16
//! on the reduced range, and degree-13 `sin`/`cos` on [−π/4, π/4] with a
//! three-part π/4 reduction. Plain multiplies and adds (never `mul_add`,
//! which is a library call where FMA is absent), so every ISA level gives
//! the same bits.

use super::lanes8::{D, DM, deq, ds};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// tan(3π/8): above it `atan(x) = π/2 − atan(1/x)`.
const TAN_3PI_8: f64 = 2.414213562373095;
/// Cephes' split between the direct polynomial and `atan(x) = π/4 + atan((x−1)/(x+1))`.
const ATAN_SPLIT: f64 = 0.66;
/// Low part of π/2 (Cephes' MOREBITS), restoring the bits the constant loses.
const PI_2_LO: f64 = 6.123233995736766e-17;

const ATAN_P: [f64; 5] = [
    -0.8750608600031904,
    -16.15753718733365,
    -75.00855792314705,
    -122.8866684490136,
    -64.85021904942025,
];
const ATAN_Q: [f64; 5] = [
    24.85846490142306,
    165.0270098316988,
    432.8810604912903,
    485.3903996359137,
    194.5506571482614,
];

/// atan(x) for x ≥ 0 (+∞ included).
#[inline]
fn atan_nonneg(x: f64) -> f64 {
    let (base, lo, t) = if x > TAN_3PI_8 {
        (FRAC_PI_2, PI_2_LO, -1.0 / x)
    } else if x > ATAN_SPLIT {
        (FRAC_PI_4, 0.5 * PI_2_LO, (x - 1.0) / (x + 1.0))
    } else {
        (0.0, 0.0, x)
    };
    let z = t * t;
    let p = (((ATAN_P[0] * z + ATAN_P[1]) * z + ATAN_P[2]) * z + ATAN_P[3]) * z + ATAN_P[4];
    let q = ((((z + ATAN_Q[0]) * z + ATAN_Q[1]) * z + ATAN_Q[2]) * z + ATAN_Q[3]) * z + ATAN_Q[4];
    base + ((t * (z * p / q) + t) + lo)
}

/// `y.atan2(x)` to within a few ulps (NaN in, NaN out; both infinite is
/// NaN too): the angle of (x, y) in [−π, π].
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    let (ay, ax) = (y.abs(), x.abs());
    let a = if ax >= ay {
        // Also (0, 0): 0/0 is NaN, which the ratio below must not see.
        if ay == 0.0 { 0.0 } else { atan_nonneg(ay / ax) }
    } else {
        FRAC_PI_2 - atan_nonneg(ax / ay)
    };
    let a = if x < 0.0 || (x == 0.0 && x.is_sign_negative() && ay == 0.0) {
        PI - a
    } else {
        a
    };
    // NaN in either argument has made `a` NaN above.
    a.copysign(y)
}

const SIN_C: [f64; 6] = [
    1.5896230157654656e-10,
    -2.5050747762857807e-8,
    2.7557313621385727e-6,
    -0.0001984126982958954,
    0.008333333333322118,
    -0.1666666666666663,
];
const COS_C: [f64; 6] = [
    -1.1358536521387682e-11,
    2.087570084197473e-9,
    -2.755731417929674e-7,
    2.4801587288851704e-5,
    -0.0013888888888873056,
    0.041666666666666595,
];
/// π/4 in three parts, each exact times small integers.
const DP1: f64 = 0.7853981256484985;
const DP2: f64 = 3.774894707930798e-8;
const DP3: f64 = 2.6951514290790595e-15;

#[inline]
fn poly6(c: &[f64; 6], z: f64) -> f64 {
    ((((c[0] * z + c[1]) * z + c[2]) * z + c[3]) * z + c[4]) * z + c[5]
}

/// `(x.sin(), x.cos())` to within a few ulps for |x| up to ~1e6 (the
/// samplers pass angles of at most 4π); NaN for non-finite `x`.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    if !x.is_finite() {
        return (f64::NAN, f64::NAN);
    }
    let ax = x.abs();
    // Octant j of |x|, rounded up to even so the remainder is in [−π/4, π/4].
    let mut j = (ax * (4.0 / PI)) as u64;
    let mut y = j as f64;
    if j & 1 == 1 {
        j += 1;
        y += 1.0;
    }
    let z = ((ax - y * DP1) - y * DP2) - y * DP3;
    let zz = z * z;
    let s = z + z * zz * poly6(&SIN_C, zz);
    let c = 1.0 - 0.5 * zz + zz * zz * poly6(&COS_C, zz);
    // Quadrant q = j/2 mod 4: rotate (s, c) by q·π/2.
    let (sin, cos) = match (j >> 1) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    };
    (if x < 0.0 { -sin } else { sin }, cos)
}

/// `sin_cos` of an f32 angle, rounded to f32: the f64 polynomial, so the
/// result is the correctly rounded value but for rare ties.
#[inline]
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    let (s, c) = sin_cos(x as f64);
    (s as f32, c as f32)
}

/// `atan_nonneg` per lane: the three reductions computed on every lane
/// and the lane's own picked, then the one polynomial.
#[inline(always)]
fn atan_nonneg_lanes(x: D) -> D {
    let big = x.gt(ds(TAN_3PI_8));
    let mid = x.gt(ds(ATAN_SPLIT));
    let base = big.select(ds(FRAC_PI_2), mid.select(ds(FRAC_PI_4), ds(0.0)));
    let lo = big.select(ds(PI_2_LO), mid.select(ds(0.5 * PI_2_LO), ds(0.0)));
    let t = big.select(ds(-1.0) / x, mid.select((x - ds(1.0)) / (x + ds(1.0)), x));
    let z = t * t;
    let c = |k: f64| ds(k);
    let p = (((c(ATAN_P[0]) * z + c(ATAN_P[1])) * z + c(ATAN_P[2])) * z + c(ATAN_P[3])) * z
        + c(ATAN_P[4]);
    let q = ((((z + c(ATAN_Q[0])) * z + c(ATAN_Q[1])) * z + c(ATAN_Q[2])) * z + c(ATAN_Q[3])) * z
        + c(ATAN_Q[4]);
    base + ((t * (z * p / q) + t) + lo)
}

/// `atan2` per lane, the same bits as the scalar form on every lane.
#[inline(always)]
pub fn atan2_lanes(y: D, x: D) -> D {
    let (ay, ax) = (y.abs(), x.abs());
    let ge = ax.ge(ay);
    // One division: the ratio the lane's own branch takes.
    let at = atan_nonneg_lanes(ge.select(ay, ax) / ge.select(ax, ay));
    let zero = ds(0.0);
    let a = ge.select(deq(ay, zero).select(zero, at), ds(FRAC_PI_2) - at);
    // x == 0 with its sign bit set: −0 exactly (an integer compare).
    let neg_zero = DM::from_fn(|l| x.0[l].to_bits() == (-0.0f64).to_bits());
    let flip = x.lt(zero).or(neg_zero.and(deq(ay, zero)));
    let a = flip.select(ds(PI) - a, a);
    a.zip(y, f64::copysign)
}

/// `sin_cos` per lane, the same bits as the scalar form for |x| below
/// 2^31 · π/4 (the samplers pass at most 4π); NaN for non-finite `x`.
#[inline(always)]
pub fn sin_cos_lanes(x: D) -> (D, D) {
    let ax = x.abs();
    // The octant, rounded up to even, in floating point (a vector
    // rounding at every level): the scalar form's u64 gives the same
    // integer on the whole range above.
    let j = (ax * ds(4.0 / PI)).map(f64::trunc);
    let half = (j * ds(0.5)).map(f64::trunc);
    let y = j + (j - ds(2.0) * half);
    // Quadrant bits of y / 2 (even, so y / 2 is an integer).
    let k = y * ds(0.5);
    let k2 = (k * ds(0.5)).map(f64::trunc);
    let q1 = (k - ds(2.0) * k2).gt(ds(0.5));
    let k4 = (k * ds(0.25)).map(f64::trunc);
    let q2 = (k2 - ds(2.0) * k4).gt(ds(0.5));
    let z = ((ax - y * ds(DP1)) - y * ds(DP2)) - y * ds(DP3);
    let zz = z * z;
    let poly = |c: &[f64; 6]| {
        ((((ds(c[0]) * zz + ds(c[1])) * zz + ds(c[2])) * zz + ds(c[3])) * zz + ds(c[4])) * zz
            + ds(c[5])
    };
    let s = z + z * zz * poly(&SIN_C);
    let c = ds(1.0) - ds(0.5) * zz + zz * zz * poly(&COS_C);
    // Rotate (s, c) by q·π/2: odd quadrants swap, quadrants 1 and 2 negate
    // the sine, 2 and 3 the cosine.
    let (sw, cw) = (q1.select(c, s), q1.select(-s, c));
    let sin = q2.select(-sw, sw);
    let cos = q2.select(-cw, cw);
    let sin = x.lt(ds(0.0)).select(-sin, sin);
    let finite = x.finite();
    let nan = ds(f64::NAN);
    (finite.select(sin, nan), finite.select(cos, nan))
}

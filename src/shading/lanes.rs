//! Four lanes, one per pixel, for the batched `U` (`u_batch`) and its
//! shape correction (`ltc_correction::lobe_factors_lanes`). Elements are
//! `f64` (`E`; see `u_batch` for why not `f32`).
//!
//! Every operation is a fixed loop over the lanes, inlined always, which
//! LLVM turns into vector instructions (one AVX2 instruction with the
//! x86-64-v3 build of `.cargo/config.toml`, two SSE2 ones otherwise): no
//! intrinsics, all safe Rust. Four lanes, not eight: eight `f64` (two
//! registers per value) ran 1.26x slower per evaluation (register spills;
//! criterion `unshadowed_batch/quad`, README). Comparisons give a mask `Mask` of all-ones /
//! all-zeros bit patterns, and a select picks per lane from that mask (one
//! blend instruction; written as a bitwise and/or it took three), so lanes
//! never branch.

use std::ops::{Add, Div, Mul, Neg, Sub};

/// Pixels per batch.
pub const LANES: usize = 4;

/// The lane element type.
pub type E = f64;

/// One value per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub struct Wide(pub [E; LANES]);

/// One lane mask: `!0` (true) or `0` (false) per lane.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct Mask(pub [u64; LANES]);

#[inline(always)]
fn each<T: Copy + Default, const K: usize>(f: impl Fn(usize) -> T) -> [T; K] {
    let mut a = [T::default(); K];
    for (i, x) in a.iter_mut().enumerate() {
        *x = f(i);
    }
    a
}

#[inline(always)]
fn bit(b: bool) -> u64 {
    if b { !0 } else { 0 }
}

impl Wide {
    pub const ZERO: Wide = Wide([0.0; LANES]);
    pub const ONE: Wide = Wide([1.0; LANES]);

    #[inline(always)]
    pub fn splat(x: impl Into<E>) -> Wide {
        Wide([x.into(); LANES])
    }

    /// Lane `l` from `f(l)`.
    #[inline(always)]
    pub fn from_fn(f: impl Fn(usize) -> f32) -> Wide {
        Wide(each(|l| E::from(f(l))))
    }

    /// Four `f32` lanes (glam's `Vec4`, as the batch's setup computes
    /// across pixels), exactly.
    #[inline(always)]
    pub fn from_vec4(v: glam::Vec4) -> Wide {
        const { assert!(LANES == 4, "one Vec4 element per lane") };
        Wide(v.to_array().map(E::from))
    }

    /// The lanes as `f32`.
    #[inline(always)]
    pub fn to_f32(self) -> [f32; LANES] {
        each(|l| self.0[l] as f32)
    }

    #[inline(always)]
    pub fn map(self, f: impl Fn(E) -> E) -> Wide {
        Wide(each(|l| f(self.0[l])))
    }

    #[inline(always)]
    pub fn zip(self, o: Wide, f: impl Fn(E, E) -> E) -> Wide {
        Wide(each(|l| f(self.0[l], o.0[l])))
    }

    /// `self * b + c`: one fused instruction where the target has FMA;
    /// a multiply and an add otherwise (`f32::mul_add` would be a library
    /// call per lane there).
    #[inline(always)]
    pub fn mul_add(self, b: Wide, c: Wide) -> Wide {
        #[cfg(target_feature = "fma")]
        {
            Wide(each(|l| self.0[l].mul_add(b.0[l], c.0[l])))
        }
        #[cfg(not(target_feature = "fma"))]
        {
            self * b + c
        }
    }

    #[inline(always)]
    pub fn abs(self) -> Wide {
        self.map(E::abs)
    }

    #[inline(always)]
    pub fn sqrt(self) -> Wide {
        self.map(E::sqrt)
    }

    /// `1 / sqrt(x)` to 5e-6 relative, for `x` in [1e-300, 1e300]: an
    /// integer first guess (3.5 % off) and two Newton steps, multiplies and
    /// adds only. For code that needs ~1e-3, not `f64` (the correction),
    /// where a square root and a division per use kept the divider busy.
    #[inline(always)]
    pub fn rsqrt_approx(self) -> Wide {
        let guess = Wide(each(|l| {
            E::from_bits(0x5FE6_EB50_C7B5_37A9u64.wrapping_sub(self.0[l].to_bits() >> 1))
        }));
        let half = self * Wide::splat(-0.5);
        let step = |y: Wide| y * (y * y).mul_add(half, Wide::splat(1.5));
        step(step(guess))
    }

    /// Lane-wise minimum (`minps` semantics: written as a compare-select so
    /// no NaN handling is added).
    #[inline(always)]
    pub fn min(self, o: Wide) -> Wide {
        self.zip(o, |a, b| if a < b { a } else { b })
    }

    #[inline(always)]
    pub fn max(self, o: Wide) -> Wide {
        self.zip(o, |a, b| if a > b { a } else { b })
    }

    #[inline(always)]
    pub fn clamp(self, lo: impl Into<E>, hi: impl Into<E>) -> Wide {
        self.max(Wide::splat(lo)).min(Wide::splat(hi))
    }

    #[inline(always)]
    pub fn lt(self, o: Wide) -> Mask {
        Mask(each(|l| bit(self.0[l] < o.0[l])))
    }

    #[inline(always)]
    pub fn le(self, o: Wide) -> Mask {
        Mask(each(|l| bit(self.0[l] <= o.0[l])))
    }

    #[inline(always)]
    pub fn gt(self, o: Wide) -> Mask {
        o.lt(self)
    }

    #[inline(always)]
    pub fn ge(self, o: Wide) -> Mask {
        o.le(self)
    }

    /// Finite lanes (not NaN, not infinite).
    #[inline(always)]
    pub fn finite(self) -> Mask {
        self.abs().lt(Wide::splat(E::INFINITY))
    }

    /// Sum over the lanes.
    #[inline(always)]
    pub fn sum(self) -> E {
        self.0.iter().sum()
    }
}

impl Mask {
    pub const NONE: Mask = Mask([0; LANES]);
    pub const ALL: Mask = Mask([!0; LANES]);

    #[inline(always)]
    pub fn from_fn(f: impl Fn(usize) -> bool) -> Mask {
        Mask(each(|l| bit(f(l))))
    }

    /// `a` where the mask is set, `b` elsewhere.
    #[inline(always)]
    pub fn select(self, a: Wide, b: Wide) -> Wide {
        Wide(each(|l| if self.0[l] != 0 { a.0[l] } else { b.0[l] }))
    }

    #[inline(always)]
    pub fn and(self, o: Mask) -> Mask {
        Mask(each(|l| self.0[l] & o.0[l]))
    }

    #[inline(always)]
    pub fn or(self, o: Mask) -> Mask {
        Mask(each(|l| self.0[l] | o.0[l]))
    }

    /// `self` and not `o`.
    #[inline(always)]
    pub fn and_not(self, o: Mask) -> Mask {
        Mask(each(|l| self.0[l] & !o.0[l]))
    }

    #[inline(always)]
    pub fn invert(self) -> Mask {
        Mask(each(|l| !self.0[l]))
    }

    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().fold(0, |a, &b| a | b) != 0
    }

    #[inline(always)]
    pub fn lane(self, l: usize) -> bool {
        self.0[l] != 0
    }
}

impl Add for Wide {
    type Output = Wide;
    #[inline(always)]
    fn add(self, o: Wide) -> Wide {
        self.zip(o, |a, b| a + b)
    }
}

impl Sub for Wide {
    type Output = Wide;
    #[inline(always)]
    fn sub(self, o: Wide) -> Wide {
        self.zip(o, |a, b| a - b)
    }
}

impl Mul for Wide {
    type Output = Wide;
    #[inline(always)]
    fn mul(self, o: Wide) -> Wide {
        self.zip(o, |a, b| a * b)
    }
}

impl Div for Wide {
    type Output = Wide;
    #[inline(always)]
    fn div(self, o: Wide) -> Wide {
        self.zip(o, |a, b| a / b)
    }
}

impl Neg for Wide {
    type Output = Wide;
    #[inline(always)]
    fn neg(self) -> Wide {
        self.map(|a| -a)
    }
}

/// A vector of lanes: `[x, y, z]`.
pub type Wide3 = [Wide; 3];

#[inline(always)]
pub fn dot(a: &Wide3, b: &Wide3) -> Wide {
    a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]))
}

#[inline(always)]
pub fn cross(a: &Wide3, b: &Wide3) -> Wide3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline(always)]
pub fn add3(a: &Wide3, b: &Wide3) -> Wide3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
pub fn scale3(a: &Wide3, s: Wide) -> Wide3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn approximate_reciprocal_square_root_is_within_its_bound() {
        let mut worst: f64 = 0.0;
        for k in 0..=6000 {
            let x = 10f64.powf(-300.0 + 0.1 * k as f64);
            for f in [1.0, 1.37, 2.0, 3.1, 7.9] {
                let x = x * f;
                let got = Wide::splat(x).rsqrt_approx().0[0];
                worst = worst.max((got * x.sqrt() - 1.0).abs());
            }
        }
        assert!(worst < 5e-6, "{worst}");
    }

    #[test]
    fn select_min_max_and_finite_act_per_lane() {
        let a = Wide::from_fn(|l| l as f32 - 1.5);
        let b = Wide::splat(0.0);
        let m = a.lt(b);
        assert_eq!(m.select(a, b).0, [-1.5, -0.5, 0.0, 0.0]);
        assert_eq!(a.min(b), m.select(a, b));
        assert_eq!(a.max(b), m.select(b, a));
        let mut c = a;
        c.0[1] = E::NAN;
        c.0[2] = E::INFINITY;
        let f = c.finite();
        assert!(!f.lane(1) && !f.lane(2) && f.lane(0) && f.lane(3));
        assert!(m.any() && !Mask::NONE.any());
    }
}

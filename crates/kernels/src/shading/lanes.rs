//! Lanes, one pixel (or one pixel's node) per lane, for the batched `U`
//! (`u_batch`) and its shape correction
//! (`ltc_correction::lobe_factors_lanes`): `Wide`, eight `f32` lanes (one
//! pixel each: the contour sums, accurate to a stated share of the pixel's
//! whole `U`; see `u_batch`), `Quad`, four `f64` lanes (half a
//! batch: the correction's per-pixel fan, where a small light cancels), and
//! `Wide8`, eight `f32` lanes (the correction's cubature nodes, two nodes of
//! a half batch's four pixels per value: it needs ~1e-3).
//!
//! Every operation is a fixed loop over the lanes, inlined always, which
//! LLVM turns into vector instructions (one AVX2 instruction at the AVX2
//! and AVX-512 levels `isa` picks at run time, two SSE2 ones at baseline):
//! no intrinsics, all safe Rust. Each lane's arithmetic is the same
//! whatever the vector width, so every level gives the same bits.
//! Comparisons give a mask of all-ones / all-zeros bit patterns, and a
//! select picks per lane from that mask (one blend instruction), so lanes
//! never branch.

use std::fmt::Debug;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// Pixels per batch.
pub const LANES: usize = 8;
/// Pixels per half batch (the correction's `Quad` lanes).
pub const HALF: usize = LANES / 2;

/// The element type of the batch's lanes.
pub type BatchFloat = f32;

/// A lane element: `f64` or `f32`.
pub trait Elem:
    Copy
    + Default
    + Debug
    + PartialEq
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// An unsigned integer of the same width (a mask lane).
    type Bits: Copy
        + Default
        + Debug
        + Eq
        + BitAnd<Output = Self::Bits>
        + BitOr<Output = Self::Bits>
        + Not<Output = Self::Bits>;
    const NO_BITS: Self::Bits;
    const ZERO: Self;
    const ONE: Self;
    const INFINITY: Self;
    fn from_f64(x: f64) -> Self;
    fn to_f32(self) -> f32;
    fn mul_add(self, b: Self, c: Self) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    /// The integer first guess of `1 / sqrt(self)` (3.5 % off).
    fn rsqrt_guess(self) -> Self;
    /// A mask lane: all ones for `true`, zero for `false`.
    fn mask_bits(b: bool) -> Self::Bits;
    /// `a` where `m` is all ones, `b` where it is zero.
    fn pick(m: Self::Bits, a: Self, b: Self) -> Self;
}

impl Elem for f64 {
    type Bits = u64;
    const NO_BITS: u64 = 0;
    const ZERO: f64 = 0.0;
    const ONE: f64 = 1.0;
    const INFINITY: f64 = f64::INFINITY;
    #[inline(always)]
    fn from_f64(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self as f32
    }
    #[inline(always)]
    fn mul_add(self, b: f64, c: f64) -> f64 {
        f64::mul_add(self, b, c)
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f64 {
        f64::abs(self)
    }
    #[inline(always)]
    fn rsqrt_guess(self) -> f64 {
        f64::from_bits(0x5FE6_EB50_C7B5_37A9u64.wrapping_sub(self.to_bits() >> 1))
    }
    #[inline(always)]
    fn mask_bits(b: bool) -> u64 {
        u64::from(b).wrapping_neg()
    }
    #[inline(always)]
    fn pick(m: u64, a: f64, b: f64) -> f64 {
        // One blend instruction (as an and / and-not / or it took three).
        if m != 0 { a } else { b }
    }
}

impl Elem for f32 {
    type Bits = u32;
    const NO_BITS: u32 = 0;
    const ZERO: f32 = 0.0;
    const ONE: f32 = 1.0;
    const INFINITY: f32 = f32::INFINITY;
    #[inline(always)]
    fn from_f64(x: f64) -> f32 {
        x as f32
    }
    #[inline(always)]
    fn to_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn mul_add(self, b: f32, c: f32) -> f32 {
        f32::mul_add(self, b, c)
    }
    #[inline(always)]
    fn sqrt(self) -> f32 {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> f32 {
        f32::abs(self)
    }
    #[inline(always)]
    fn rsqrt_guess(self) -> f32 {
        f32::from_bits(0x5F37_5A86u32.wrapping_sub(self.to_bits() >> 1))
    }
    #[inline(always)]
    fn mask_bits(b: bool) -> u32 {
        u32::from(b).wrapping_neg()
    }
    #[inline(always)]
    fn pick(m: u32, a: f32, b: f32) -> f32 {
        // Bitwise: written as an `if`, LLVM chose between the operands'
        // addresses lane by lane (eight extractions and scalar loads).
        f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
    }
}

/// One value per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Lanes<T: Elem, const L: usize>(pub [T; L]);

/// One lane mask: all ones (true) or zero (false) per lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct LaneMask<T: Elem, const L: usize>(pub [T::Bits; L]);

/// Eight `f32` lanes: one pixel each.
pub type Wide = Lanes<f32, LANES>;
/// `Wide`'s mask.
pub type Mask = LaneMask<f32, LANES>;
/// Four `f64` lanes: the pixels of half a batch.
pub type Quad = Lanes<f64, HALF>;
/// `Quad`'s mask.
pub type QuadMask = LaneMask<f64, HALF>;
/// Eight `f32` lanes: two nodes of a half batch's `HALF` pixels.
pub type Wide8 = Lanes<f32, 8>;

#[inline(always)]
fn each<T: Copy + Default, const K: usize>(f: impl Fn(usize) -> T) -> [T; K] {
    let mut a = [T::default(); K];
    for (i, x) in a.iter_mut().enumerate() {
        *x = f(i);
    }
    a
}

#[inline(always)]
fn bit<T: Elem>(b: bool) -> T::Bits {
    T::mask_bits(b)
}

impl<T: Elem, const L: usize> Lanes<T, L> {
    pub const ZERO: Self = Lanes([T::ZERO; L]);
    pub const ONE: Self = Lanes([T::ONE; L]);

    /// Every lane `x` (rounded to the element type).
    #[inline(always)]
    pub fn splat(x: impl Into<f64>) -> Self {
        Lanes([T::from_f64(x.into()); L])
    }

    /// Lane `l` from `f(l)`.
    #[inline(always)]
    pub fn from_fn(f: impl Fn(usize) -> f32) -> Self {
        Lanes(each(|l| T::from_f64(f64::from(f(l)))))
    }

    /// The lanes as `f32`.
    #[inline(always)]
    pub fn to_f32(self) -> [f32; L] {
        each(|l| self.0[l].to_f32())
    }

    #[inline(always)]
    pub fn map(self, f: impl Fn(T) -> T) -> Self {
        Lanes(each(|l| f(self.0[l])))
    }

    #[inline(always)]
    pub fn zip(self, o: Self, f: impl Fn(T, T) -> T) -> Self {
        Lanes(each(|l| f(self.0[l], o.0[l])))
    }

    /// `self * b + c`, rounded once: one fused instruction with FMA (the
    /// AVX2 and AVX-512 levels of `isa`), a library call per lane at
    /// baseline, the same value on every level.
    #[inline(always)]
    pub fn mul_add(self, b: Self, c: Self) -> Self {
        Lanes(each(|l| self.0[l].mul_add(b.0[l], c.0[l])))
    }

    #[inline(always)]
    pub fn abs(self) -> Self {
        self.map(T::abs)
    }

    #[inline(always)]
    pub fn sqrt(self) -> Self {
        self.map(T::sqrt)
    }

    /// `1 / sqrt(x)` to 5e-6 relative (`f64`: for `x` in [1e-300, 1e300];
    /// `f32`: for normal `x`): an integer first guess (3.5 % off) and two
    /// Newton steps, multiplies and adds only. For code that needs ~1e-3
    /// (the correction), where a square root and a division per use kept
    /// the divider busy.
    #[inline(always)]
    pub fn rsqrt_approx(self) -> Self {
        let guess = self.map(T::rsqrt_guess);
        let half = self * Self::splat(-0.5);
        let step = |y: Self| y * (y * y).mul_add(half, Self::splat(1.5));
        step(step(guess))
    }

    /// Lane-wise minimum (`minps` semantics: written as a compare-select so
    /// no NaN handling is added).
    #[inline(always)]
    pub fn min(self, o: Self) -> Self {
        self.zip(o, |a, b| if a < b { a } else { b })
    }

    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        self.zip(o, |a, b| if a > b { a } else { b })
    }

    #[inline(always)]
    pub fn clamp(self, lo: impl Into<f64>, hi: impl Into<f64>) -> Self {
        self.max(Self::splat(lo)).min(Self::splat(hi))
    }

    #[inline(always)]
    pub fn lt(self, o: Self) -> LaneMask<T, L> {
        LaneMask(each(|l| bit::<T>(self.0[l] < o.0[l])))
    }

    #[inline(always)]
    pub fn le(self, o: Self) -> LaneMask<T, L> {
        LaneMask(each(|l| bit::<T>(self.0[l] <= o.0[l])))
    }

    #[inline(always)]
    pub fn gt(self, o: Self) -> LaneMask<T, L> {
        o.lt(self)
    }

    #[inline(always)]
    pub fn ge(self, o: Self) -> LaneMask<T, L> {
        o.le(self)
    }

    /// Finite lanes (not NaN, not infinite).
    #[inline(always)]
    pub fn finite(self) -> LaneMask<T, L> {
        self.abs().lt(Lanes([T::INFINITY; L]))
    }

    /// Sum over the lanes.
    #[inline(always)]
    pub fn sum(self) -> T {
        self.0.iter().fold(T::ZERO, |a, &b| a + b)
    }
}

impl Quad {
    /// Four `f32` lanes (glam's `Vec4`, as the batch's setup computes
    /// across pixels), exactly.
    #[inline(always)]
    pub fn from_vec4(v: glam::Vec4) -> Quad {
        Lanes(v.to_array().map(f64::from))
    }
}

impl Wide8 {
    /// `lo` in lanes 0-3 and `hi` in lanes 4-7, each rounded to `f32`.
    #[inline(always)]
    pub fn join(lo: Quad, hi: Quad) -> Wide8 {
        Lanes(each(|l| {
            if l < HALF {
                lo.0[l] as f32
            } else {
                hi.0[l - HALF] as f32
            }
        }))
    }

    /// `lo` in lanes 0-3 and `hi` in lanes 4-7 (a batch's two halves as
    /// its setup computes them, four pixels per `Vec4`).
    #[inline(always)]
    pub fn from_halves(lo: glam::Vec4, hi: glam::Vec4) -> Wide8 {
        let (a, b) = (lo.to_array(), hi.to_array());
        Lanes(each(|l| if l < HALF { a[l] } else { b[l - HALF] }))
    }

    /// The same four `f32` lanes (`glam`'s `Vec4`) in both halves.
    #[inline(always)]
    pub fn twice(v: glam::Vec4) -> Wide8 {
        let a = v.to_array();
        Lanes(each(|l| a[l % HALF]))
    }

    /// Lanes 0-3 plus lanes 4-7, as `f64`: a per-pixel sum over the two
    /// nodes a value holds.
    #[inline(always)]
    pub fn halves_sum(self) -> Quad {
        Lanes(each(|l| f64::from(self.0[l] + self.0[l + HALF])))
    }

    /// Half `h` (lanes `4 h..4 h + 4`) as `f64`, exactly.
    #[inline(always)]
    pub fn half(self, h: usize) -> Quad {
        Lanes(each(|l| f64::from(self.0[HALF * h + l])))
    }

    /// Half `h` (lanes `4 h..4 h + 4`) as glam's `Vec4` (what code
    /// written four pixels per `Vec4` reads).
    #[inline(always)]
    pub fn vec4_half(self, h: usize) -> glam::Vec4 {
        glam::Vec4::from_slice(&self.0[HALF * h..HALF * h + HALF])
    }
}

impl LaneMask<f32, LANES> {
    /// Half `h` (lanes `4 h..4 h + 4`) as a `Quad` mask.
    #[inline(always)]
    pub fn half(self, h: usize) -> QuadMask {
        LaneMask(each(|l| bit::<f64>(self.0[HALF * h + l] != 0)))
    }
}

impl<T: Elem, const L: usize> LaneMask<T, L> {
    pub const NONE: Self = LaneMask([T::NO_BITS; L]);

    #[inline(always)]
    pub fn from_fn(f: impl Fn(usize) -> bool) -> Self {
        LaneMask(each(|l| bit::<T>(f(l))))
    }

    /// `a` where the mask is set, `b` elsewhere.
    #[inline(always)]
    pub fn select(self, a: Lanes<T, L>, b: Lanes<T, L>) -> Lanes<T, L> {
        Lanes(each(|l| T::pick(self.0[l], a.0[l], b.0[l])))
    }

    #[inline(always)]
    pub fn and(self, o: Self) -> Self {
        LaneMask(each(|l| self.0[l] & o.0[l]))
    }

    #[inline(always)]
    pub fn or(self, o: Self) -> Self {
        LaneMask(each(|l| self.0[l] | o.0[l]))
    }

    /// `self` and not `o`.
    #[inline(always)]
    pub fn and_not(self, o: Self) -> Self {
        LaneMask(each(|l| self.0[l] & !o.0[l]))
    }

    #[inline(always)]
    pub fn invert(self) -> Self {
        LaneMask(each(|l| !self.0[l]))
    }

    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().fold(T::NO_BITS, |a, &b| a | b) != T::NO_BITS
    }

    #[inline(always)]
    pub fn lane(self, l: usize) -> bool {
        self.0[l] != T::NO_BITS
    }
}

impl<T: Elem, const L: usize> Default for Lanes<T, L> {
    fn default() -> Self {
        Self::ZERO
    }
}

impl<T: Elem, const L: usize> Default for LaneMask<T, L> {
    fn default() -> Self {
        Self::NONE
    }
}

impl<T: Elem, const L: usize> Add for Lanes<T, L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self.zip(o, |a, b| a + b)
    }
}

impl<T: Elem, const L: usize> Sub for Lanes<T, L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self.zip(o, |a, b| a - b)
    }
}

impl<T: Elem, const L: usize> Mul for Lanes<T, L> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self.zip(o, |a, b| a * b)
    }
}

impl<T: Elem, const L: usize> Div for Lanes<T, L> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self.zip(o, |a, b| a / b)
    }
}

impl<T: Elem, const L: usize> Neg for Lanes<T, L> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|a| -a)
    }
}

/// A vector of lanes: `[x, y, z]`.
pub type Vec3Lanes<T, const L: usize> = [Lanes<T, L>; 3];
/// A vector of `Wide` lanes.
pub type Wide3 = Vec3Lanes<f32, LANES>;
/// A vector of `Quad` lanes.
pub type Quad3 = Vec3Lanes<f64, HALF>;

#[inline(always)]
pub fn dot<T: Elem, const L: usize>(a: &Vec3Lanes<T, L>, b: &Vec3Lanes<T, L>) -> Lanes<T, L> {
    a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]))
}

#[inline(always)]
pub fn cross<T: Elem, const L: usize>(a: &Vec3Lanes<T, L>, b: &Vec3Lanes<T, L>) -> Vec3Lanes<T, L> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[inline(always)]
pub fn add3<T: Elem, const L: usize>(a: &Vec3Lanes<T, L>, b: &Vec3Lanes<T, L>) -> Vec3Lanes<T, L> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
pub fn sub3<T: Elem, const L: usize>(a: &Vec3Lanes<T, L>, b: &Vec3Lanes<T, L>) -> Vec3Lanes<T, L> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

#[inline(always)]
pub fn scale3<T: Elem, const L: usize>(a: &Vec3Lanes<T, L>, s: Lanes<T, L>) -> Vec3Lanes<T, L> {
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
                let got = Quad::splat(x).rsqrt_approx().0[0];
                worst = worst.max((got * x.sqrt() - 1.0).abs());
            }
        }
        assert!(worst < 5e-6, "{worst}");
        let mut worst: f64 = 0.0;
        for k in 0..=7000 {
            let x = 10f64.powf(-37.0 + 0.01 * k as f64) as f32;
            let got = Wide8::splat(x).rsqrt_approx().0[5];
            worst = worst.max((f64::from(got) * f64::from(x).sqrt() - 1.0).abs());
        }
        assert!(worst < 5e-6, "f32: {worst}");
    }

    #[test]
    fn select_min_max_and_finite_act_per_lane() {
        let a = Quad::from_fn(|l| l as f32 - 1.5);
        let b = Quad::splat(0.0);
        let m = a.lt(b);
        assert_eq!(m.select(a, b).0, [-1.5, -0.5, 0.0, 0.0]);
        assert_eq!(a.min(b), m.select(a, b));
        assert_eq!(a.max(b), m.select(b, a));
        let mut c = a;
        c.0[1] = f64::NAN;
        c.0[2] = f64::INFINITY;
        let f = c.finite();
        assert!(!f.lane(1) && !f.lane(2) && f.lane(0) && f.lane(3));
        assert!(m.any() && !QuadMask::NONE.any());
    }

    #[test]
    fn eight_lanes_hold_two_nodes_of_four_pixels() {
        let lo = Quad::from_fn(|l| l as f32);
        let hi = Quad::from_fn(|l| 10.0 + l as f32);
        let j = Wide8::join(lo, hi);
        assert_eq!(j.0, [0.0, 1.0, 2.0, 3.0, 10.0, 11.0, 12.0, 13.0]);
        assert_eq!(j.halves_sum(), Quad::from_fn(|l| 10.0 + 2.0 * l as f32));
        assert_eq!(j.half(1), hi);
        let m = j.gt(Wide8::splat(2.5)).half(0);
        assert!(!m.lane(2) && m.lane(3));
        let t = Wide8::twice(glam::Vec4::new(5.0, 6.0, 7.0, 8.0));
        assert_eq!(t.0, [5.0, 6.0, 7.0, 8.0, 5.0, 6.0, 7.0, 8.0]);
        let m = j.gt(Wide8::splat(2.5));
        assert_eq!(
            m.select(j, Wide8::ZERO).0,
            [0.0, 0.0, 0.0, 3.0, 10.0, 11.0, 12.0, 13.0]
        );
    }
}

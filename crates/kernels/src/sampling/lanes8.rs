//! Eight-lane forms of the scalar operations the per-pixel sampling uses,
//! one pixel per lane, over `shading::lanes::Lanes`: `F` (eight `f32`)
//! and `D` (eight `f64`). Unlike `shading::lanes::dot`, which fuses, every
//! operation here is the scalar code's own sequence of roundings (glam's
//! `Vec3` arithmetic, `f32::clamp`, `f32::max`), so a lane gives the bits
//! the scalar code gives for the same input; a branch of the scalar code
//! becomes both arms computed and a per-lane select.

use crate::shading::lanes::{LaneMask, Lanes};

/// Pixels per call of the sampling kernels.
pub const N: usize = 8;

pub type F = Lanes<f32, N>;
pub type D = Lanes<f64, N>;
pub type FM = LaneMask<f32, N>;
pub type DM = LaneMask<f64, N>;
/// A `Vec3` per lane, `[x, y, z]`.
pub type F3 = [F; 3];
pub type D3 = [D; 3];

#[inline(always)]
pub fn each<T: Copy + Default>(f: impl Fn(usize) -> T) -> [T; N] {
    let mut a = [T::default(); N];
    for (i, x) in a.iter_mut().enumerate() {
        *x = f(i);
    }
    a
}

#[inline(always)]
pub fn fl(f: impl Fn(usize) -> f32) -> F {
    Lanes(each(f))
}

#[inline(always)]
pub fn dl(f: impl Fn(usize) -> f64) -> D {
    Lanes(each(f))
}

#[inline(always)]
pub fn fs(x: f32) -> F {
    Lanes([x; N])
}

#[inline(always)]
pub fn ds(x: f64) -> D {
    Lanes([x; N])
}

/// `f32` to `f64`, exactly.
#[inline(always)]
pub fn widen(x: F) -> D {
    dl(|l| f64::from(x.0[l]))
}

/// `f64` to `f32`, rounded as `as f32` does.
#[inline(always)]
pub fn narrow(x: D) -> F {
    fl(|l| x.0[l] as f32)
}

#[inline(always)]
pub fn widen3(v: &F3) -> D3 {
    [widen(v[0]), widen(v[1]), widen(v[2])]
}

#[inline(always)]
pub fn narrow3(v: &D3) -> F3 {
    [narrow(v[0]), narrow(v[1]), narrow(v[2])]
}

#[inline(always)]
pub fn fmask(m: DM) -> FM {
    FM::from_fn(|l| m.lane(l))
}

#[inline(always)]
pub fn dmask(m: FM) -> DM {
    DM::from_fn(|l| m.lane(l))
}

/// Per lane `x == y` (false for NaN).
#[inline(always)]
pub fn feq(x: F, y: F) -> FM {
    FM::from_fn(|l| x.0[l] == y.0[l])
}

#[inline(always)]
pub fn deq(x: D, y: D) -> DM {
    DM::from_fn(|l| x.0[l] == y.0[l])
}

/// Per lane `x.is_nan()`.
#[inline(always)]
pub fn fnan(x: F) -> FM {
    FM::from_fn(|l| x.0[l].is_nan())
}

#[inline(always)]
pub fn dnan(x: D) -> DM {
    DM::from_fn(|l| x.0[l].is_nan())
}

/// `f32::clamp`'s sequence (`lo` if below, then `hi` if above; NaN stays
/// NaN) without its panic on bad bounds: lanes the caller discards may
/// hold any bounds.
#[inline(always)]
pub fn clampf(x: F, lo: F, hi: F) -> F {
    let x = x.lt(lo).select(lo, x);
    x.gt(hi).select(hi, x)
}

/// `f64::clamp`'s sequence with constant bounds.
#[inline(always)]
pub fn clampd(x: D, lo: f64, hi: f64) -> D {
    let x = x.lt(ds(lo)).select(ds(lo), x);
    x.gt(ds(hi)).select(ds(hi), x)
}

/// `clampf` with constant bounds.
#[inline(always)]
pub fn clampc(x: F, lo: f32, hi: f32) -> F {
    clampf(x, fs(lo), fs(hi))
}

/// `f32::max` per lane (a NaN operand gives the other one).
#[inline(always)]
pub fn fmax(x: F, y: F) -> F {
    x.zip(y, f32::max)
}

#[inline(always)]
pub fn dmax(x: D, y: D) -> D {
    x.zip(y, f64::max)
}

/// `f32::copysign` per lane.
#[inline(always)]
pub fn copysign(x: F, s: F) -> F {
    x.zip(s, f32::copysign)
}

/// glam's `Vec3::dot`: `(x·x') + (y·y') + (z·z')`, no fused steps.
#[inline(always)]
pub fn dot<T: crate::shading::lanes::Elem>(
    a: &[Lanes<T, N>; 3],
    b: &[Lanes<T, N>; 3],
) -> Lanes<T, N> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// glam's `Vec3::cross`.
#[inline(always)]
pub fn cross<T: crate::shading::lanes::Elem>(
    a: &[Lanes<T, N>; 3],
    b: &[Lanes<T, N>; 3],
) -> [Lanes<T, N>; 3] {
    [
        a[1] * b[2] - b[1] * a[2],
        a[2] * b[0] - b[2] * a[0],
        a[0] * b[1] - b[0] * a[1],
    ]
}

#[inline(always)]
pub fn add3<T: crate::shading::lanes::Elem>(
    a: &[Lanes<T, N>; 3],
    b: &[Lanes<T, N>; 3],
) -> [Lanes<T, N>; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[inline(always)]
pub fn sub3<T: crate::shading::lanes::Elem>(
    a: &[Lanes<T, N>; 3],
    b: &[Lanes<T, N>; 3],
) -> [Lanes<T, N>; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Component-wise product (glam's `Vec3 * Vec3`).
#[inline(always)]
pub fn mul3<T: crate::shading::lanes::Elem>(
    a: &[Lanes<T, N>; 3],
    b: &[Lanes<T, N>; 3],
) -> [Lanes<T, N>; 3] {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

/// glam's `Vec3 * f32` (and `f32 * Vec3`: the product commutes exactly).
#[inline(always)]
pub fn scale3<T: crate::shading::lanes::Elem>(
    a: &[Lanes<T, N>; 3],
    s: Lanes<T, N>,
) -> [Lanes<T, N>; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// glam's `Vec3 / f32`.
#[inline(always)]
pub fn div3<T: crate::shading::lanes::Elem>(
    a: &[Lanes<T, N>; 3],
    s: Lanes<T, N>,
) -> [Lanes<T, N>; 3] {
    [a[0] / s, a[1] / s, a[2] / s]
}

/// glam's `Vec3::length`.
#[inline(always)]
pub fn length(a: &F3) -> F {
    dot(a, a).sqrt()
}

/// glam's `Vec3::normalize`: times `1 / length`.
#[inline(always)]
pub fn normalize(a: &F3) -> F3 {
    scale3(a, fs(1.0) / length(a))
}

/// Per lane `a` where `m`, else `b`.
#[inline(always)]
pub fn select3(m: FM, a: &F3, b: &F3) -> F3 {
    [
        m.select(a[0], b[0]),
        m.select(a[1], b[1]),
        m.select(a[2], b[2]),
    ]
}

/// `select3` for `f64` lanes.
#[inline(always)]
pub fn select3d(m: DM, a: &D3, b: &D3) -> D3 {
    [
        m.select(a[0], b[0]),
        m.select(a[1], b[1]),
        m.select(a[2], b[2]),
    ]
}

/// Every lane `v`.
#[inline(always)]
pub fn splat3(v: glam::Vec3) -> F3 {
    [fs(v.x), fs(v.y), fs(v.z)]
}

/// Every lane `v`.
#[inline(always)]
pub fn splat3d(v: glam::DVec3) -> D3 {
    [ds(v.x), ds(v.y), ds(v.z)]
}

/// glam's `Vec3::max_element`.
#[inline(always)]
pub fn max_element(a: &F3) -> F {
    let max = |x: F, y: F| x.zip(y, |a, b| if a > b { a } else { b });
    max(max(a[0], a[1]), a[2])
}

/// Finite lanes, as `x - x == 0` (NaN for infinities and NaN): written
/// as `abs(x) < inf`, or as a compare, and joined with a sign test, LLVM
/// turned it into a floating-point class test that it then ran lane by
/// lane in integer code.
#[inline(always)]
#[allow(clippy::eq_op)] // x - x is the test itself, not a slip
pub fn finite(x: F) -> FM {
    feq(x - x, fs(0.0))
}

/// `finite` for `f64` lanes.
#[inline(always)]
#[allow(clippy::eq_op)] // x - x is the test itself, not a slip
pub fn dfinite(x: D) -> DM {
    deq(x - x, ds(0.0))
}

/// Lanes whose three components are all finite.
#[inline(always)]
pub fn finite3(a: &F3) -> FM {
    finite(a[0]).and(finite(a[1])).and(finite(a[2]))
}

/// One lane of an array of `Vec3` lanes as a `glam::Vec3`.
#[inline(always)]
pub fn lane3(a: &F3, l: usize) -> glam::Vec3 {
    glam::Vec3::new(a[0].0[l], a[1].0[l], a[2].0[l])
}

/// Writes `v` into lane `l`.
#[inline(always)]
pub fn set3(a: &mut F3, l: usize, v: glam::Vec3) {
    a[0].0[l] = v.x;
    a[1].0[l] = v.y;
    a[2].0[l] = v.z;
}

/// Writes `v` into lane `l`.
#[inline(always)]
pub fn set3d(a: &mut D3, l: usize, v: glam::DVec3) {
    a[0].0[l] = v.x;
    a[1].0[l] = v.y;
    a[2].0[l] = v.z;
}

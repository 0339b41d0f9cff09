//! Integrals of the clamped cosine over convex polygons seen from the origin.
//!
//! The polygon is given in a local frame whose +Z is the cosine's axis, with
//! the shading point at the origin. It must be clipped to the upper hemisphere
//! (`clip_upper`) before `cosine_integral`: the contour formula integrates the
//! *unclamped* cosine, so any part below the horizon would subtract from (or,
//! after an absolute value, leak into) the result.
//!
//! Everything is `f64`: a light of 1e-6 sr has edges of ~1e-3 rad whose
//! contour terms cancel down to ~1e-6, so `f32` loses ~20% there, while `f64`
//! keeps ~1e-10. Scalar `f64` costs about the same as `f32` on the CPU.
//! No heap allocation: polygons live in fixed arrays (8 input vertices, plus
//! one per clipping plane; we clip at most twice).

use super::lanes::{Elem, Lanes};
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// Largest polygon a light may have.
pub const MAX_LIGHT_VERTICES: usize = 8;
/// Room for an 8-gon clipped by two planes (each clip adds at most one vertex).
pub const MAX_VERTICES: usize = MAX_LIGHT_VERTICES + 2;

/// A convex polygon in a fixed-size buffer.
#[derive(Clone, Copy, Debug)]
pub struct Polygon {
    pub v: [DVec3; MAX_VERTICES],
    pub n: usize,
}

impl Default for Polygon {
    fn default() -> Self {
        Polygon {
            v: [DVec3::ZERO; MAX_VERTICES],
            n: 0,
        }
    }
}

impl Polygon {
    /// From up to `MAX_VERTICES` points (extra points are ignored).
    pub fn from_points(points: &[DVec3]) -> Polygon {
        let mut p = Polygon::default();
        for &q in points.iter().take(MAX_VERTICES) {
            p.v[p.n] = q;
            p.n += 1;
        }
        p
    }

    pub fn vertices(&self) -> &[DVec3] {
        &self.v[..self.n]
    }

    /// Sutherland-Hodgman against the half-space z >= 0. New vertices get
    /// z = 0 exactly so that a second clip sees them as inside. Returns an
    /// empty polygon when nothing (of positive area) is left.
    pub fn clip_upper(&self) -> Polygon {
        if self.n < 3 {
            return Polygon::default();
        }
        if self.vertices().iter().all(|a| a.z >= 0.0) {
            return *self;
        }
        let mut out = Polygon::default();
        clip_upper_into(self.vertices(), &mut out);
        out
    }

    /// `clip_upper` in place; copies nothing when the polygon is already
    /// entirely above the horizon (the common case).
    #[inline]
    pub fn clip_upper_in_place(&mut self) {
        if self.n >= 3 && self.vertices().iter().all(|a| a.z >= 0.0) {
            return;
        }
        *self = self.clip_upper();
    }

    /// Applies a linear map to every vertex.
    pub fn transformed(&self, m: &DMat3) -> Polygon {
        let mut out = *self;
        for v in &mut out.v[..self.n] {
            *v = *m * *v;
        }
        out
    }
}

/// `clip_upper` of the polygon `src` (at most `MAX_VERTICES - 1` vertices),
/// written into `out`: the hot path (LTC images of U) clips a third of the
/// time, and returning a whole `Polygon` by value cost a copy of the buffer
/// per call.
#[inline]
pub fn clip_upper_into(src: &[DVec3], out: &mut Polygon) {
    let n = src.len();
    out.n = 0;
    if n < 3 {
        return;
    }
    // Same order and arithmetic as the textbook loop (vertex, then the
    // crossing of its outgoing edge), so results are bit-for-bit those of
    // the former by-value clip.
    for (i, &a) in src.iter().enumerate() {
        let b = src[if i + 1 == n { 0 } else { i + 1 }];
        if a.z >= 0.0 {
            out.v[out.n] = a;
            out.n += 1;
        }
        if (a.z > 0.0 && b.z < 0.0) || (a.z < 0.0 && b.z > 0.0) {
            let t = a.z / (a.z - b.z);
            let mut p = a + (b - a) * t;
            p.z = 0.0;
            out.v[out.n] = p;
            out.n += 1;
        }
    }
    if out.n < 3 {
        out.n = 0;
    }
}

/// `acos(x) / sqrt(1 - x^2)` on x in [0, 1] as a degree-10 polynomial in
/// `t = 2x - 1`: Chebyshev interpolation at 11 nodes, converted to monomial
/// form. Max relative error 2.1e-9 (checked by a test against `acos`). The
/// function is analytic on [0, 1] (it is theta / sin(theta), even in theta),
/// so a polynomial is accurate right up to x = 1, where `acos / sqrt` is 0/0.
pub(crate) const THETA_SIN_POLY: [f64; 11] = [
    1.2091995761561447,
    -0.2636001657036012,
    0.06973319987759215,
    -0.01983666099098492,
    0.005861473274439291,
    -0.0017756137256588807,
    0.0005456343293128315,
    -0.00016333429026812755,
    5.1159417917677857e-05,
    -2.23862115392008e-05,
    7.119548376460278e-06,
];

/// theta / sin(theta) for x = cos(theta) in [0, 1]. Estrin's scheme: the
/// polynomial is the hot spot of U, and Horner/Clenshaw chains of 10
/// dependent multiply-adds were latency-bound (measured 3x slower U).
#[inline]
pub(crate) fn theta_over_sin_pos(x: f64) -> f64 {
    let c = &THETA_SIN_POLY;
    let t = 2.0 * x - 1.0;
    let t2 = t * t;
    let t4 = t2 * t2;
    let t8 = t4 * t4;
    let q0 = (c[0] + c[1] * t) + (c[2] + c[3] * t) * t2;
    let q1 = (c[4] + c[5] * t) + (c[6] + c[7] * t) * t2;
    let q2 = (c[8] + c[9] * t) + c[10] * t2;
    (q0 + q1 * t4) + q2 * t8
}

/// `theta_over_sin_pos` in every lane, from `THETA_SIN_POLY` as vectors
/// (`c`): the same Estrin scheme, its multiply-adds fused (14 instructions
/// instead of 23; the values differ by rounding).
#[inline(always)]
pub(crate) fn theta_over_sin_lanes<T: Elem, const L: usize>(
    c: &[Lanes<T, L>; 11],
    x: Lanes<T, L>,
) -> Lanes<T, L> {
    let t = x.mul_add(Lanes::splat(2.0), Lanes::splat(-1.0));
    let t2 = t * t;
    let t4 = t2 * t2;
    let t8 = t4 * t4;
    let q0 = c[3].mul_add(t, c[2]).mul_add(t2, c[1].mul_add(t, c[0]));
    let q1 = c[7].mul_add(t, c[6]).mul_add(t2, c[5].mul_add(t, c[4]));
    let q2 = c[10].mul_add(t2, c[9].mul_add(t, c[8]));
    q2.mul_add(t8, q1.mul_add(t4, q0))
}

/// theta / sin(theta) for x = cos(theta) in [-1, 1], finite everywhere.
/// For x < 0, theta = pi - theta' with cos(theta') = -x, so
/// theta / sin = pi / sin - theta' / sin. At x = -1 (antipodal vertices, an
/// edge through the shading point) the value is huge but finite; it is only
/// ever multiplied by a cross product that vanishes there.
#[inline]
pub fn theta_over_sin(x: f64) -> f64 {
    let x = x.clamp(-1.0, 1.0);
    if x >= 0.0 {
        theta_over_sin_pos(x)
    } else {
        let s = ((1.0 - x) * (1.0 + x)).max(1e-30).sqrt();
        PI / s - theta_over_sin_pos(-x)
    }
}

/// `v / |v|`, or zero for a vector too short to have a direction (a vertex
/// at the shading point: its edges then contribute nothing instead of NaN).
#[inline]
fn unit_or_zero(v: DVec3) -> DVec3 {
    let l2 = v.length_squared();
    if l2 > 1e-280 && l2.is_finite() {
        // One division instead of three.
        v * l2.sqrt().recip()
    } else {
        DVec3::ZERO
    }
}

/// Signed contour sum `sum_i theta_i * z . (a_i x b_i) / |a_i x b_i|` over the
/// edges (a_i, b_i) of the projected polygon; equals
/// `±2 ∫ cos θ dω` over a polygon in the upper hemisphere; the sign follows
/// the winding of the vertex order as seen from the origin.
pub fn edge_sum(poly: &Polygon) -> f64 {
    if poly.n < 3 {
        return 0.0;
    }
    let mut u = [DVec3::ZERO; MAX_VERTICES];
    for (dst, &src) in u.iter_mut().zip(poly.vertices()) {
        *dst = unit_or_zero(src);
    }
    let mut sum = 0.0;
    for i in 0..poly.n {
        let a = u[i];
        let b = u[if i + 1 == poly.n { 0 } else { i + 1 }];
        let cz = a.x * b.y - a.y * b.x;
        sum += theta_over_sin(a.dot(b)) * cz;
    }
    sum
}

/// `edge_sum` of `K` polygons of exactly `N` vertices each (`v[k][..N]`),
/// computed together. The arithmetic is `edge_sum`'s (normalise each vertex
/// once, then each edge reads its two unit vertices), arranged for speed:
/// - U needs three polygons with the same vertex count (the light in the
///   shading frame for Lambert and the cosine part of each lobe, and its
///   images in the two LTC spaces); doing them in lockstep lets the
///   compiler pack them into `f64` SIMD and overlaps their square roots and
///   divisions, the latency of U;
/// - the normalisations carry no branch;
/// - `pi / sin` is needed only by edges spanning more than 90 degrees
///   (cos < 0, only on very wide polygons): one well-predicted test keeps
///   its extra square root and division off the common path.
#[inline(always)]
fn edge_sums<const K: usize, const N: usize>(v: [&[DVec3; MAX_VERTICES]; K]) -> [f64; K] {
    let mut inv = [[0.0; N]; K];
    for k in 0..K {
        for i in 0..N {
            // No test and select here: the compiler turns one into a
            // branch around each square root, serialising them. The floor
            // alone keeps a vertex at the shading point finite (it stays
            // the zero vector, so its edges add exactly 0); lengths cannot
            // overflow, the vertices come from `f32` scene data.
            inv[k][i] = 1.0 / v[k][i].length_squared().max(1e-280).sqrt();
        }
    }
    let mut dot = [[0.0; N]; K];
    let mut cz = [[0.0; N]; K];
    let mut wide = false;
    for k in 0..K {
        for i in 0..N {
            let j = if i + 1 == N { 0 } else { i + 1 };
            let (a, b) = (v[k][i], v[k][j]);
            let w = inv[k][i] * inv[k][j];
            dot[k][i] = (a.dot(b) * w).clamp(-1.0, 1.0);
            cz[k][i] = (a.x * b.y - a.y * b.x) * w;
            wide |= dot[k][i] < 0.0;
        }
    }
    let mut sum = [0.0; K];
    for k in 0..K {
        for i in 0..N {
            let t = if wide {
                theta_over_sin(dot[k][i])
            } else {
                theta_over_sin_pos(dot[k][i])
            };
            sum[k] += t * cz[k][i];
        }
    }
    sum
}

/// `edge_sum` of the first `n` vertices of `v` (n <= `MAX_VERTICES`), with
/// triangles and quads (nearly every light, unclipped) on unrolled paths.
#[inline(always)]
pub fn edge_sum_fixed(v: &[DVec3; MAX_VERTICES], n: usize) -> f64 {
    match n {
        0..=2 => 0.0,
        3 => edge_sums::<1, 3>([v])[0],
        4 => edge_sums::<1, 4>([v])[0],
        5 => edge_sums::<1, 5>([v])[0],
        6 => edge_sums::<1, 6>([v])[0],
        7 => edge_sums::<1, 7>([v])[0],
        8 => edge_sums::<1, 8>([v])[0],
        9 => edge_sums::<1, 9>([v])[0],
        _ => edge_sums::<1, MAX_VERTICES>([v])[0],
    }
}

/// `[edge_sum(a), edge_sum(b), edge_sum(c)]` for three polygons of `n`
/// vertices each (the light for Lambert and its two LTC images).
#[inline(always)]
pub fn edge_sum_triple(
    a: &[DVec3; MAX_VERTICES],
    b: &[DVec3; MAX_VERTICES],
    c: &[DVec3; MAX_VERTICES],
    n: usize,
) -> [f64; 3] {
    match n {
        0..=2 => [0.0; 3],
        3 => edge_sums::<3, 3>([a, b, c]),
        4 => edge_sums::<3, 4>([a, b, c]),
        5 => edge_sums::<3, 5>([a, b, c]),
        6 => edge_sums::<3, 6>([a, b, c]),
        7 => edge_sums::<3, 7>([a, b, c]),
        8 => edge_sums::<3, 8>([a, b, c]),
        9 => edge_sums::<3, 9>([a, b, c]),
        _ => edge_sums::<3, MAX_VERTICES>([a, b, c]),
    }
}

/// `(1/π) ∫ max(cos θ, 0) dω` over a polygon already clipped to z >= 0,
/// i.e. the form factor; in [0, 1] for any orientation of the vertex order.
pub fn cosine_integral(poly: &Polygon) -> f64 {
    (edge_sum(poly).abs() / (2.0 * PI)).min(1.0)
}

/// Clip then integrate: the form factor of the visible upper-hemisphere part.
pub fn clipped_cosine_integral(poly: &Polygon) -> f64 {
    cosine_integral(&poly.clip_upper())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn theta_over_sin_matches_acos_everywhere() {
        let mut worst: f64 = 0.0;
        for i in 0..=200_000 {
            let x = -0.999 + 1.999 * i as f64 / 200_000.0;
            let exact = if x >= 1.0 {
                1.0
            } else {
                x.acos() / (1.0 - x * x).sqrt()
            };
            worst = worst.max((theta_over_sin(x) - exact).abs() / exact);
        }
        assert!(worst < 1e-8, "worst relative error {worst}");
        assert!((theta_over_sin(1.0) - 1.0).abs() < 1e-8);
        assert!(theta_over_sin(-1.0).is_finite());
    }

    #[test]
    fn full_hemisphere_square_has_form_factor_near_one() {
        let s = 1e4;
        let p = Polygon::from_points(&[
            DVec3::new(-s, -s, 1.0),
            DVec3::new(s, -s, 1.0),
            DVec3::new(s, s, 1.0),
            DVec3::new(-s, s, 1.0),
        ]);
        let f = clipped_cosine_integral(&p);
        assert!((f - 1.0).abs() < 1e-3, "{f}");
    }

    #[test]
    fn clipping_an_octagon_twice_fits_the_buffer() {
        let pts: Vec<DVec3> = (0..8)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 8.0;
                DVec3::new(a.cos(), a.sin() + 0.3, a.cos() * 0.7 + 0.1)
            })
            .collect();
        let p = Polygon::from_points(&pts).clip_upper();
        assert!(p.n <= MAX_LIGHT_VERTICES + 1);
        let q = p.transformed(&DMat3::from_rotation_x(0.4)).clip_upper();
        assert!(q.n <= MAX_VERTICES);
    }
}

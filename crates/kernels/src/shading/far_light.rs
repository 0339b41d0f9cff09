//! One far light at many points at once, in `f32` lanes: its exact Lambert
//! form factor, and an upper bound on its GGX `U` per point. The `U`
//! stage's light culling hands it the far case: the light wholly above
//! every point's horizon, every point on its emitting side, every edge seen
//! under less than 60 degrees (`PointGroup::far_view`). Then no clipping
//! is needed and the contour integral is well conditioned, so `f32` carries
//! it to the rounding bound `form_factor_rounding` (measured in the tests
//! against the `f64` path), at a fraction of the `f64` batch's cost.
//!
//! The GGX bound (which holds for any light, far or not) is
//! `light_bound`'s, taken per point instead of per tile:
//! from one point the light's directions lie within `rho = r / (d - r)` of
//! the direction to its centre, so the cones are those of the light alone
//! and the bound is tight enough to leave a light's GGX lobe out wherever
//! the point's lobe does not face it.

use super::lanes::Lanes;
use super::light_bound::{LTC_FIT_MARGIN, LightExtent};
use super::polygon::{THETA_SIN_POLY, theta_over_sin_lanes};
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};

/// Points per vector.
pub const WIDE: usize = 16;
type W = Lanes<f32, WIDE>;

/// An absolute bound on the form factor's rounding per edge of the light,
/// in units of `f32::EPSILON`, plus the rounding of the vertices relative to
/// a point (`form_factor_rounding`). From the terms: unit vectors and their
/// cross product to ~4 eps each, `theta / sin` to 2 (polynomial, edges under
/// 60 degrees) and its product; a margin of 4 over the sum.
const EDGE_ROUNDING_EPS: f32 = 64.0;

/// The points as the kernel reads them, one array per coordinate, padded
/// to whole vectors with copies of the last point.
#[derive(Default, Debug, Clone)]
pub struct WidePoints {
    p: [Vec<f32>; 3],
    n: [Vec<f32>; 3],
    wo: [Vec<f32>; 3],
    alpha: Vec<f32>,
    /// Largest channel of F0 (0: no GGX lobe).
    f0: Vec<f32>,
    len: usize,
}

impl WidePoints {
    fn columns(&mut self) -> impl Iterator<Item = &mut Vec<f32>> {
        self.p
            .iter_mut()
            .chain(self.n.iter_mut())
            .chain(self.wo.iter_mut())
            .chain([&mut self.alpha, &mut self.f0])
    }

    pub fn clear(&mut self) {
        self.columns().for_each(Vec::clear);
        self.len = 0;
    }

    /// A point: position, unit shading normal, unit view direction, GGX
    /// alpha and the largest channel of F0. Points are pushed after `clear`
    /// and before `finish`.
    pub fn push(&mut self, p: Vec3, n: Vec3, wo: Vec3, alpha: f32, f0: f32) {
        debug_assert_eq!(self.alpha.len(), self.len, "push after finish");
        for k in 0..3 {
            self.p[k].push(p[k]);
            self.n[k].push(n[k]);
            self.wo[k].push(wo[k]);
        }
        self.alpha.push(alpha);
        self.f0.push(f0);
        self.len += 1;
    }

    /// Pads to whole vectors.
    pub fn finish(&mut self) {
        let whole = self.len.div_ceil(WIDE) * WIDE;
        self.columns().for_each(|c| {
            let last = c.last().copied().unwrap_or(0.0);
            c.resize(whole, last);
        });
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[inline(always)]
fn lanes(c: &[f32], g: usize) -> W {
    let mut v = W::ZERO;
    v.0.copy_from_slice(&c[g * WIDE..(g + 1) * WIDE]);
    v
}

#[inline(always)]
fn lanes3(v: &[Vec<f32>; 3], g: usize) -> [W; 3] {
    [lanes(&v[0], g), lanes(&v[1], g), lanes(&v[2], g)]
}

#[inline(always)]
fn dot(a: &[W; 3], b: &[W; 3]) -> W {
    a[0].mul_add(b[0], a[1].mul_add(b[1], a[2] * b[2]))
}

/// The rounding bound of a form factor of an `edges`-gon whose vertices,
/// seen from a point, lie at least `near` away, all coordinates at most
/// `scale` in magnitude.
pub fn form_factor_rounding(edges: usize, near: f32, scale: f32) -> f32 {
    let per_edge = EDGE_ROUNDING_EPS + 4.0 * scale / near.max(f32::MIN_POSITIVE);
    edges as f32 * per_edge * f32::EPSILON * std::f32::consts::FRAC_1_PI * 0.5
}

/// `theta / sin(theta)` for `x = cos(theta)` in [0.5, 1]: the `f64`
/// path's polynomial, evaluated in `f32`.
#[inline(always)]
fn theta_over_sin(x: W) -> W {
    let mut c = [W::ZERO; 11];
    for (c, &k) in c.iter_mut().zip(&THETA_SIN_POLY) {
        *c = W::splat(k);
    }
    theta_over_sin_lanes(&c, x)
}

/// The form factor `1/pi ∫ cos dω` of the polygon `vertices` (3 to 8, any
/// winding) at every point of `points` into `out[..points.len()]`, for
/// the far case of the module comment (the caller's to check).
pub fn form_factors(points: &WidePoints, vertices: &[Vec3], out: &mut [f32]) {
    isa::run_at_most_avx2(FormFactors {
        points,
        vertices,
        out,
    })
}

/// `form_factors` as a `Kernel` (`isa`).
struct FormFactors<'a> {
    points: &'a WidePoints,
    vertices: &'a [Vec3],
    out: &'a mut [f32],
}

impl Kernel for FormFactors<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        form_factors_of(self.points, self.vertices, self.out)
    }
}

#[inline(always)]
fn form_factors_of(points: &WidePoints, vertices: &[Vec3], out: &mut [f32]) {
    let nv = vertices.len().min(8);
    for g in 0..points.len.div_ceil(WIDE) {
        let p = lanes3(&points.p, g);
        let n = lanes3(&points.n, g);
        // Unit vectors from the points to each vertex.
        let mut u = [[W::ZERO; 3]; 8];
        for (i, v) in vertices.iter().take(nv).enumerate() {
            let a = [
                W::splat(v.x) - p[0],
                W::splat(v.y) - p[1],
                W::splat(v.z) - p[2],
            ];
            let inv = W::ONE / dot(&a, &a).sqrt();
            u[i] = [a[0] * inv, a[1] * inv, a[2] * inv];
        }
        let mut sum = W::ZERO;
        for i in 0..nv {
            let (a, b) = (&u[i], &u[(i + 1) % nv]);
            let cos = dot(a, b).clamp(0.5, 1.0);
            let cross = [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ];
            sum = theta_over_sin(cos).mul_add(dot(&n, &cross), sum);
        }
        let ff = (sum * W::splat(0.5 * std::f32::consts::FRAC_1_PI)).abs();
        store(ff, g, points.len, out);
    }
}

#[inline(always)]
fn store(v: W, g: usize, len: usize, out: &mut [f32]) {
    let lanes = v.to_f32();
    let start = g * WIDE;
    let end = (start + WIDE).min(len);
    out[start..end].copy_from_slice(&lanes[..end - start]);
}

/// `(cos, sin)` of `a + b` for angles in [0, pi] given as `(cos, sin)`,
/// at most pi.
#[inline(always)]
fn plus(a: (W, W), b: (W, W)) -> (W, W) {
    let cos = a.0 * b.0 - a.1 * b.1;
    let sin = a.1.mul_add(b.0, a.0 * b.1);
    let over = (a.0 + b.0).le(W::ZERO);
    (
        over.select(W::splat(-1.0), cos),
        over.select(W::ZERO, sin.max(W::ZERO)),
    )
}

/// `(cos, sin)` of `a - b`, at least 0.
#[inline(always)]
fn minus(a: (W, W), b: (W, W)) -> (W, W) {
    let cos = a.0.mul_add(b.0, a.1 * b.1);
    let sin = a.1 * b.0 - a.0 * b.1;
    let under = a.0.ge(b.0);
    (
        under.select(W::ONE, cos),
        under.select(W::ZERO, sin.max(W::ZERO)),
    )
}

#[inline(always)]
fn angle_of_cos(cos: W) -> (W, W) {
    let c = cos.clamp(-1.0, 1.0);
    (c, (W::ONE - c * c).max(W::ZERO).sqrt())
}

/// An upper bound on `light`'s GGX `U` per unit radiance (luminance, F0
/// at its largest channel) at every point of `points` into
/// `out[..points.len()]`. It holds for any light, near or far, clipped or
/// not (what a horizon clips only lowers the integral). Zero at
/// points without a GGX lobe, infinite where the view lies under the
/// point's shading horizon (see `light_bound`) or the point lies within the
/// light's bounding sphere.
pub fn ggx_bounds(points: &WidePoints, light: &LightExtent, out: &mut [f32]) {
    isa::run_at_most_avx2(GgxBounds { points, light, out })
}

/// `ggx_bounds` as a `Kernel` (`isa`).
struct GgxBounds<'a> {
    points: &'a WidePoints,
    light: &'a LightExtent,
    out: &'a mut [f32],
}

impl Kernel for GgxBounds<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        ggx_bounds_of(self.points, self.light, self.out)
    }
}

#[inline(always)]
fn ggx_bounds_of(points: &WidePoints, light: &LightExtent, out: &mut [f32]) {
    let c = light.centre;
    let (normal, r) = (light.normal, light.radius);
    for g in 0..points.len.div_ceil(WIDE) {
        let p = lanes3(&points.p, g);
        let n = lanes3(&points.n, g);
        let wo = lanes3(&points.wo, g);
        let alpha = lanes(&points.alpha, g);
        let f0 = lanes(&points.f0, g);
        let to = [
            W::splat(c.x) - p[0],
            W::splat(c.y) - p[1],
            W::splat(c.z) - p[2],
        ];
        let dist = dot(&to, &to).sqrt();
        let inv = W::ONE / dist;
        let wi = [to[0] * inv, to[1] * inv, to[2] * inv];
        // Every direction to the light lies within `spread` of `wi`.
        let near = (dist - W::splat(r)).max(W::splat(f32::MIN_POSITIVE));
        let spread_sin = (W::splat(r) / dist).min(W::ONE);
        let spread = (
            (W::ONE - spread_sin * spread_sin).max(W::ZERO).sqrt(),
            spread_sin,
        );
        // The light's solid angle: its area at its most facing, over near^2.
        let facing = dot(
            &wi,
            &[W::splat(normal.x), W::splat(normal.y), W::splat(normal.z)],
        );
        let facing = if light.two_sided {
            facing.abs()
        } else {
            -facing
        };
        let cos_light = minus(angle_of_cos(facing), spread).0.max(W::ZERO);
        let omega =
            (W::splat(light.area) * cos_light / (near * near)).min(W::splat(std::f32::consts::TAU));
        // Half vectors within `half` of the central one.
        let sum = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let m = dot(&sum, &sum).sqrt();
        let chord = (W::splat(2.0) * (W::ONE - spread.0)).max(W::ZERO).sqrt();
        let wide = chord.ge(m);
        let half_sin = (chord / m).min(W::ONE);
        let half = ((W::ONE - half_sin * half_sin).max(W::ZERO).sqrt(), half_sin);
        let cos_nh = dot(&n, &sum) / m;
        let off = minus(angle_of_cos(cos_nh), half);
        let off_cos = wide.select(W::ONE, off.0);
        // D at its largest: at `off` from the normal, with this alpha.
        let a2 = alpha * alpha;
        let c2 = off_cos.max(W::ZERO) * off_cos.max(W::ZERO);
        let den = c2.mul_add(a2 - W::ONE, W::ONE);
        let d_max = a2 / (W::splat(std::f32::consts::PI) * den * den);
        // G1(wo) / (4 cos_o).
        let co_signed = dot(&n, &wo);
        let co = co_signed.abs();
        let g1 = W::ONE / (W::splat(2.0) * (co + a2.mul_add(W::ONE - co * co, co * co).sqrt()));
        // Fresnel at the widest angle between wi and wo.
        let io = plus(angle_of_cos(dot(&wi, &wo)), spread);
        let cos_d = (W::splat(0.5) * (W::ONE + io.0)).max(W::ZERO).sqrt();
        let x = W::ONE - cos_d;
        let x2 = x * x;
        let f_max = f0 + (W::ONE - f0) * (x2 * x2 * x);
        let lobe = (W::splat(LTC_FIT_MARGIN) * d_max * g1 * omega).min(W::splat(LTC_FIT_MARGIN));
        // A view under the shading horizon: the LTC's grazing entry, no bound.
        // Inside the light's sphere its directions may span more than the
        // cone above: no bound there either.
        let outside = dist.gt(W::splat(r * (1.0 + 1e-4)));
        let bound = co_signed
            .gt(W::ZERO)
            .and(outside)
            .select(f_max * lobe, W::splat(f32::INFINITY));
        let bound = f0.gt(W::ZERO).select(bound, W::ZERO);
        store(bound, g, points.len, out);
    }
}

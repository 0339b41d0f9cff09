//! Helpers shared by the sampling tests: light construction, f64 reference
//! geometry and the BRDF of docs/scene-format.md.

use glam::{DVec3, Vec3};
use penumbra::scene::Light;

/// A quad light as the scene loader builds it (corners c ± u ± v, normal u×v).
pub fn quad_light(c: Vec3, u: Vec3, v: Vec3, two_sided: bool) -> Light {
    Light::quad(c, u, v, Vec3::ONE)
        .expect("a test quad spans an area")
        .with_two_sided(two_sided)
}

/// A convex polygon light of unit radiance; normal by the right-hand rule.
pub fn polygon_light(vertices: Vec<Vec3>, two_sided: bool) -> Light {
    super::ltc::polygon_light(&vertices, Vec3::ONE, two_sided)
}

/// A regular n-gon around `c` in the plane spanned by `a`, `b` (unit,
/// orthogonal), counter-clockwise about a × b.
pub fn regular_polygon(c: Vec3, a: Vec3, b: Vec3, r: f32, n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let t = i as f32 / n as f32 * std::f32::consts::TAU;
            c + r * (t.cos() * a + t.sin() * b)
        })
        .collect()
}

/// Solid angle of a triangle in f64 (Van Oosterom–Strackee).
pub fn tri_solid_angle(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let t = a.dot((b - a).cross(c - a)).abs();
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    2.0 * t.atan2(la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la)
}

/// Solid angle of a light's polygon seen from p, in f64.
pub fn light_solid_angle(light: &Light, p: Vec3) -> f64 {
    let v: Vec<DVec3> = light.vertices.iter().map(|x| (*x - p).as_dvec3()).collect();
    (1..v.len() - 1)
        .map(|i| tri_solid_angle(v[0], v[i], v[i + 1]))
        .sum()
}

/// Midpoint quadrature of ∫ g(ω) dω over a parallelogram light seen from p,
/// as an area integral: Σ g(wi) |cos_light| / d² dA (emitting side only
/// unless two-sided).
pub fn quad_integral(light: &Light, p: Vec3, n: usize, g: impl Fn(DVec3) -> f64) -> f64 {
    let (c, u, v) = light.quad.expect("a quad light");
    let (c, u, v, p) = (c.as_dvec3(), u.as_dvec3(), v.as_dvec3(), p.as_dvec3());
    let nrm = light.normal.as_dvec3();
    let da = 4.0 * u.cross(v).length() / (n * n) as f64;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let s = 2.0 * (i as f64 + 0.5) / n as f64 - 1.0;
            let t = 2.0 * (j as f64 + 0.5) / n as f64 - 1.0;
            let d = c + s * u + t * v - p;
            let dist2 = d.length_squared();
            let wi = d / dist2.sqrt();
            let cos_l = -wi.dot(nrm);
            if cos_l <= 0.0 && !light.two_sided {
                continue;
            }
            sum += g(wi) * cos_l.abs() / dist2 * da;
        }
    }
    sum
}

fn ggx_d(nh: f64, alpha: f64) -> f64 {
    if nh <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = nh * nh * (a2 - 1.0) + 1.0;
    a2 / (std::f64::consts::PI * t * t)
}

fn smith_lambda(cos: f64, alpha: f64) -> f64 {
    let c2 = cos * cos;
    let tan2 = (1.0 - c2).max(0.0) / c2;
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// The specular lobe of docs/scene-format.md with F = 1 (specular = [1,1,1]):
/// D G2 / (4 |n·wi| |n·wo|), height-correlated G2; 0 below either horizon.
pub fn f_spec(n: DVec3, wo: DVec3, wi: DVec3, alpha: f64) -> f64 {
    let (no, ni) = (n.dot(wo), n.dot(wi));
    if no <= 0.0 || ni <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize();
    let g2 = 1.0 / (1.0 + smith_lambda(ni, alpha) + smith_lambda(no, alpha));
    ggx_d(n.dot(h), alpha) * g2 / (4.0 * ni * no)
}

/// Mean and standard error of a sample.
pub fn mean_se(xs: &[f64]) -> (f64, f64) {
    let n = xs.len() as f64;
    let m = xs.iter().sum::<f64>() / n;
    let var = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0);
    (m, (var / n).sqrt())
}

/// Pearson chi-square statistic of observed counts against expected ones.
pub fn chi_square(observed: &[f64], expected: &[f64]) -> f64 {
    observed
        .iter()
        .zip(expected)
        .map(|(o, e)| (o - e) * (o - e) / e)
        .sum()
}

/// A chi-square bound no correct sampler exceeds in practice: mean + 5 sd of
/// the chi-square distribution with `dof` degrees of freedom.
pub fn chi_square_bound(dof: usize) -> f64 {
    dof as f64 + 5.0 * (2.0 * dof as f64).sqrt()
}

//! Brute-force references for the shading tests: adaptive quadrature of the
//! BRDF x light over the light's AREA (not its contour, as the code under
//! test does), in f64, after clipping the light by the tangent plane so that
//! the integrand is smooth on every triangle.
// The 3-component loops index several arrays at once, which reads better
// than zipped iterators.
#![allow(clippy::needless_range_loop)]

use glam::{DVec3, Vec3};
use penumbra::scene::Light;
use penumbra::shading::SurfacePoint;
use penumbra::shading::brdf;

/// Reference integrals for one light at one point.
#[derive(Clone, Copy, Debug, Default)]
pub struct Reference {
    /// ∫ cos/π dω (the form factor): U_diffuse = diffuse * L * ff.
    pub ff: f64,
    /// ∫ f_spec(F=1) cos dω.
    pub spec_a: f64,
    /// ∫ f_spec(F=1) (1 - wo.h)^5 cos dω.
    pub spec_b: f64,
    /// Quadrature evaluations used.
    pub evals: usize,
    /// Estimated relative error reached (sum of the per-triangle estimates).
    pub est_rel_err: f64,
}

impl Reference {
    /// (diffuse, specular) U as `unshadowed_lobes` defines it.
    pub fn lobes(&self, sp: &SurfacePoint, light: &Light) -> (Vec3, Vec3) {
        let d = sp.diffuse * light.radiance * self.ff as f32;
        let s = light.radiance
            * (sp.specular * self.spec_a as f32 + (Vec3::ONE - sp.specular) * self.spec_b as f32);
        (d, s)
    }
}

// Degree-5, 7-point rule on a triangle (barycentric points and weights).
const A1: f64 = 0.059_715_871_789_770;
const B1: f64 = 0.470_142_064_105_115;
const W1: f64 = 0.132_394_152_788_506;
const A2: f64 = 0.797_426_985_353_087;
const B2: f64 = 0.101_286_507_323_456;
const W2: f64 = 0.125_939_180_544_827;
const W0: f64 = 0.225;

struct Setup {
    n: DVec3,
    tx: DVec3,
    ty: DVec3,
    wo_local: Vec3,
    alpha: f32,
    light_n: DVec3,
}

impl Setup {
    /// Integrand per unit area at light point `x` (relative to the shading
    /// point): [cos/π, f1 cos, f1 s cos] * cos_l / r².
    fn eval(&self, x: DVec3) -> [f64; 3] {
        let r2 = x.length_squared();
        if r2 == 0.0 {
            return [0.0; 3];
        }
        let r = r2.sqrt();
        let w = x / r;
        let cos_i = w.dot(self.n);
        if cos_i <= 0.0 {
            return [0.0; 3];
        }
        let jac = self.light_n.dot(w).abs() / r2;
        let wl = Vec3::new(w.dot(self.tx) as f32, w.dot(self.ty) as f32, cos_i as f32);
        let (f1, cos_oh) = brdf::spec_local(self.alpha, wl, self.wo_local);
        let f1 = f1 as f64 * cos_i * jac;
        [
            cos_i / std::f64::consts::PI * jac,
            f1,
            f1 * brdf::schlick_weight(cos_oh) as f64,
        ]
    }

    fn rule(&self, t: &[DVec3; 3]) -> [f64; 3] {
        let area = 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length();
        let mut s = [0.0; 3];
        let mut add = |b: [f64; 3], wgt: f64| {
            let v = self.eval(t[0] * b[0] + t[1] * b[1] + t[2] * b[2]);
            for k in 0..3 {
                s[k] += wgt * v[k];
            }
        };
        add([1.0 / 3.0; 3], W0);
        for (a, b, w) in [(A1, B1, W1), (A2, B2, W2)] {
            add([a, b, b], w);
            add([b, a, b], w);
            add([b, b, a], w);
        }
        s.map(|v| v * area)
    }

    fn split(t: &[DVec3; 3]) -> [[DVec3; 3]; 4] {
        let m01 = (t[0] + t[1]) * 0.5;
        let m12 = (t[1] + t[2]) * 0.5;
        let m20 = (t[2] + t[0]) * 0.5;
        [
            [t[0], m01, m20],
            [m01, t[1], m12],
            [m20, m12, t[2]],
            [m01, m12, m20],
        ]
    }

    /// A triangle with its rule value and the value of its 4 children.
    fn node(&self, t: [DVec3; 3]) -> Node {
        let whole = self.rule(&t);
        let mut fine = [0.0; 3];
        for k in Self::split(&t) {
            let v = self.rule(&k);
            for c in 0..3 {
                fine[c] += v[c];
            }
        }
        Node {
            t,
            fine,
            diff: (0..3)
                .map(|c| (fine[c] - whole[c]).abs())
                .collect::<Vec<_>>()
                .try_into()
                .unwrap(),
            key: 0.0,
        }
    }
}

struct Node {
    t: [DVec3; 3],
    fine: [f64; 3],
    diff: [f64; 3],
    key: f64,
}

impl PartialEq for Node {
    fn eq(&self, o: &Self) -> bool {
        self.key == o.key
    }
}
impl Eq for Node {}
impl PartialOrd for Node {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Node {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.key.total_cmp(&o.key)
    }
}

/// Clips a convex polygon against the half-space `n . x >= 0`.
fn clip_plane(poly: &[DVec3], n: DVec3) -> Vec<DVec3> {
    let mut out = Vec::new();
    for i in 0..poly.len() {
        let a = poly[i];
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (a.dot(n), b.dot(n));
        if da >= 0.0 {
            out.push(a);
        }
        if (da > 0.0 && db < 0.0) || (da < 0.0 && db > 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

/// Brute-force integrals with relative tolerance `rel_tol` per component
/// (relative to a first coarse estimate of each).
pub fn reference(sp: &SurfacePoint, light: &Light, rel_tol: f64) -> Reference {
    let p = sp.p.as_dvec3();
    let ln = light.normal.as_dvec3();
    let side = ln.dot(p - light.vertices[0].as_dvec3());
    if !(side > 0.0 || (light.two_sided && side < 0.0)) {
        return Reference::default();
    }
    let n = sp.n.as_dvec3();
    let frame = brdf::ShadingBasis::from_normal_view(sp.n, sp.wo);
    let setup = Setup {
        n,
        tx: frame.x.as_dvec3(),
        ty: frame.y.as_dvec3(),
        wo_local: frame.to_local(sp.wo),
        alpha: brdf::alpha_from_roughness(sp.roughness),
        light_n: ln,
    };
    let local: Vec<DVec3> = light.vertices.iter().map(|v| v.as_dvec3() - p).collect();
    let poly = clip_plane(&local, n);
    if poly.len() < 3 {
        return Reference::default();
    }
    // Fan of triangles, each pre-split 4 levels so the first estimate that
    // sets the tolerance is already decent.
    let mut tris = Vec::new();
    for i in 1..poly.len() - 1 {
        tris.push([poly[0], poly[i], poly[i + 1]]);
    }
    for _ in 0..4 {
        let mut next = Vec::new();
        for t in tris {
            let m01 = (t[0] + t[1]) * 0.5;
            let m12 = (t[1] + t[2]) * 0.5;
            let m20 = (t[2] + t[0]) * 0.5;
            next.extend([
                [t[0], m01, m20],
                [m01, t[1], m12],
                [m20, m12, t[2]],
                [m01, m12, m20],
            ]);
        }
        tris = next;
    }
    // Global adaptivity: always refine the triangle whose estimated error
    // (children minus parent, relative to each component's total) is
    // largest, until the summed estimate is below `rel_tol` or the budget
    // is spent. Bounded cost whatever the integrand does.
    let mut nodes: Vec<Node> = tris.into_iter().map(|t| setup.node(t)).collect();
    let mut evals = nodes.len() * 35;
    let mut total = [0.0; 3];
    for nd in &nodes {
        for c in 0..3 {
            total[c] += nd.fine[c];
        }
    }
    let scale = total.map(|v| {
        if v.abs() > 1e-14 {
            v.abs()
        } else {
            f64::INFINITY
        }
    });
    let key = |nd: &Node| (0..3).map(|c| nd.diff[c] / scale[c]).fold(0.0, f64::max);
    let mut err_sum = 0.0;
    for nd in &mut nodes {
        nd.key = key(nd);
        err_sum += nd.key;
    }
    let mut heap: std::collections::BinaryHeap<Node> = nodes.into();
    const BUDGET: usize = 3_000_000;
    while err_sum > rel_tol && evals < BUDGET {
        let worst = heap.pop().unwrap();
        err_sum -= worst.key;
        for k in Setup::split(&worst.t) {
            let mut nd = setup.node(k);
            nd.key = key(&nd);
            err_sum += nd.key;
            heap.push(nd);
        }
        evals += 4 * 35;
    }
    let mut out = [0.0; 3];
    for nd in heap.iter() {
        for c in 0..3 {
            out[c] += nd.fine[c];
        }
    }
    Reference {
        ff: out[0],
        spec_a: out[1],
        spec_b: out[2],
        evals,
        est_rel_err: err_sum,
    }
}

/// A light from its vertices (normal from the right-hand rule).
pub fn polygon_light(vertices: &[Vec3], radiance: Vec3, two_sided: bool) -> Light {
    let mut area2 = Vec3::ZERO;
    for i in 1..vertices.len() - 1 {
        area2 += (vertices[i] - vertices[0]).cross(vertices[i + 1] - vertices[0]);
    }
    Light {
        vertices: vertices.to_vec(),
        radiance,
        two_sided,
        normal: area2.normalize(),
        area: 0.5 * area2.length(),
        quad: None,
    }
}

/// A parallelogram light with corners c ± u ± v, emitting along u × v.
pub fn quad_light(c: Vec3, u: Vec3, v: Vec3, radiance: Vec3, two_sided: bool) -> Light {
    let mut l = polygon_light(
        &[c - u - v, c + u - v, c + u + v, c - u + v],
        radiance,
        two_sided,
    );
    l.quad = Some((c, u, v));
    l
}

/// A square light of half-size `h` centred at `c`, emitting along `facing`.
pub fn facing_square(c: Vec3, facing: Vec3, h: f32, radiance: Vec3) -> Light {
    let f = facing.normalize();
    let u = f.any_orthonormal_vector() * h;
    let v = f.cross(u);
    quad_light(c, u, v, radiance, false)
}

/// Relative error with a guard for zero references.
pub fn rel(x: f32, reference: f32) -> f32 {
    if reference == 0.0 {
        if x == 0.0 { 0.0 } else { f32::INFINITY }
    } else {
        (x - reference).abs() / reference.abs()
    }
}

/// ∫ f_spec(F=1) cos over the whole hemisphere for a local view `wo`
/// (VNDF estimate, 512² strata): the scale of the whole specular lobe.
pub fn lobe_total(roughness: f32, wo: Vec3) -> f32 {
    let a = brdf::alpha_from_roughness(roughness);
    let k = 512;
    let mut s = 0.0f64;
    for j in 0..k {
        for i in 0..k {
            let h = brdf::sample_vndf(
                a,
                wo,
                (i as f32 + 0.5) / k as f32,
                (j as f32 + 0.5) / k as f32,
            );
            let wi = brdf::reflect(wo, h);
            if wi.z > 0.0 {
                s += (brdf::spec_f1_local(a, wi, wo) * wi.z / brdf::vndf_pdf(a, wi, wo)) as f64;
            }
        }
    }
    (s / (k * k) as f64) as f32
}

/// A surface point at `p` with normal +Z, viewed from `view_deg` off the
/// normal in the xz plane, white diffuse and the given F0 and roughness.
pub fn point_z(p: Vec3, view_deg: f32, specular: Vec3, roughness: f32) -> SurfacePoint {
    let t = view_deg.to_radians();
    SurfacePoint {
        p,
        n: Vec3::Z,
        wo: Vec3::new(t.sin(), 0.0, t.cos()),
        diffuse: Vec3::ONE,
        specular,
        roughness,
    }
}

/// The `q` quantile (0 to 1, nearest rank) of `v`, which it sorts.
pub fn quantile(v: &mut [f32], q: f64) -> f32 {
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

//! The analytic unshadowed light `U` of `unshadowed` for `LANES` (4) pixels at a
//! time, one pixel per lane (`lanes::Wide`, `f64` elements), branch-free
//! within a batch: the three contour sums (the Lambert form factor and the
//! two LTC lobes), the clipping of the LTC images to their horizon, and the
//! LTC shape correction (`ltc_correction::lobe_factors_lanes`) all run
//! across pixels.
//!
//! Per batch, what does not depend on the light is set up once, across the
//! lanes in `f32` (`PixelBatch::new`, bit for bit the scalar path's values):
//! the shading frame, the LTC cell (the blend of four table cells stays a
//! per-lane gather, transposed into lanes) and the correction's constants. Per light, the vertices are taken
//! into each lane's local frame; each contour sum is a loop over the edges
//! with running sums.
//!
//! Why `f64` lanes. A first version ran `f32` lanes (twice the pixels per
//! instruction) and sent the lanes it could not vouch for to the scalar
//! path: on `room` a third of them, because the LTC images of mid-rough
//! lobes compress lights away from the highlight, and the contour sum of a
//! small image cancels beyond what `f32` carries (measured deviations up to
//! 23 % there). In `f64` the same arithmetic is the scalar path's, and the
//! fallback falls to the lights that straddle a lane's horizon.
//!
//! Horizon clips. A light that straddles a lane's horizon is clipped to it
//! in that lane (`clip_lane`, scalar code, the scalar path's
//! Sutherland-Hodgman) into `N + 1` slots, and a batch with such a lane
//! integrates all its lanes' polygons in `N + 1` slots, the unclipped ones
//! with their first vertex repeated (an edge that adds exactly 0: their
//! answers do not change). On the 4-light `u_pass` G-buffer this kept
//! 12.6 % of the lanes off the scalar path, which cost four vector lanes
//! each.
//!
//! Which lanes stay here. A lane goes to the scalar path
//! (`unshadowed_lobes_prepared`, whose answer it then has exactly) when it
//! lies (nearly) in the light's plane, or when the rounding bound of its
//! contour sums exceeds `REL_TOL` of its pixel's whole `U` (this light's
//! and what the lights shaded before it give the pixel, `set_others`; edge
//! terms are computed from a vertex and the light's edge vector,
//! `a x b = a x (b - a)`, so each keeps its own precision; each lane
//! bounds the cancellation between them).
//! Lanes unlit or entirely under the horizon get exactly 0, as in the
//! scalar path. `tests/u_batch.rs` checks the result against the scalar
//! path.

use super::brdf::MIN_ALPHA;
use super::lanes::{BatchFloat, Mask, Wide, Wide3, dot};
use super::ltc::{self, CellLanes, LtcCell};
use super::ltc_correction::{CorrectionLanes, Stakes, lobe_factors_lanes};
use super::polygon::MAX_LIGHT_VERTICES;

/// Slots of a light's polygon in lanes: its vertices, and one more for a
/// polygon clipped to the horizon. Loops run to the light's own count, so
/// one copy of each kernel serves every light.
const SLOTS: usize = MAX_LIGHT_VERTICES + 1;

/// The slots a polygon of `len` uses: `N` where the caller fixed it at
/// compile time (triangles and quads, whose loops LLVM then unrolls), its
/// run-time length where `N` is 0 (every other light, one copy for all).
#[inline(always)]
fn slots<const N: usize>(len: usize) -> usize {
    if N == 0 { len } else { N }
}
use super::unshadowed::{ShadingLight, SurfacePoint, unshadowed_lobes_among};
use glam::{BVec4A, DVec3, Vec3, Vec4};
use penumbra_isa::{self as isa, Kernel};
use penumbra_scene::Light;
use penumbra_scene::color::luminance;

pub use super::lanes::LANES;

/// Relative error of a lane's lobes (against the `f64` path, as a share of
/// its pixel's whole `U`) that the fast path accepts; above it the lane
/// goes to the scalar path.
pub const REL_TOL: f32 = 2e-4;
/// Rounding of one edge term, in ulps of its magnitude bound (rotation,
/// LTC map, cross and dot products).
const ERR_ULPS: BatchFloat = 16.0;
/// A point this close to the light's plane (relative to its distance) is
/// decided by the scalar path (exactly as it decides it).
const SIDE_TOL: f32 = 1e-5;

/// A light as the batch reads it: vertices, exact edge vectors, plane,
/// sidedness, and the
/// light prepared for the scalar path (for the lanes sent there).
#[derive(Clone, Copy, Debug)]
pub struct BatchLight {
    /// Vertex count; 0 for a light that cannot emit (as `ShadingLight`).
    n: usize,
    v: [[BatchFloat; 3]; MAX_LIGHT_VERTICES],
    e: [[BatchFloat; 3]; MAX_LIGHT_VERTICES],
    normal: [BatchFloat; 3],
    radiance: Vec3,
    two_sided: bool,
    scalar: ShadingLight,
}

impl BatchLight {
    pub fn new(light: &Light) -> BatchLight {
        // The scalar light decides which lights emit at all (n = 0: dark
        // or degenerate); the batch follows it.
        let scalar = ShadingLight::new(light);
        let n = scalar.vertex_count();
        let mut v = [[0.0 as BatchFloat; 3]; MAX_LIGHT_VERTICES];
        let mut e = [[0.0 as BatchFloat; 3]; MAX_LIGHT_VERTICES];
        for i in 0..n {
            let (a, b) = (light.vertices[i], light.vertices[(i + 1) % n]);
            v[i] = a.as_dvec3().to_array().map(|x| x as BatchFloat);
            let d = b.as_dvec3() - a.as_dvec3();
            e[i] = [d.x as BatchFloat, d.y as BatchFloat, d.z as BatchFloat];
        }
        BatchLight {
            n,
            v,
            e,
            normal: light.normal.as_dvec3().to_array().map(|x| x as BatchFloat),
            radiance: light.radiance,
            two_sided: light.two_sided,
            scalar,
        }
    }
}

/// Up to `LANES` shading points with what does not depend on the light.
pub struct PixelBatch {
    sp: [SurfacePoint; LANES],
    /// Lanes that hold a point (the rest of a row's last batch is padding).
    active: Mask,
    p: Wide3,
    /// Rows of each lane's local frame: x, y, z (= normal), world vectors.
    frame: [Wide3; 3],
    kd: Wide3,
    ks: Wide3,
    /// Lanes with a specular lobe (its LTC lobe A, the F0 term, carries
    /// weight in all of them: the same test), and those of them whose lobe
    /// B (Schlick) does.
    lobe: Mask,
    want_b: Mask,
    /// `M^-1` of lobe A and of lobe B: m00, m02, m20, m22; their infinity
    /// norms (for the error bound).
    ma: [Wide; 4],
    mb: [Wide; 4],
    norm_a: Wide,
    norm_b: Wide,
    /// Each lobe's LTC integral and cosine share: `share = w ltc + mix ff`.
    wa: Wide,
    mix: Wide,
    wb: Wide,
    fmix: Wide,
    mag: Wide,
    fres: Wide,
    corr: CorrectionLanes,
    /// What the lights already shaded give each lane (luminance of `U`):
    /// the shape correction is refined only where this light's doubt
    /// matters against the pixel's whole `U` (`set_others`; 0 until set).
    others: Wide,
}

impl PixelBatch {
    /// `points[l]` for each lane `l` that has one (at most `LANES`).
    ///
    /// Across the lanes in `f32` (`Vec4`, one lane per element) with the
    /// scalar path's formulas in its order of operations, so every lane
    /// gets its pixel's frame, cell and constants bit for bit; converted to
    /// `f64` lanes once at the end.
    pub fn new(points: &[Option<SurfacePoint>]) -> PixelBatch {
        isa::run(NewBatch(points))
    }

    #[inline(always)]
    fn setup(points: &[Option<SurfacePoint>]) -> PixelBatch {
        const { assert!(LANES == 4, "the setup runs on Vec4 lanes") };
        // Read in place (each field gathered once across the lanes); the
        // points themselves are copied once, into the batch.
        let at = |l: usize| points.get(l).and_then(Option::as_ref);
        let sp = [0, 1, 2, 3].map(|l| at(l).unwrap_or(&BLANK));
        let active = Mask::from_fn(|l| at(l).is_some());
        let v4 = |f: fn(&SurfacePoint) -> f32| Vec4::new(f(sp[0]), f(sp[1]), f(sp[2]), f(sp[3]));
        let n = [v4(|s| s.n.x), v4(|s| s.n.y), v4(|s| s.n.z)];
        let wo = [v4(|s| s.wo.x), v4(|s| s.wo.y), v4(|s| s.wo.z)];
        let (frame, cos_v) = frames(&n, &wo);
        let ks = [
            v4(|s| s.specular.x),
            v4(|s| s.specular.y),
            v4(|s| s.specular.z),
        ]
        .map(Wide::from_vec4);
        // `has_specular_lobe` (`Vec3::max_element`, whose compare-select
        // `Wide::max` is) and `min_element() < 1`, on the exact `f64`
        // values. Lobe A is wanted wherever there is a lobe (the same test).
        let lobe = active.and(ks[0].max(ks[1]).max(ks[2]).gt(Wide::ZERO));
        let want_b = lobe.and(ks[0].min(ks[1]).min(ks[2]).lt(Wide::ONE));
        // Lanes without a specular lobe (and padding) get a harmless cell
        // (their lobes are masked off): identity matrices, unit masses, no
        // magnitude; a normal view and alpha 1.
        let on = BVec4A::new(lobe.lane(0), lobe.lane(1), lobe.lane(2), lobe.lane(3));
        let roughness = v4(|s| s.roughness);
        let mut cells = ltc::packed_table().lookup_lanes(roughness, cos_v);
        for (l, cell) in cells.iter_mut().enumerate() {
            if !lobe.lane(l) {
                *cell = ltc::packed_cell(&BLANK_CELL);
            }
        }
        let cells = CellLanes::from_packed(&cells);
        let c = cos_v.clamp(Vec4::ZERO, Vec4::ONE);
        let view = [
            Vec4::select(on, (Vec4::ONE - c * c).sqrt(), Vec4::ZERO),
            Vec4::select(on, c, Vec4::ONE),
        ];
        // `alpha_from_roughness`.
        let r = roughness.clamp(Vec4::ZERO, Vec4::ONE);
        let alpha = Vec4::select(on, (r * r).max(Vec4::splat(MIN_ALPHA)), Vec4::ONE);

        let ma = cells.ma().map(Wide::from_vec4);
        let mb = cells.mb().map(Wide::from_vec4);
        let norm = |m: &[Wide; 4]| {
            (m[0].abs() + m[1].abs())
                .max(m[2].abs() + m[3].abs())
                .max(Wide::ONE)
        };
        let (mix, fmix) = (Wide::from_vec4(cells.mix()), Wide::from_vec4(cells.fmix()));
        let wide3 = |v: [Vec4; 3]| v.map(Wide::from_vec4);
        PixelBatch {
            active,
            p: wide3([v4(|s| s.p.x), v4(|s| s.p.y), v4(|s| s.p.z)]),
            frame: frame.map(wide3),
            kd: wide3([
                v4(|s| s.diffuse.x),
                v4(|s| s.diffuse.y),
                v4(|s| s.diffuse.z),
            ]),
            ks,
            lobe,
            want_b,
            norm_a: norm(&ma),
            norm_b: norm(&mb),
            ma,
            mb,
            wa: (Wide::ONE - mix) / Wide::from_vec4(cells.hmass()),
            mix,
            wb: (Wide::ONE - fmix) / Wide::from_vec4(cells.fhmass()),
            fmix,
            mag: Wide::from_vec4(cells.mag()),
            fres: Wide::from_vec4(cells.fres()),
            corr: CorrectionLanes::new(&cells, view, alpha),
            others: Wide::ZERO,
            sp: sp.map(|s| *s),
        }
    }

    /// The luminance of `U` that other lights give each lane, for the next
    /// light's shape correction to weigh its doubt against.
    pub fn set_others(&mut self, others: [f32; LANES]) {
        self.others = Wide::from_vec4(Vec4::from_array(others));
    }

    /// The shading point of lane `l`, if any.
    pub fn point(&self, l: usize) -> Option<&SurfacePoint> {
        self.active.lane(l).then_some(&self.sp[l])
    }
}

/// `PixelBatch::new` as a `Kernel` (`isa`).
struct NewBatch<'a>(&'a [Option<SurfacePoint>]);

impl Kernel for NewBatch<'_> {
    type Out = PixelBatch;
    #[inline(always)]
    fn run(self) -> PixelBatch {
        PixelBatch::setup(self.0)
    }
}

/// The padding lanes' point (never shaded: masked off by `active`).
const BLANK: SurfacePoint = SurfacePoint {
    p: Vec3::ZERO,
    n: Vec3::Z,
    wo: Vec3::Z,
    diffuse: Vec3::ZERO,
    specular: Vec3::ZERO,
    roughness: 1.0,
};

/// The cell of lanes without a specular lobe.
const BLANK_CELL: LtcCell = LtcCell {
    m00: 1.0,
    m02: 0.0,
    m20: 0.0,
    m22: 1.0,
    mag: 0.0,
    hmass: 1.0,
    mix: 0.0,
    f00: 1.0,
    f02: 0.0,
    f20: 0.0,
    f22: 1.0,
    fres: 0.0,
    fhmass: 1.0,
    fmix: 0.0,
    err: 0.0,
};

/// `ShadingBasis::from_normal_view` of each lane (rows x, y, z as world vectors),
/// and `n . wo` (the scalar path's LTC lookup cosine). Lanes whose view
/// lies along the normal take the scalar fallback, lane by lane.
#[inline(always)]
fn frames(n: &[Vec4; 3], wo: &[Vec4; 3]) -> ([[Vec4; 3]; 3], Vec4) {
    let dot = |a: &[Vec4; 3], b: &[Vec4; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let nw = dot(n, wo);
    let t = [wo[0] - n[0] * nw, wo[1] - n[1] * nw, wo[2] - n[2] * nw];
    let l2 = dot(&t, &t);
    let len = l2.sqrt();
    let mut x = [t[0] / len, t[1] / len, t[2] / len];
    // As the scalar rule: `l2 > 1e-12` or the fallback (NaN included).
    let tangent = l2.cmpgt(Vec4::splat(1e-12));
    for l in 0..LANES {
        if !tangent.test(l) {
            let f = Vec3::new(n[0][l], n[1][l], n[2][l]).any_orthonormal_vector();
            (x[0][l], x[1][l], x[2][l]) = (f.x, f.y, f.z);
        }
    }
    // `n.cross(x)` as glam writes it.
    let y = [
        n[1] * x[2] - x[1] * n[2],
        n[2] * x[0] - x[2] * n[0],
        n[0] * x[1] - x[0] * n[1],
    ];
    ([x, y, *n], nw)
}

/// (diffuse, specular) lobes per lane, one `[f32; LANES]` per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LaneLobes {
    pub diffuse: [[f32; LANES]; 3],
    pub specular: [[f32; LANES]; 3],
}

impl LaneLobes {
    /// Lane `l` as `(diffuse, specular)`.
    #[inline]
    pub fn lane(&self, l: usize) -> (Vec3, Vec3) {
        let [d, s] = [&self.diffuse, &self.specular].map(|c| Vec3::new(c[0][l], c[1][l], c[2][l]));
        (d, s)
    }

    #[inline]
    fn set_lane(&mut self, l: usize, (d, s): (Vec3, Vec3)) {
        for k in 0..3 {
            self.diffuse[k][l] = d[k];
            self.specular[k][l] = s[k];
        }
    }
}

/// How the lanes of one or more batches went, for tests and measurements.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LaneCounts {
    /// Lanes finished on the fast path (including unlit ones).
    pub fast: u64,
    /// Lanes handed to the scalar path.
    pub scalar: u64,
}

/// (diffuse, specular) lobes of `light` for every lane of `batch`, as
/// `unshadowed_lobes_prepared` gives them (zero for inactive lanes).
pub fn lobes_batch(batch: &PixelBatch, light: &BatchLight, out: &mut LaneLobes) -> LaneCounts {
    isa::run(Lobes {
        batch,
        light,
        specular: true,
        out,
    })
}

/// `lobes_batch` without the GGX lobe (its specular lobes are zero), for
/// a light whose GGX share is known to be negligible.
pub fn diffuse_batch(batch: &PixelBatch, light: &BatchLight, out: &mut LaneLobes) -> LaneCounts {
    isa::run(Lobes {
        batch,
        light,
        specular: false,
        out,
    })
}

/// `lobes_of` as a `Kernel` (`isa`).
struct Lobes<'a> {
    batch: &'a PixelBatch,
    light: &'a BatchLight,
    specular: bool,
    out: &'a mut LaneLobes,
}

impl Kernel for Lobes<'_> {
    type Out = LaneCounts;
    #[inline(always)]
    fn run(self) -> LaneCounts {
        lobes_of(self.batch, self.light, self.specular, self.out)
    }
}

#[inline(always)]
fn lobes_of(
    batch: &PixelBatch,
    light: &BatchLight,
    specular: bool,
    out: &mut LaneLobes,
) -> LaneCounts {
    match light.n {
        3 => lobes_n::<3, 4>(batch, light, specular, out),
        4 => lobes_n::<4, 5>(batch, light, specular, out),
        5..=MAX_LIGHT_VERTICES => lobes_n::<0, 0>(batch, light, specular, out),
        _ => {
            *out = LaneLobes::default();
            LaneCounts {
                fast: count(batch.active),
                scalar: 0,
            }
        }
    }
}

fn count(m: Mask) -> u64 {
    m.0.iter().filter(|&&b| b != 0).count() as u64
}

#[inline(always)]
fn splat3(v: [impl Into<BatchFloat> + Copy; 3]) -> Wide3 {
    [Wide::splat(v[0]), Wide::splat(v[1]), Wide::splat(v[2])]
}

/// `d` in the local frame whose rows (world vectors) are `frame`.
#[inline(always)]
fn rotate(frame: &[Wide3; 3], d: &Wide3) -> Wide3 {
    [dot(&frame[0], d), dot(&frame[1], d), dot(&frame[2], d)]
}

/// The LTC image `M^-1 v` (m = m00, m02, m20, m22).
#[inline(always)]
pub(super) fn ltc_map(m: &[Wide; 4], v: &Wide3) -> Wide3 {
    [
        m[0].mul_add(v[0], m[1] * v[2]),
        v[1],
        m[2].mul_add(v[0], m[3] * v[2]),
    ]
}

/// `|v|` per lane, at least the smallest normal number (so that `1 / |v|`
/// of a zero vector stays finite: its edges add 0).
#[inline(always)]
fn length(v: &Wide3) -> Wide {
    dot(v, v).max(Wide::splat(BatchFloat::MIN_POSITIVE)).sqrt()
}

/// `1 / |v|` per lane (see `length`).
#[inline(always)]
fn inv_len(v: &Wide3) -> Wide {
    Wide::ONE / length(v)
}

/// Its relative error bound (`polygon::theta_over_sin_pos`, degree 10,
/// 2.1e-9), carried into each lane's error bound.
const POLY_ERR_F64: BatchFloat = 3e-9;

/// `polygon::THETA_SIN_POLY` in every lane, as whole vectors. (Meant to let
/// the multiply-adds read them from memory; the instruction profile
/// (`u_profile` under callgrind) shows LLVM still broadcasts each one before
/// use, and copies of them as
/// run-time data traded those broadcasts for more register moves.)
static THETA_SIN_WIDE: [Wide; 11] = {
    let p = super::polygon::THETA_SIN_POLY;
    let mut w = [Wide::ZERO; 11];
    let mut i = 0;
    while i < 11 {
        w[i] = super::lanes::Lanes([p[i]; super::lanes::LANES]);
        i += 1;
    }
    w
};

/// `theta / sin(theta)` for `x = cos(theta)` in [0, 1]: the scalar path's
/// polynomial, per lane.
#[inline(always)]
fn theta_over_sin_pos(x: Wide) -> Wide {
    super::polygon::theta_over_sin_lanes(&THETA_SIN_WIDE, x)
}

/// `theta / sin(theta)` for x in [-1, 1] (already clamped): below 0,
/// `pi / sin - theta' / sin`, as `polygon::theta_over_sin`.
#[inline(always)]
fn theta_over_sin(x: Wide) -> Wide {
    let p = theta_over_sin_pos(x.abs());
    let s = ((Wide::ONE - x) * (Wide::ONE + x))
        .max(Wide::splat(1e-30))
        .sqrt();
    let far = Wide::splat(std::f64::consts::PI) / s - p;
    x.ge(Wide::ZERO).select(p, far)
}

/// One edge from `a` (inverse length `ia`) along `e` to `b` (inverse length
/// `ib`): its cosine (clamped), its `z . (a x b) / (|a| |b|)` and the
/// magnitude its rounding error scales with.
#[inline(always)]
fn edge_parts(a: &Wide3, b: &Wide3, e: &Wide3, ia: Wide, ib: Wide) -> (Wide, Wide, Wide) {
    let w = ia * ib;
    let d = (dot(a, b) * w).clamp(-1.0, 1.0);
    // (a x b).z = (a x (b - a)).z: no cancellation between near-equal vertices.
    let cz = a[0].mul_add(e[1], -(a[1] * e[0])) * w;
    let size = (e[0].abs() + e[1].abs() + e[2].abs()) * ib;
    (d, cz, size)
}

/// A polygon's edges as a contour sum reads them: edge `i` as (cosine,
/// cz, size) (`edge_parts`). A trait with always-inlined methods rather
/// than a closure: LLVM stopped inlining the closures once the function
/// around them grew, and each call then cost a spill of everything live.
trait Edges {
    fn count(&self) -> usize;
    fn edge(&self, i: usize) -> (Wide, Wide, Wide);
}

/// Unclipped polygon: vertices `q`, exact edge vectors `e`, inverse vertex
/// lengths `inv`.
struct Unclipped<'a, const N: usize> {
    q: &'a [Wide3],
    e: &'a [Wide3],
    inv: &'a [Wide],
}

impl<const N: usize> Edges for Unclipped<'_, N> {
    #[inline(always)]
    fn count(&self) -> usize {
        slots::<N>(self.q.len())
    }
    #[inline(always)]
    fn edge(&self, i: usize) -> (Wide, Wide, Wide) {
        let j = if i + 1 == self.count() { 0 } else { i + 1 };
        edge_parts(&self.q[i], &self.q[j], &self.e[i], self.inv[i], self.inv[j])
    }
}

/// Edges already made: (cosines, cz, sizes).
impl Edges for (&[Wide], &[Wide], &[Wide]) {
    #[inline(always)]
    fn count(&self) -> usize {
        self.0.len()
    }
    #[inline(always)]
    fn edge(&self, i: usize) -> (Wide, Wide, Wide) {
        (self.0[i], self.1[i], self.2[i])
    }
}

/// `sum theta/sin(theta) cz` and `sum theta/sin(theta) size` over the
/// edges, each edge's terms added as soon as they are made (no arrays of
/// them live at once). The `pi / sin` branch of theta/sin is needed only
/// when some lane that counts (`live`) has an edge wider than 90 degrees
/// (rare: very wide polygons); then the edges are made again and summed
/// with it.
#[inline(always)]
fn sum_terms(edges: &impl Edges, live: Mask) -> (Wide, Wide) {
    let mut wide = Mask::NONE;
    let mut sum = Wide::ZERO;
    let mut bound = Wide::ZERO;
    for i in 0..edges.count() {
        let (d, cz, size) = edges.edge(i);
        wide = wide.or(d.lt(Wide::ZERO));
        let t = theta_over_sin_pos(d);
        sum = t.mul_add(cz, sum);
        bound = t.mul_add(size, bound);
    }
    if wide.and(live).any() {
        (sum, bound) = (Wide::ZERO, Wide::ZERO);
        for i in 0..edges.count() {
            let (d, cz, size) = edges.edge(i);
            let t = theta_over_sin(d);
            sum = t.mul_add(cz, sum);
            bound = t.mul_add(size, bound);
        }
    }
    (sum, bound)
}

/// The Lambert contour sum of the local polygon (`q` vertices, `e` edges;
/// no vertex below the horizon in the lanes that count), its error bound,
/// the vertex lengths and the unit vertices (which feed the shape
/// correction).
#[inline(always)]
fn lambert_sum<const N: usize>(
    q: &[Wide3],
    e: &[Wide3],
    live: Mask,
) -> (Wide, Wide, [Wide; SLOTS], [Wide3; SLOTS]) {
    let n = slots::<N>(q.len());
    let mut len = [Wide::ZERO; SLOTS];
    let mut inv = [Wide::ZERO; SLOTS];
    for i in 0..n {
        len[i] = length(&q[i]);
        inv[i] = Wide::ONE / len[i];
    }
    let edges = Unclipped::<N> {
        q,
        e,
        inv: &inv[..n],
    };
    let (sum, bound) = sum_terms(&edges, live);
    let mut u = [[Wide::ZERO; 3]; SLOTS];
    for i in 0..n {
        u[i] = [q[i][0] * inv[i], q[i][1] * inv[i], q[i][2] * inv[i]];
    }
    (sum, bound, len, u)
}

/// The mean of three channels.
#[inline(always)]
fn mean3(v: &[Wide; 3]) -> Wide {
    (v[0] + v[1] + v[2]) * Wide::splat(1.0 / 3.0)
}

/// `ltc_sum` as a `Kernel` (`isa`): out of line, where LLVM put it in
/// `shade` before, and at the batch's instruction set.
struct LtcSum<'a, const N: usize> {
    m: &'a [Wide; 4],
    norm: Wide,
    q: &'a [Wide3],
    e: &'a [Wide3],
    len_l: &'a [Wide],
    live: Mask,
}

impl<const N: usize> Kernel for LtcSum<'_, N> {
    type Out = (Wide, Wide, Wide);
    #[inline(always)]
    fn run(self) -> (Wide, Wide, Wide) {
        ltc_sum::<N>(self.m, self.norm, self.q, self.e, self.len_l, self.live)
    }
}

/// Contour sum of one LTC image (`m` applied to the local polygon), clipped
/// to its horizon where a lane that counts dips below it; its error bound;
/// and the factor by which the image magnifies the local rounding.
#[inline(always)]
fn ltc_sum<const N: usize>(
    m: &[Wide; 4],
    norm: Wide,
    q: &[Wide3],
    e: &[Wide3],
    len_l: &[Wide],
    live: Mask,
) -> (Wide, Wide, Wide) {
    let n = slots::<N>(q.len());
    let mut qi = [[Wide::ZERO; 3]; SLOTS];
    let mut ei = [[Wide::ZERO; 3]; SLOTS];
    let mut len = [Wide::ZERO; SLOTS];
    let mut inv = [Wide::ZERO; SLOTS];
    for i in 0..n {
        qi[i] = ltc_map(m, &q[i]);
        ei[i] = ltc_map(m, &e[i]);
        len[i] = length(&qi[i]);
        inv[i] = Wide::ONE / len[i];
    }
    let mut gain = Wide::ZERO;
    let mut clips = Mask::NONE;
    for i in 0..n {
        gain = gain.max(inv[i] * len_l[i]);
        clips = clips.or(qi[i][2].lt(Wide::ZERO));
    }
    let (sum, bound) = if clips.and(live).any() {
        clipped_sum::<N>(&qi[..n], &ei[..n], &len[..n], &inv[..n], live)
    } else {
        let edges = Unclipped::<N> {
            q: &qi[..n],
            e: &ei[..n],
            inv: &inv[..n],
        };
        sum_terms(&edges, live)
    };
    (sum, bound, gain * norm)
}

/// The contour sum of the polygon clipped to z >= 0, lane by lane without
/// branches (the polygon of `polygon::clip_upper_into`): each edge keeps
/// its part above the horizon, and one more edge along the horizon joins
/// the exit crossing to the entry crossing (a convex polygon has at most
/// one of each).
///
/// No division finds a crossing: the edge from `a` to `b` (signs of `z`
/// differ) crosses the horizon in the direction `x = a |b.z| + b |a.z|`
/// (its `z` is exactly 0: the two products are the same number with
/// opposite signs), and since `a x x = |a.z| (a x e)` and
/// `x x b = |b.z| (a x e)` with `e = b - a`, a clipped edge's cross product
/// is the whole edge's, `(a x e).z`, which keeps its precision, times
/// `|a.z|` (leaving) or `|b.z|` (arriving). The contour sum only needs
/// directions, so `x` is never scaled to the crossing point itself.
#[inline(always)]
fn clipped_sum<const N: usize>(
    q: &[Wide3],
    e: &[Wide3],
    len: &[Wide],
    inv_v: &[Wide],
    live: Mask,
) -> (Wide, Wide) {
    let n = slots::<N>(q.len());
    let zero = Wide::ZERO;
    let mut dots = [zero; SLOTS];
    let mut cz = [zero; SLOTS];
    let mut size = [zero; SLOTS];
    let mut exit = [zero; 3];
    let mut entry = [zero; 3];
    let mut crossed = Mask::NONE;
    for i in 0..n {
        let j = if i + 1 == n { 0 } else { i + 1 };
        let (a, b, ev) = (&q[i], &q[j], &e[i]);
        let (ina, inb) = (a[2].ge(zero), b[2].ge(zero));
        let (az, bz) = (a[2].abs(), b[2].abs());
        let x = [
            a[0].mul_add(bz, b[0] * az),
            a[1].mul_add(bz, b[1] * az),
            zero,
        ];
        let ix = Wide::ONE
            / x[0]
                .mul_add(x[0], x[1] * x[1])
                .max(Wide::splat(BatchFloat::MIN_POSITIVE))
                .sqrt();
        let leaving = ina.and_not(inb);
        let arriving = inb.and_not(ina);
        // The share of the edge's cross product kept (one case per lane).
        let k = ina.select(inb.select(Wide::ONE, az), inb.select(bz, zero));
        let i0 = ina.select(inv_v[i], ix);
        let i1 = inb.select(inv_v[j], ix);
        let start = [
            ina.select(a[0], x[0]),
            ina.select(a[1], x[1]),
            ina.select(a[2], zero),
        ];
        let end = [
            inb.select(b[0], x[0]),
            inb.select(b[1], x[1]),
            inb.select(b[2], zero),
        ];
        let w = i0 * i1;
        dots[i] = (dot(&start, &end) * w).clamp(-1.0, 1.0);
        let kw = k * w;
        cz[i] = a[0].mul_add(ev[1], -(a[1] * ev[0])) * kw;
        // Rounding of `(a x e).z` scales with |a| |e|.
        size[i] = (ev[0].abs() + ev[1].abs() + ev[2].abs()) * len[i] * kw;
        for c in 0..2 {
            exit[c] = leaving.select(x[c], exit[c]);
            entry[c] = arriving.select(x[c], entry[c]);
        }
        crossed = crossed.or(leaving);
    }
    let (sum, bound) = sum_terms(&(&dots[..n], &cz[..n], &size[..n]), live);
    // The horizon edge (exit = entry = 0 where nothing crossed: adds 0).
    // Its vector is a difference of two rounded crossings: two more ulps
    // of the edge's own scale in its bound.
    let (ex, en) = (inv_len(&exit), inv_len(&entry));
    let along = [entry[0] - exit[0], entry[1] - exit[1], entry[2] - exit[2]];
    let (d, c, s) = edge_parts(&exit, &entry, &along, ex, en);
    let s = crossed.select(s + Wide::splat(2.0), zero);
    let (hsum, hbound) = sum_terms(&(&[d][..], &[c][..], &[s][..]), live);
    (sum + hsum, bound + hbound)
}

/// `min(|sum| / 2π, 1)`: a contour sum as the form factor of its polygon.
#[inline(always)]
fn form_factor(sum: Wide) -> Wide {
    (sum.abs() * Wide::splat(0.5 / std::f64::consts::PI)).min(Wide::ONE)
}

/// The local polygon clipped to the horizon, `k` (= n + 1) slots per lane,
/// as `polygon::clip_upper_into` makes it: vertices `q`, the vector `e`
/// from each to the next, `real` (false for the slots that pad a lane's
/// polygon: repeats of its first vertex, whose edges add exactly 0), and
/// `slack`, what the crossings add to each lane's rounding bound.
struct Clipped {
    q: [Wide3; SLOTS],
    e: [Wide3; SLOTS],
    real: [Mask; SLOTS],
    slack: Wide,
    /// Slots in use: the light's vertex count plus one.
    k: usize,
}

/// `q`, `e` (`n` vertices) in `k = n + 1` slots: every lane gets its polygon
/// with its first vertex repeated in the last slot, and the lanes of
/// `straddle` get their polygon clipped to z >= 0 (`clip_lane`). Returns the
/// lanes whose clip could not be made (they take the scalar path).
#[inline(always)]
fn clip_lanes(q: &[Wide3], e: &[Wide3], straddle: Mask) -> (Clipped, Mask) {
    let n = q.len();
    let mut c = Clipped {
        q: [[Wide::ZERO; 3]; SLOTS],
        e: [[Wide::ZERO; 3]; SLOTS],
        real: [Mask::from_fn(|_| true); SLOTS],
        slack: Wide::ZERO,
        k: n + 1,
    };
    c.q[..n].copy_from_slice(q);
    c.e[..n].copy_from_slice(e);
    c.q[n] = q[0];
    c.real[n] = Mask::NONE;
    let mut failed = [false; LANES];
    for (l, failed) in failed.iter_mut().enumerate() {
        if straddle.lane(l) {
            *failed = !clip_lane(q, e, l, &mut c);
        }
    }
    (c, Mask::from_fn(|l| failed[l]))
}

/// Lane `l` of `q`, `e` clipped to z >= 0 into the slots of `out`, in
/// `clip_upper_into`'s order and with its crossings (`a + t e`, z set to 0).
/// Each slot's edge vector is, where one is known, an exact edge's (or its
/// share `t e`, `(1 - t) e` of it), so edge terms keep their precision; the
/// edge along the horizon is the difference of its two crossings.
///
/// `slack` bounds what this adds to the error of a contour sum over the
/// polygon. Rounding moves a crossing by a few ulps of `|a| + |e|`, its
/// direction by that over `|x|`, and each of its two edges' terms by at
/// most `1 + theta / sin` (< 4 below 120 degrees) times that; the horizon
/// edge's difference of crossings errs by an ulp of their lengths. False
/// if the polygon has more crossings than a convex one (rounding of a
/// near-degenerate light).
#[inline(never)]
fn clip_lane(q: &[Wide3], e: &[Wide3], l: usize, out: &mut Clipped) -> bool {
    let (n, slots) = (q.len(), out.k);
    let at = |v: &Wide3| DVec3::new(v[0].0[l], v[1].0[l], v[2].0[l]);
    let norm1 = |v: DVec3| v.abs().element_sum();
    let mut pts = [DVec3::ZERO; SLOTS];
    let mut next: [Option<DVec3>; SLOTS] = [None; SLOTS];
    let mut slack = 0.0;
    let mut k = 0;
    for i in 0..n {
        let j = if i + 1 == n { 0 } else { i + 1 };
        let (a, b, ev) = (at(&q[i]), at(&q[j]), at(&e[i]));
        if a.z >= 0.0 {
            if k == slots {
                return false;
            }
            pts[k] = a;
            next[k] = (b.z >= 0.0).then_some(ev);
            k += 1;
        }
        if (a.z > 0.0 && b.z < 0.0) || (a.z < 0.0 && b.z > 0.0) {
            if k == slots {
                return false;
            }
            let den = a.z - b.z;
            let t = a.z / den;
            let mut x = a + ev * t;
            x.z = 0.0;
            if a.z > 0.0 {
                next[k - 1] = Some(ev * t);
            } else {
                next[k] = Some(ev * (-b.z / den));
            }
            slack += 32.0 * BatchFloat::EPSILON * (norm1(a) + norm1(ev))
                / x.length().max(f64::MIN_POSITIVE);
            pts[k] = x;
            k += 1;
        }
    }
    if k < 3 {
        return false;
    }
    for s in 0..slots {
        let (p, ev, real) = if s < k {
            let to = pts[if s + 1 == k { 0 } else { s + 1 }];
            let ev = next[s].unwrap_or_else(|| {
                slack += 4.0 * BatchFloat::EPSILON * (norm1(pts[s]) + norm1(to))
                    / to.length().max(f64::MIN_POSITIVE);
                to - pts[s]
            });
            (pts[s], ev, true)
        } else {
            (pts[0], DVec3::ZERO, false)
        };
        for c in 0..3 {
            out.q[s][c].0[l] = p[c];
            out.e[s][c].0[l] = ev[c];
        }
        out.real[s].0[l] = if real { !0 } else { 0 };
    }
    out.slack.0[l] = slack;
    true
}

#[inline(always)]
fn lobes_n<const N: usize, const K: usize>(
    b: &PixelBatch,
    light: &BatchLight,
    specular: bool,
    out: &mut LaneLobes,
) -> LaneCounts {
    *out = LaneLobes::default();
    let p = &b.p;
    // Side of the light's plane, as the scalar path's `side`.
    let v0 = splat3(light.v[0]);
    let d0 = [p[0] - v0[0], p[1] - v0[1], p[2] - v0[2]];
    let side = dot(&splat3(light.normal), &d0);
    let reach = d0[0].abs() + d0[1].abs() + d0[2].abs();
    let near = side.abs().le(reach * Wide::splat(SIDE_TOL));
    let lit = if light.two_sided {
        side.abs().gt(Wide::ZERO)
    } else {
        side.gt(Wide::ZERO)
    };
    let go = b.active.and(lit.or(near));
    if !go.any() {
        return LaneCounts {
            fast: count(b.active),
            scalar: 0,
        };
    }

    // The light in each lane's local frame: vertices relative to the point,
    // and edges rotated from the light's own (exact) edge vectors.
    let n = slots::<N>(light.n);
    let mut q = [[Wide::ZERO; 3]; SLOTS];
    let mut e = [[Wide::ZERO; 3]; SLOTS];
    let mut min_z = Wide::splat(BatchFloat::INFINITY);
    let mut max_z = Wide::splat(BatchFloat::NEG_INFINITY);
    for i in 0..n {
        let v = splat3(light.v[i]);
        q[i] = rotate(&b.frame, &[v[0] - p[0], v[1] - p[1], v[2] - p[2]]);
        e[i] = rotate(&b.frame, &splat3(light.e[i]));
        min_z = min_z.min(q[i][2]);
        max_z = max_z.max(q[i][2]);
    }
    let under = max_z.le(Wide::ZERO);
    let mut hard = go.and(near);
    let fast = go.and_not(hard).and_not(under);
    let straddle = fast.and(min_z.lt(Wide::ZERO));

    if straddle.any() {
        hard = hard.or(isa::run(ShadeClipped::<N, K> {
            b,
            light,
            specular,
            q: &q[..n],
            e: &e[..n],
            straddle,
            fast,
            out,
        }));
    } else if fast.any() {
        hard = hard.or(shade::<N>(
            b,
            light,
            specular,
            &q[..n],
            &e[..n],
            None,
            fast,
            out,
        ));
    }

    let mut counts = LaneCounts {
        fast: count(b.active.and_not(hard)),
        scalar: 0,
    };
    if hard.any() {
        for l in 0..LANES {
            if hard.lane(l) {
                let (d, s) = unshadowed_lobes_among(&b.sp[l], &light.scalar, b.others.0[l] as f32);
                out.set_lane(l, (d, if specular { s } else { Vec3::ZERO }));
                counts.scalar += 1;
            }
        }
    }
    counts
}

/// `shade` when some lane's light straddles its horizon (`straddle`): the
/// batch integrates every lane's polygon in `n + 1` slots, those
/// lanes' clipped. Kept out of line, as a `Kernel` of its own (`isa`): the
/// common batch, with no clip, runs `shade` inlined in `lobes_n` and is not
/// slowed by this copy of it.
struct ShadeClipped<'a, const N: usize, const K: usize> {
    b: &'a PixelBatch,
    light: &'a BatchLight,
    specular: bool,
    q: &'a [Wide3],
    e: &'a [Wide3],
    straddle: Mask,
    fast: Mask,
    out: &'a mut LaneLobes,
}

impl<const N: usize, const K: usize> Kernel for ShadeClipped<'_, N, K> {
    type Out = Mask;
    #[inline(always)]
    fn run(self) -> Mask {
        let ShadeClipped {
            b,
            light,
            specular,
            q,
            e,
            straddle,
            fast,
            out,
        } = self;
        shade_clipped::<N, K>(b, light, specular, q, e, straddle, fast, out)
    }
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn shade_clipped<const N: usize, const K: usize>(
    b: &PixelBatch,
    light: &BatchLight,
    specular: bool,
    q: &[Wide3],
    e: &[Wide3],
    straddle: Mask,
    fast: Mask,
    out: &mut LaneLobes,
) -> Mask {
    let (c, failed) = clip_lanes(q, e, straddle);
    let fast = fast.and_not(failed);
    let k = slots::<K>(c.k);
    failed.or(shade::<K>(
        b,
        light,
        specular,
        &c.q[..k],
        &c.e[..k],
        Some((&c.real[..k], c.slack)),
        fast,
        out,
    ))
}

/// The lobes of the lanes of `fast` into `out`, from their local polygon
/// (`q`, `e`: above the horizon in those lanes; for a clipped polygon,
/// which slots are real and the slack of each lane's rounding bound, as in
/// `Clipped`). Returns the lanes whose rounding bound exceeds `REL_TOL` (or
/// whose value is not finite): the caller sends them to the scalar path.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn shade<const N: usize>(
    b: &PixelBatch,
    light: &BatchLight,
    specular: bool,
    q: &[Wide3],
    e: &[Wide3],
    clipped: Option<(&[Mask], Wide)>,
    fast: Mask,
    out: &mut LaneLobes,
) -> Mask {
    let eps = Wide::splat(ERR_ULPS * BatchFloat::EPSILON * 0.5 + POLY_ERR_F64);
    let k = slots::<N>(q.len());
    let (sum_l, bnd_l, len_l, u) = lambert_sum::<N>(q, e, fast);
    // A contour sum's error: `eps` of its bound, plus the clip's slack.
    // (Plain code, no closures here: a closure is compiled out of line at
    // baseline, whatever instruction set its caller runs; `isa`.)
    let (real, slack): (Option<&[Mask]>, Wide) = match clipped {
        Some((real, slack)) => (Some(real), slack),
        None => (None, Wide::ZERO),
    };
    let ff = form_factor(sum_l);
    let err_l = eps.mul_add(bnd_l, slack) * Wide::splat(0.5 / std::f64::consts::PI);
    let mut spec = [Wide::ZERO; 3];
    let mut spec_err = [Wide::ZERO; 3];
    let lobe = if specular {
        fast.and(b.lobe)
    } else {
        Mask::NONE
    };
    if lobe.any() {
        let (sum_a, bnd_a, gain_a) = isa::run(LtcSum::<N> {
            m: &b.ma,
            norm: b.norm_a,
            q,
            e,
            len_l: &len_l[..k],
            live: lobe,
        });
        let want_b = lobe.and(b.want_b);
        let (sum_b, bnd_b, gain_b) = if want_b.any() {
            isa::run(LtcSum::<N> {
                m: &b.mb,
                norm: b.norm_b,
                q,
                e,
                len_l: &len_l[..k],
                live: want_b,
            })
        } else {
            (Wide::ZERO, Wide::ZERO, Wide::ZERO)
        };
        let share_a = b.wa.mul_add(form_factor(sum_a), b.mix * ff);
        let share_b = b.wb.mul_add(form_factor(sum_b), b.fmix * ff);
        let one_less = [
            Wide::ONE - b.ks[0],
            Wide::ONE - b.ks[1],
            Wide::ONE - b.ks[2],
        ];
        let stakes = Stakes {
            a: b.lobe.select(b.mag * share_a * mean3(&b.ks), Wide::ZERO),
            b: b.want_b
                .select(b.fres * share_b * mean3(&one_less), Wide::ZERO),
            diffuse: mean3(&b.kd) * ff,
            others: b.others / Wide::splat(BatchFloat::from(luminance(light.radiance)).max(1e-30)),
        };
        let (ka, kb) = lobe_factors_lanes(&u[..k], real, &b.corr, share_a, share_b, &stakes);
        let err_a = eps.mul_add(bnd_a, slack) * gain_a * Wide::splat(0.5 / std::f64::consts::PI);
        let err_b = eps.mul_add(bnd_b, slack) * gain_b * Wide::splat(0.5 / std::f64::consts::PI);
        let a = b.lobe.select(b.mag * share_a * ka, Wide::ZERO);
        let bb = b.want_b.select(b.fres * share_b * kb, Wide::ZERO);
        let a_err = b
            .lobe
            .select(b.mag * ka * b.wa.mul_add(err_a, b.mix * err_l), Wide::ZERO);
        let b_err = b.want_b.select(
            b.fres * kb * b.wb.mul_add(err_b, b.fmix * err_l),
            Wide::ZERO,
        );
        for c in 0..3 {
            let ks = b.ks[c];
            let s = ks.mul_add(a, (Wide::ONE - ks) * bb);
            let s_err = ks.mul_add(a_err, (Wide::ONE - ks) * b_err);
            spec[c] = b.lobe.select(s, Wide::ZERO);
            spec_err[c] = b.lobe.select(s_err, Wide::ZERO);
        }
    }
    // The Lambert lobe to `REL_TOL` of itself (the form factor keeps its
    // accuracy), this light's U to `REL_TOL` of the pixel's whole U (what
    // the lights shaded before it give the pixel included) in every
    // channel: a lobe tiny against the pixel needs no precision of its own.
    let tol = Wide::splat(REL_TOL);
    let mut doubt = err_l.gt(tol * ff);
    let rad = light.radiance.to_array();
    for c in 0..3 {
        let d = b.kd[c] * ff;
        let total = d + spec[c];
        // The other lights' luminance in this light's units for channel
        // `c` (a channel this light does not emit in has nothing to doubt).
        let scale = if rad[c] > 0.0 {
            1.0 / BatchFloat::from(rad[c])
        } else {
            0.0
        };
        let whole = b.others.mul_add(Wide::splat(scale), total);
        doubt = doubt
            .or(b.kd[c].mul_add(err_l, spec_err[c]).gt(tol * whole))
            .or(total.finite().invert());
        let r = Wide::splat(rad[c]);
        out.diffuse[c] = fast.select((d * r).max(Wide::ZERO), Wide::ZERO).to_f32();
        out.specular[c] = fast
            .select((spec[c] * r).max(Wide::ZERO), Wide::ZERO)
            .to_f32();
    }
    fast.and(doubt)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shading::brdf::ShadingBasis;

    #[test]
    fn lane_frames_are_the_scalar_frames_bit_for_bit() {
        let n = |x: f32, y: f32| Vec3::new(x, y, 1.0).normalize();
        // Ordinary views, a view along the normal, one opposite it, one
        // within 1e-6 of it (the fallback's threshold), and a padding lane.
        let cases = [
            (n(0.1, -0.3), Vec3::new(0.5, 0.2, 0.8).normalize()),
            (n(0.7, 0.2), n(0.7, 0.2)),
            (n(-0.2, 0.4), -n(-0.2, 0.4)),
            (Vec3::Z, Vec3::new(1e-7, 0.0, 1.0).normalize()),
            (n(0.0, 0.0), Vec3::new(-0.9, 0.1, 0.05).normalize()),
            (BLANK.n, BLANK.wo),
            (n(0.3, 0.3), Vec3::new(0.0, 1.0, 0.0)),
            (n(-0.6, 0.1), Vec3::new(0.2, -0.1, 0.97).normalize()),
        ];
        for group in cases.chunks(LANES) {
            let v4 = |f: &dyn Fn(usize) -> f32| Vec4::from_array(std::array::from_fn(f));
            let ns = [0, 1, 2].map(|k| v4(&|l| group[l].0[k]));
            let wos = [0, 1, 2].map(|k| v4(&|l| group[l].1[k]));
            let (rows, cos_v) = frames(&ns, &wos);
            for (l, &(n, wo)) in group.iter().enumerate() {
                let want = ShadingBasis::from_normal_view(n, wo);
                let got = rows.map(|r| Vec3::new(r[0][l], r[1][l], r[2][l]));
                assert_eq!(got, [want.x, want.y, want.z], "n {n}, wo {wo}");
                assert_eq!(cos_v[l].to_bits(), n.dot(wo).to_bits(), "n {n}, wo {wo}");
            }
        }
    }
}

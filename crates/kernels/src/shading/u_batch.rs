//! The analytic unshadowed light `U` of `unshadowed` for `LANES` (8) pixels at a
//! time, one pixel per lane (`lanes::Wide`, `f32` elements), branch-free
//! within a batch: the three contour sums (the Lambert form factor and the
//! two LTC lobes), the clipping of the LTC images to their horizon, and the
//! LTC shape correction (`ltc_correction::lobe_factors_lanes`) all run
//! across pixels.
//!
//! Per batch, what does not depend on the light is set up once, across the
//! lanes in `f32`, eight pixels per `Wide` (`PixelBatch::set`, in place,
//! bit for bit the scalar path's values): the shading frame, the LTC cell
//! (the blend of four table cells stays a per-lane gather, transposed into
//! lanes) and the correction's constants (four pixels per `Vec4`). Per light, the vertices are taken into each
//! lane's local frame; each contour sum is a loop over the edges with
//! running sums.
//!
//! Precision. `f32` throughout, judged per pixel against the pixel's
//! whole `U` (`PIXEL_TOL`, `RADIANCE_TOL`), not lobe by lobe: edge terms
//! are computed from a vertex and the light's exact edge vector
//! (`a x b = a x (b - a)`), so each keeps its own precision; theta /
//! sin(theta) is a polynomial in the cosine (no `acos`), and an edge wider
//! than 90 degrees takes its sine from the cross product. Two things `f32`
//! cannot carry go to the scalar path: the LTC map of a sharp lobe seen
//! obliquely (`MAX_CONDITION`, decided once per pixel) and an edge within
//! a few degrees of 180 (`WIDEST_COS`). The table keeps every lobe's mass
//! above the horizon at >= 5 % (`fit_ltc`), so no lobe multiplies its
//! contour sum's rounding by more than about 20.
//!
//! Horizon clips. A light that straddles a lane's horizon is clipped to it
//! in that lane (`clip_lane`, scalar code, the scalar path's
//! Sutherland-Hodgman) into `N + 1` slots, and a batch with such a lane
//! integrates all its lanes' polygons in `N + 1` slots, the unclipped ones
//! with their first vertex repeated (an edge that adds exactly 0: their
//! answers do not change).
//!
//! Which lanes stay here. A lane goes to the scalar path
//! (`unshadowed_lobes_prepared`, whose answer it then has exactly) only
//! when it lies (nearly) in the light's plane, when its LTC map or one of
//! its polygon's edges is too ill-conditioned for `f32` (above), when its
//! clip could not be made (a near-degenerate light), or when its value is
//! not finite. Lanes unlit or entirely under the horizon get exactly 0, as
//! in the scalar path. `tests/integration/ltc/u_batch.rs` checks the
//! result against the scalar path.

use super::brdf::MIN_ALPHA;
use super::lanes::{BatchFloat, Elem, HALF, Lanes, Mask, Vec3Lanes, Wide, Wide3, dot};
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
/// The kernels' per-vertex arrays hold `A` slots alongside: `N` where it is
/// fixed, `SLOTS` where not (arrays of `SLOTS` for a triangle or a quad
/// were stores of unused slots, a call to `memset` each: with the tile
/// loop's lane mask, `U` 2,047 → 1,977 instructions per pixel on `room`).
#[inline(always)]
fn slots<const N: usize>(len: usize) -> usize {
    if N == 0 { len } else { N }
}
use super::unshadowed::{ShadingLight, SurfacePoint, unshadowed_lobes_among};
use glam::{DVec3, Vec3, Vec4};
use penumbra_isa::{self as isa, Kernel};
use penumbra_scene::Light;
use penumbra_scene::color::luminance;

pub use super::lanes::LANES;

/// The batch's stated accuracy against the `f64` scalar path, per pixel
/// and channel: within `PIXEL_TOL` of the pixel's whole `U`, plus
/// `RADIANCE_TOL` of the light's radiance (one light's `U` never exceeds
/// its radiance). `PIXEL_TOL` is twice an EXR half's resolution and a fifth
/// of the LTC fit's own median error (measured worst: 1.2e-3, a rough
/// metal under a large near triangle).
/// The absolute part covers what `f32` cannot resolve of a light a few 1e-4
/// rad across (its contour sum cancels to `eps / size` of itself).
/// `tests/integration/ltc/u_batch.rs` holds the batch to both.
pub const PIXEL_TOL: f32 = 2e-3;
pub const RADIANCE_TOL: f32 = 1e-6;

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
            v[i] = a.to_array();
            // The edge in `f64`, rounded once.
            let d = b.as_dvec3() - a.as_dvec3();
            e[i] = [d.x as BatchFloat, d.y as BatchFloat, d.z as BatchFloat];
        }
        BatchLight {
            n,
            v,
            e,
            normal: light.normal.to_array(),
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
    /// Lanes whose LTC map is too ill-conditioned for `f32` (`ill_conditioned`):
    /// they take the scalar path for every light.
    sharp: Mask,
    /// `M^-1` of lobe A and of lobe B: m00, m02, m20, m22.
    ma: [Wide; 4],
    mb: [Wide; 4],
    /// Each lobe's LTC integral and cosine share: `share = w ltc + mix ff`.
    wa: Wide,
    mix: Wide,
    wb: Wide,
    fmix: Wide,
    mag: Wide,
    fres: Wide,
    /// The correction's constants.
    corr: CorrectionLanes,
    /// What the lights already shaded give each lane (luminance of `U`):
    /// the shape correction is refined only where this light's doubt
    /// matters against the pixel's whole `U` (`set_others`; 0 until set).
    others: Wide,
}

impl PixelBatch {
    /// `points[l]` for each lane `l` that has one (at most `LANES`).
    pub fn new(points: &[Option<SurfacePoint>]) -> PixelBatch {
        let mut batch = PixelBatch::blank();
        batch.set(std::array::from_fn(|l| {
            points.get(l).and_then(Option::as_ref)
        }));
        batch
    }

    /// A batch of padding lanes only: storage for `set`.
    pub fn blank() -> PixelBatch {
        let (view, alpha) = ([Vec4::ZERO, Vec4::ONE], Vec4::ONE);
        let cells = CellLanes::splat(&BLANK_CELL);
        PixelBatch {
            sp: [BLANK; LANES],
            active: Mask::NONE,
            p: [Wide::ZERO; 3],
            frame: [[Wide::ZERO; 3]; 3],
            kd: [Wide::ZERO; 3],
            ks: [Wide::ZERO; 3],
            lobe: Mask::NONE,
            want_b: Mask::NONE,
            sharp: Mask::NONE,
            ma: [Wide::ZERO; 4],
            mb: [Wide::ZERO; 4],
            wa: Wide::ZERO,
            mix: Wide::ZERO,
            wb: Wide::ZERO,
            fmix: Wide::ZERO,
            mag: Wide::ZERO,
            fres: Wide::ZERO,
            corr: CorrectionLanes::new([(&cells, view, alpha), (&cells, view, alpha)]),
            others: Wide::ZERO,
        }
    }

    /// Makes this batch the one of `lanes` (`None`: a padding lane), in
    /// place: the batch is a few kilobytes, and building it in its slot
    /// spares the copies a returned value took.
    ///
    /// Across the lanes in `f32`, eight pixels per `Wide`, with the scalar
    /// path's formulas in its order of operations, so every lane gets its
    /// pixel's frame, cell and constants bit for bit.
    pub fn set(&mut self, lanes: [Option<&SurfacePoint>; LANES]) {
        let mut active = 0;
        for (l, (to, from)) in self.sp.iter_mut().zip(lanes).enumerate() {
            if let Some(from) = from {
                *to = *from;
                active |= 1 << l;
            }
        }
        self.set_active(active);
    }

    /// The lanes' points, for a caller that writes them in place before
    /// `set_active` (one copy from where they come from, none in between).
    pub fn points_mut(&mut self) -> &mut [SurfacePoint; LANES] {
        &mut self.sp
    }

    /// Makes this batch the one of its points (`points_mut`) in the lanes
    /// of `active` (bit `l`: lane `l`); the other lanes are padding,
    /// whatever they held.
    pub fn set_active(&mut self, active: u32) {
        for (l, sp) in self.sp.iter_mut().enumerate() {
            if active & (1 << l) == 0 {
                *sp = BLANK;
            }
        }
        // Two kernels, the blended cells in memory between them: as one,
        // LLVM interleaved the per-lane blends with their transposition and
        // the constants, and spilled most of what it held.
        let mut cells = Cells {
            cells: [[0.0; 16]; LANES],
            cos_v: Wide::ZERO,
            roughness: Wide::ZERO,
        };
        isa::run_at_most_avx2(SetPoints {
            batch: self,
            active: Mask::from_fn(|l| active & (1 << l) != 0),
            cells: &mut cells,
        });
        isa::run_at_most_avx2(SetCells {
            batch: self,
            cells: &cells,
        });
    }

    /// The points' fields, frames and masks, and each lane's LTC cell
    /// (the blank cell in lanes without a specular lobe) into `cells`.
    #[inline(always)]
    fn set_points(&mut self, active: Mask, cells: &mut Cells) {
        let sp = &self.sp;
        let ks = [
            gather(sp, |s| s.specular.x),
            gather(sp, |s| s.specular.y),
            gather(sp, |s| s.specular.z),
        ];
        // `has_specular_lobe` (`Vec3::max_element`, whose compare-select
        // `Wide::max` is) and `min_element() < 1`. Lobe A is wanted wherever
        // there is a lobe (the same test).
        let lobe = active.and(ks[0].max(ks[1]).max(ks[2]).gt(Wide::ZERO));
        let want_b = lobe.and(ks[0].min(ks[1]).min(ks[2]).lt(Wide::ONE));
        self.active = active;
        self.lobe = lobe;
        self.want_b = want_b;
        self.ks = ks;
        let n = [
            gather(sp, |s| s.n.x),
            gather(sp, |s| s.n.y),
            gather(sp, |s| s.n.z),
        ];
        let wo = [
            gather(sp, |s| s.wo.x),
            gather(sp, |s| s.wo.y),
            gather(sp, |s| s.wo.z),
        ];
        let (frame, cos_v) = frames(&n, &wo);
        self.frame = frame;
        let roughness = gather(sp, |s| s.roughness);
        ltc::packed_table().lookup_cells(roughness, cos_v, &mut cells.cells);
        // Lanes without a specular lobe (and padding) get a harmless
        // cell (their lobes are masked off): identity matrices, unit
        // masses, no magnitude; a normal view and alpha 1.
        for (l, cell) in cells.cells.iter_mut().enumerate() {
            if !lobe.lane(l) {
                *cell = BLANK_FIELDS;
            }
        }
        cells.cos_v = cos_v;
        cells.roughness = roughness;
        self.p = [
            gather(sp, |s| s.p.x),
            gather(sp, |s| s.p.y),
            gather(sp, |s| s.p.z),
        ];
        self.kd = [
            gather(sp, |s| s.diffuse.x),
            gather(sp, |s| s.diffuse.y),
            gather(sp, |s| s.diffuse.z),
        ];
        self.others = Wide::ZERO;
    }

    /// The LTC cells of `cells` in lanes, and the correction's constants.
    #[inline(always)]
    fn set_cells(&mut self, cells: &Cells) {
        const { assert!(LANES == 2 * HALF && HALF == 4, "two Vec4 halves") };
        let lobe = self.lobe;
        // Plain loops: `[T; N]::map` and `array::from_fn` are compiled out
        // of line, at baseline whatever level the caller runs (`isa`).
        let mut packed = [[[Vec4::ZERO; 4]; HALF]; 2];
        for (h, half) in packed.iter_mut().enumerate() {
            for (l, cell) in half.iter_mut().enumerate() {
                let c = &cells.cells[HALF * h + l];
                for (k, v) in cell.iter_mut().enumerate() {
                    *v = Vec4::from_slice(&c[4 * k..4 * k + 4]);
                }
            }
        }
        let halves = [
            CellLanes::from_packed(&packed[0]),
            CellLanes::from_packed(&packed[1]),
        ];
        let f = CellLanes::join(&halves[0], &halves[1]);
        // The true view, below the horizon too (the cell is the grazing
        // one there; the correction's exact lobe is not).
        let c = cells.cos_v.clamp(-1.0f32, 1.0f32);
        let view = [
            lobe.select((Wide::ONE - c * c).sqrt(), Wide::ZERO),
            lobe.select(c, Wide::ONE),
        ];
        // `alpha_from_roughness`.
        let r = cells.roughness.clamp(0.0f32, 1.0f32);
        let alpha = lobe.select((r * r).max(Wide::splat(MIN_ALPHA)), Wide::ONE);
        let at = |h: usize| {
            (
                [view[0].vec4_half(h), view[1].vec4_half(h)],
                alpha.vec4_half(h),
            )
        };
        let (a0, a1) = (at(0), at(1));
        self.corr = CorrectionLanes::new([(&halves[0], a0.0, a0.1), (&halves[1], a1.0, a1.1)]);
        let ma = [f[0], f[1], f[2], f[3]];
        let mb = [f[7], f[8], f[9], f[10]];
        self.sharp = lobe
            .and(ill_conditioned(&ma))
            .or(self.want_b.and(ill_conditioned(&mb)));
        self.ma = ma;
        self.mb = mb;
        let (mix, fmix) = (f[6], f[13]);
        self.wa = (Wide::ONE - mix) / f[5];
        self.mix = mix;
        self.wb = (Wide::ONE - fmix) / f[12];
        self.fmix = fmix;
        self.mag = f[4];
        self.fres = f[11];
    }

    /// The luminance of `U` that other lights give each lane, for the next
    /// light's shape correction to weigh its doubt against.
    pub fn set_others(&mut self, others: [f32; LANES]) {
        self.others = Lanes(others);
    }

    /// The shading point of lane `l`, if any.
    pub fn point(&self, l: usize) -> Option<&SurfacePoint> {
        self.active.lane(l).then_some(&self.sp[l])
    }
}

/// Field `f` of every lane's point. A function taking a function pointer,
/// not a closure: a closure is compiled out of line at baseline, whatever
/// instruction set its caller runs (`isa`).
#[inline(always)]
fn gather(sp: &[SurfacePoint; LANES], f: fn(&SurfacePoint) -> f32) -> Wide {
    Lanes(std::array::from_fn(|l| f(&sp[l])))
}

/// Largest condition number of an LTC map `M^-1` that the `f32` lanes
/// take. The map of a sharp lobe (roughness under ~0.15) seen obliquely
/// squeezes the plane of the view by up to 1e4 against its normal: lights
/// become slivers between nearly opposite directions, whose contour sums
/// `f32` cannot resolve (`ltc::image_accuracy`'s metal at 86 degrees,
/// roughness 0.05: p95 6.3 % in `f32` against 0.8 % in `f64`). Every cell
/// of roughness >= 0.19 stays under 150.
pub const MAX_CONDITION: f32 = 1000.0;

/// Lanes whose map `m` (m00, m02, m20, m22; the middle element 1) has a
/// condition number above `MAX_CONDITION`, estimated from above: the 2x2
/// block's singular values lie between `|det| / |m|_F` and `|m|_F`.
#[inline(always)]
fn ill_conditioned(m: &[Wide; 4]) -> Mask {
    let frob = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2] + m[3] * m[3]).sqrt();
    let det = m[0].mul_add(m[3], -(m[1] * m[2])).abs();
    let hi = frob.max(Wide::ONE);
    let lo = (det / frob.max(Wide::splat(f32::MIN_POSITIVE))).min(Wide::ONE);
    hi.gt(Wide::splat(MAX_CONDITION) * lo)
}

/// Each lane's blended LTC cell (`PackedLtc::lookup_cells`), and what
/// the correction's constants take besides, between `PixelBatch::set`'s
/// two kernels.
struct Cells {
    cells: [[f32; 16]; LANES],
    cos_v: Wide,
    roughness: Wide,
}

/// `PixelBatch::set_points` as a `Kernel` (`isa`).
struct SetPoints<'a> {
    batch: &'a mut PixelBatch,
    active: Mask,
    cells: &'a mut Cells,
}

impl Kernel for SetPoints<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        self.batch.set_points(self.active, self.cells)
    }
}

/// `PixelBatch::set_cells` as a `Kernel` (`isa`).
struct SetCells<'a> {
    batch: &'a mut PixelBatch,
    cells: &'a Cells,
}

impl Kernel for SetCells<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        self.batch.set_cells(self.cells)
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

/// `BLANK_CELL` as `PackedLtc::lookup_cells` gives a cell.
const BLANK_FIELDS: [f32; 16] = {
    let c = BLANK_CELL;
    [
        c.m00, c.m02, c.m20, c.m22, c.mag, c.hmass, c.mix, c.f00, c.f02, c.f20, c.f22, c.fres,
        c.fhmass, c.fmix, c.err, 0.0,
    ]
};

/// `ShadingBasis::from_normal_view` of each lane (rows x, y, z as world vectors),
/// and `n . wo` (the scalar path's LTC lookup cosine). Lanes whose view
/// lies along the normal take the scalar fallback, lane by lane.
#[inline(always)]
fn frames(n: &Wide3, wo: &Wide3) -> ([Wide3; 3], Wide) {
    // Products summed left to right, unfused, as glam's `Vec3::dot`.
    let nw = n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2];
    let t = [wo[0] - n[0] * nw, wo[1] - n[1] * nw, wo[2] - n[2] * nw];
    let l2 = t[0] * t[0] + t[1] * t[1] + t[2] * t[2];
    let len = l2.sqrt();
    let mut x = [t[0] / len, t[1] / len, t[2] / len];
    // As the scalar rule: `l2 > 1e-12` or the fallback (NaN included).
    let tangent = l2.gt(Wide::splat(1e-12f32));
    if tangent.invert().any() {
        for l in 0..LANES {
            if !tangent.lane(l) {
                let f = Vec3::new(n[0].0[l], n[1].0[l], n[2].0[l]).any_orthonormal_vector();
                (x[0].0[l], x[1].0[l], x[2].0[l]) = (f.x, f.y, f.z);
            }
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
    isa::run_at_most_avx2(Lobes {
        batch,
        light,
        specular: true,
        out,
    })
}

/// `lobes_batch` without the GGX lobe (its specular lobes are zero), for
/// a light whose GGX share is known to be negligible.
pub fn diffuse_batch(batch: &PixelBatch, light: &BatchLight, out: &mut LaneLobes) -> LaneCounts {
    isa::run_at_most_avx2(Lobes {
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
        3 => lobes_n::<3, 4, 3, 4>(batch, light, specular, out),
        4 => lobes_n::<4, 5, 4, 5>(batch, light, specular, out),
        5..=MAX_LIGHT_VERTICES => lobes_n::<0, 0, SLOTS, SLOTS>(batch, light, specular, out),
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
fn splat3(v: [BatchFloat; 3]) -> Wide3 {
    [Wide::splat(v[0]), Wide::splat(v[1]), Wide::splat(v[2])]
}

/// `d` in the local frame whose rows (world vectors) are `frame`.
#[inline(always)]
fn rotate(frame: &[Wide3; 3], d: &Wide3) -> Wide3 {
    [dot(&frame[0], d), dot(&frame[1], d), dot(&frame[2], d)]
}

/// The LTC image `M^-1 v` (m = m00, m02, m20, m22).
#[inline(always)]
pub(super) fn ltc_map<T: Elem, const L: usize>(
    m: &[Lanes<T, L>; 4],
    v: &Vec3Lanes<T, L>,
) -> Vec3Lanes<T, L> {
    [
        m[0].mul_add(v[0], m[1] * v[2]),
        v[1],
        m[2].mul_add(v[0], m[3] * v[2]),
    ]
}

/// `1 / |v|` per lane, at least the smallest normal number under the root
/// (so that a zero vector stays finite: its edges add 0).
#[inline(always)]
fn inv_len(v: &Wide3) -> Wide {
    Wide::ONE / dot(v, v).max(Wide::splat(BatchFloat::MIN_POSITIVE)).sqrt()
}

/// `polygon::THETA_SIN_POLY` in every lane, as whole vectors, rounded to
/// `f32` (its relative error, 2.1e-9 as a polynomial, is then a few ulps).
static THETA_SIN_WIDE: [Wide; 11] = {
    let p = super::polygon::THETA_SIN_POLY;
    let mut w = [Wide::ZERO; 11];
    let mut i = 0;
    while i < 11 {
        w[i] = Lanes([p[i] as f32; LANES]);
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
/// `pi / sin - theta' / sin`, as `polygon::theta_over_sin` (sin(theta)
/// from the cosine, well conditioned there but for antipodal vertices,
/// whose cross product vanishes with it).
#[inline(always)]
fn theta_over_sin(x: Wide, sin: Wide) -> Wide {
    let p = theta_over_sin_pos(x.abs());
    let s = sin.max(Wide::splat(1e-30));
    let far = Wide::splat(std::f64::consts::PI) / s - p;
    x.ge(Wide::ZERO).select(p, far)
}

/// One edge from `a` (inverse length `ia`) along `e` to `b` (inverse length
/// `ib`): its cosine (clamped) and `z . (a x b) / (|a| |b|)`, the vector
/// form factor's z (computed as `a x (b - a)`: no cancellation between
/// near-equal vertices).
#[inline(always)]
fn edge_parts(a: &Wide3, b: &Wide3, e: &Wide3, ia: Wide, ib: Wide) -> (Wide, Wide) {
    let w = ia * ib;
    let d = (dot(a, b) * w).clamp(-1.0, 1.0);
    let cz = a[0].mul_add(e[1], -(a[1] * e[0])) * w;
    (d, cz)
}

/// A polygon's edges as a contour sum reads them: edge `i` as (cosine,
/// cz) (`edge_parts`). A trait with always-inlined methods rather than a
/// closure: LLVM stopped inlining the closures once the function around
/// them grew, and each call then cost a spill of everything live.
trait Edges {
    fn count(&self) -> usize;
    fn edge(&self, i: usize) -> (Wide, Wide);
    /// The edge's sine, `|a x b| / (|a| |b|)`, for edges wider than 90
    /// degrees: from the cross product, which keeps `eps / sin` of it,
    /// where `sqrt(1 - cos^2)` keeps only `eps / sin^2`.
    fn sin(&self, i: usize) -> Wide;
}

/// `|a x e| w`: the sine of the edge from `a` along `e`, with `w = 1 / (|a| |b|)`.
#[inline(always)]
fn edge_sin(a: &Wide3, e: &Wide3, w: Wide) -> Wide {
    let c = [
        a[1].mul_add(e[2], -(a[2] * e[1])),
        a[2].mul_add(e[0], -(a[0] * e[2])),
        a[0].mul_add(e[1], -(a[1] * e[0])),
    ];
    dot(&c, &c).sqrt() * w
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
    fn edge(&self, i: usize) -> (Wide, Wide) {
        let j = if i + 1 == self.count() { 0 } else { i + 1 };
        edge_parts(&self.q[i], &self.q[j], &self.e[i], self.inv[i], self.inv[j])
    }
    #[inline(always)]
    fn sin(&self, i: usize) -> Wide {
        let j = if i + 1 == self.count() { 0 } else { i + 1 };
        edge_sin(&self.q[i], &self.e[i], self.inv[i] * self.inv[j])
    }
}

/// Edges already made: (cosines, cz, sines).
impl Edges for (&[Wide], &[Wide], &[Wide]) {
    #[inline(always)]
    fn count(&self) -> usize {
        self.0.len()
    }
    #[inline(always)]
    fn edge(&self, i: usize) -> (Wide, Wide) {
        (self.0[i], self.1[i])
    }
    #[inline(always)]
    fn sin(&self, i: usize) -> Wide {
        self.2[i]
    }
}

/// The cosine below which an edge is too wide for `f32`: near 180 degrees
/// theta / sin(theta) grows as `1 / sin`, and `sin` from the cosine of two
/// nearly opposite `f32` directions keeps only `eps / (1 + cos)` of itself
/// (on a light covering most of the hemisphere the Lambert lobe was off by
/// 1.7 %). Edges this wide (> 177.4 degrees) are met only by points within a
/// few percent of a light's size from its edge lines; their lanes take the
/// scalar path.
const WIDEST_COS: BatchFloat = -0.999;

/// `sum theta/sin(theta) (a x b).z` over the edges (the vector form
/// factor's z), each edge's term added as soon as it is made (no arrays of
/// them live at once), and the lanes of `live` with an edge wider than
/// `WIDEST_COS` allows. The `pi / sin` branch of theta/sin is needed only
/// when some lane that counts (`live`) has an edge wider than 90 degrees
/// (rare: very wide polygons); then the edges are made again and summed
/// with it.
#[inline(always)]
fn sum_terms(edges: &impl Edges, live: Mask) -> (Wide, Mask) {
    let mut wide = Mask::NONE;
    let mut sum = Wide::ZERO;
    for i in 0..edges.count() {
        let (d, cz) = edges.edge(i);
        wide = wide.or(d.lt(Wide::ZERO));
        sum = theta_over_sin_pos(d).mul_add(cz, sum);
    }
    let mut widest = Mask::NONE;
    if wide.and(live).any() {
        sum = Wide::ZERO;
        for i in 0..edges.count() {
            let (d, cz) = edges.edge(i);
            widest = widest.or(d.lt(Wide::splat(WIDEST_COS)));
            sum = theta_over_sin(d, edges.sin(i)).mul_add(cz, sum);
        }
    }
    (sum, widest.and(live))
}

/// The Lambert contour sum of the local polygon (`q` vertices, `e` edges;
/// no vertex below the horizon in the lanes that count) and the unit
/// vertices (which feed the shape correction).
#[inline(always)]
fn lambert_sum<const N: usize, const A: usize>(
    q: &[Wide3],
    e: &[Wide3],
    live: Mask,
) -> (Wide, [Wide3; A], Mask) {
    let n = slots::<N>(q.len());
    let mut inv = [Wide::ZERO; A];
    for i in 0..n {
        inv[i] = inv_len(&q[i]);
    }
    let edges = Unclipped::<N> {
        q,
        e,
        inv: &inv[..n],
    };
    let (sum, widest) = sum_terms(&edges, live);
    let mut u = [[Wide::ZERO; 3]; A];
    for i in 0..n {
        u[i] = [q[i][0] * inv[i], q[i][1] * inv[i], q[i][2] * inv[i]];
    }
    (sum, u, widest)
}

/// The mean of three channels.
#[inline(always)]
fn mean3(v: &[Wide; 3]) -> Wide {
    (v[0] + v[1] + v[2]) * Wide::splat(1.0 / 3.0)
}

/// `ltc_sum` as a `Kernel` (`isa`): out of line, at the batch's
/// instruction set.
struct LtcSum<'a, const N: usize, const A: usize> {
    m: &'a [Wide; 4],
    q: &'a [Wide3],
    e: &'a [Wide3],
    live: Mask,
}

impl<const N: usize, const A: usize> Kernel for LtcSum<'_, N, A> {
    type Out = (Wide, Mask);
    #[inline(always)]
    fn run(self) -> (Wide, Mask) {
        ltc_sum::<N, A>(self.m, self.q, self.e, self.live)
    }
}

/// Contour sum of one LTC image (`m` applied to the local polygon), clipped
/// to its horizon where a lane that counts dips below it, and the lanes
/// with an edge too wide for `f32` (`sum_terms`).
#[inline(always)]
fn ltc_sum<const N: usize, const A: usize>(
    m: &[Wide; 4],
    q: &[Wide3],
    e: &[Wide3],
    live: Mask,
) -> (Wide, Mask) {
    let n = slots::<N>(q.len());
    let mut qi = [[Wide::ZERO; 3]; A];
    let mut ei = [[Wide::ZERO; 3]; A];
    let mut inv = [Wide::ZERO; A];
    let mut clips = Mask::NONE;
    for i in 0..n {
        qi[i] = ltc_map(m, &q[i]);
        ei[i] = ltc_map(m, &e[i]);
        inv[i] = inv_len(&qi[i]);
        clips = clips.or(qi[i][2].lt(Wide::ZERO));
    }
    if clips.and(live).any() {
        clipped_sum::<N, A>(&qi[..n], &ei[..n], &inv[..n], live)
    } else {
        let edges = Unclipped::<N> {
            q: &qi[..n],
            e: &ei[..n],
            inv: &inv[..n],
        };
        sum_terms(&edges, live)
    }
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
fn clipped_sum<const N: usize, const A: usize>(
    q: &[Wide3],
    e: &[Wide3],
    inv_v: &[Wide],
    live: Mask,
) -> (Wide, Mask) {
    let n = slots::<N>(q.len());
    let zero = Wide::ZERO;
    let mut dots = [zero; A];
    let mut cz = [zero; A];
    let mut sines = [zero; A];
    let mut exit = [zero; 3];
    let mut entry = [zero; 3];
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
        cz[i] = a[0].mul_add(ev[1], -(a[1] * ev[0])) * (k * w);
        sines[i] = edge_sin(a, ev, k * w);
        for c in 0..2 {
            exit[c] = leaving.select(x[c], exit[c]);
            entry[c] = arriving.select(x[c], entry[c]);
        }
    }
    let (sum, widest) = sum_terms(&(&dots[..n], &cz[..n], &sines[..n]), live);
    // The horizon edge (exit = entry = 0 where nothing crossed: adds 0).
    let (ex, en) = (inv_len(&exit), inv_len(&entry));
    let along = [entry[0] - exit[0], entry[1] - exit[1], entry[2] - exit[2]];
    let (d, cz) = edge_parts(&exit, &entry, &along, ex, en);
    let sin = edge_sin(&exit, &along, ex * en);
    let (horizon, widest_h) = sum_terms(&(&[d][..], &[cz][..], &[sin][..]), live);
    (sum + horizon, widest.or(widest_h))
}

/// `min(|sum| / 2π, 1)`: a contour sum as the form factor of its polygon.
#[inline(always)]
fn form_factor(sum: Wide) -> Wide {
    (sum.abs() * Wide::splat(0.5 / std::f64::consts::PI)).min(Wide::ONE)
}

/// The local polygon clipped to the horizon, `k` (= n + 1) slots per lane,
/// as `polygon::clip_upper_into` makes it: vertices `q`, the vector `e`
/// from each to the next, and `real` (false for the slots that pad a
/// lane's polygon: repeats of its first vertex, whose edges add exactly 0).
struct Clipped {
    q: [Wide3; SLOTS],
    e: [Wide3; SLOTS],
    real: [Mask; SLOTS],
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
/// `clip_upper_into`'s order and with its crossings (`a + t e`, z set to 0),
/// in `f64`. Each slot's edge vector is, where one is known, an exact
/// edge's (or its share `t e`, `(1 - t) e` of it), so edge terms keep their
/// precision; the edge along the horizon is the difference of its two
/// crossings. False if the polygon has more crossings than a convex one
/// (rounding of a near-degenerate light).
#[inline(never)]
fn clip_lane(q: &[Wide3], e: &[Wide3], l: usize, out: &mut Clipped) -> bool {
    let (n, slots) = (q.len(), out.k);
    let at = |v: &Wide3| DVec3::new(v[0].0[l].into(), v[1].0[l].into(), v[2].0[l].into());
    let mut pts = [DVec3::ZERO; SLOTS];
    let mut next: [Option<DVec3>; SLOTS] = [None; SLOTS];
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
            (pts[s], next[s].unwrap_or(to - pts[s]), true)
        } else {
            (pts[0], DVec3::ZERO, false)
        };
        for c in 0..3 {
            out.q[s][c].0[l] = p[c] as BatchFloat;
            out.e[s][c].0[l] = ev[c] as BatchFloat;
        }
        out.real[s].0[l] = if real { !0 } else { 0 };
    }
    true
}

#[inline(always)]
fn lobes_n<const N: usize, const K: usize, const NA: usize, const KA: usize>(
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
    let mut q = [[Wide::ZERO; 3]; NA];
    let mut e = [[Wide::ZERO; 3]; NA];
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
    // An ill-conditioned LTC map matters only where the GGX lobe is wanted.
    let sharp = if specular { b.sharp } else { Mask::NONE };
    let mut hard = go.and(near.or(sharp));
    let fast = go.and_not(hard).and_not(under);
    let straddle = fast.and(min_z.lt(Wide::ZERO));

    if straddle.any() {
        hard = hard.or(isa::run_at_most_avx2(ShadeClipped::<N, K, KA> {
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
        hard = hard.or(shade::<N, NA>(
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
                let (d, s) = unshadowed_lobes_among(&b.sp[l], &light.scalar, b.others.0[l]);
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
struct ShadeClipped<'a, const N: usize, const K: usize, const KA: usize> {
    b: &'a PixelBatch,
    light: &'a BatchLight,
    specular: bool,
    q: &'a [Wide3],
    e: &'a [Wide3],
    straddle: Mask,
    fast: Mask,
    out: &'a mut LaneLobes,
}

impl<const N: usize, const K: usize, const KA: usize> Kernel for ShadeClipped<'_, N, K, KA> {
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
        shade_clipped::<N, K, KA>(b, light, specular, q, e, straddle, fast, out)
    }
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn shade_clipped<const N: usize, const K: usize, const KA: usize>(
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
    failed.or(shade::<K, KA>(
        b,
        light,
        specular,
        &c.q[..k],
        &c.e[..k],
        Some(&c.real[..k]),
        fast,
        out,
    ))
}

/// The lobes of the lanes of `fast` into `out`, from their local polygon
/// (`q`, `e`: above the horizon in those lanes; for a clipped polygon,
/// which slots are real, as in `Clipped`). Returns the lanes whose value
/// is not finite or whose polygon has an edge too wide for `f32`
/// (`WIDEST_COS`): the caller sends them to the scalar path.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn shade<const N: usize, const A: usize>(
    b: &PixelBatch,
    light: &BatchLight,
    specular: bool,
    q: &[Wide3],
    e: &[Wide3],
    real: Option<&[Mask]>,
    fast: Mask,
    out: &mut LaneLobes,
) -> Mask {
    let k = slots::<N>(q.len());
    let (sum_l, u, mut widest) = lambert_sum::<N, A>(q, e, fast);
    // (Plain code, no closures here: a closure is compiled out of line at
    // baseline, whatever instruction set its caller runs; `isa`.)
    let ff = form_factor(sum_l);
    let mut spec = [Wide::ZERO; 3];
    let lobe = if specular {
        fast.and(b.lobe)
    } else {
        Mask::NONE
    };
    if lobe.any() {
        let (sum_a, widest_a) = isa::run_at_most_avx2(LtcSum::<N, A> {
            m: &b.ma,
            q,
            e,
            live: lobe,
        });
        let want_b = lobe.and(b.want_b);
        let (sum_b, widest_b) = if want_b.any() {
            isa::run_at_most_avx2(LtcSum::<N, A> {
                m: &b.mb,
                q,
                e,
                live: want_b,
            })
        } else {
            (Wide::ZERO, Mask::NONE)
        };
        widest = widest.or(widest_a).or(widest_b);
        let share_a = b.wa.mul_add(form_factor(sum_a), b.mix * ff);
        let share_b = b.wb.mul_add(form_factor(sum_b), b.fmix * ff);
        let one_less = [
            Wide::ONE - b.ks[0],
            Wide::ONE - b.ks[1],
            Wide::ONE - b.ks[2],
        ];
        let stakes = [
            b.lobe.select(b.mag * share_a * mean3(&b.ks), Wide::ZERO),
            b.want_b
                .select(b.fres * share_b * mean3(&one_less), Wide::ZERO),
            mean3(&b.kd) * ff,
            // What the lights shaded before this one give each pixel, in
            // this light's units (its radiance's luminance divided out).
            b.others / Wide::splat(luminance(light.radiance).max(1e-30)),
        ];
        let (ka, kb) = correction(&u[..k], real, b, [share_a, share_b], &stakes, lobe);
        let a = b.lobe.select(b.mag * share_a * ka, Wide::ZERO);
        let bb = b.want_b.select(b.fres * share_b * kb, Wide::ZERO);
        for (s, &ks) in spec.iter_mut().zip(&b.ks) {
            *s = b
                .lobe
                .select(ks.mul_add(a, (Wide::ONE - ks) * bb), Wide::ZERO);
        }
    }
    let mut bad = widest;
    let rad = light.radiance.to_array();
    for c in 0..3 {
        let d = b.kd[c] * ff;
        bad = bad.or((d + spec[c]).finite().invert());
        let r = Wide::splat(rad[c]);
        out.diffuse[c] = fast.select((d * r).max(Wide::ZERO), Wide::ZERO).to_f32();
        out.specular[c] = fast
            .select((spec[c] * r).max(Wide::ZERO), Wide::ZERO)
            .to_f32();
    }
    fast.and(bad)
}

/// The shape correction's factors `(A, B)` of every lane
/// (`lobe_factors_lanes`, all eight lanes at once); `u`, `real`: the unit
/// polygon and its real slots as `shade` has them; `stakes`: lobe A, lobe
/// B, the diffuse part and the other lights (`Stakes`). Lanes outside
/// `lobe` (their factors are not used) weigh nothing, so they never ask
/// for a finer cubature.
#[inline(always)]
fn correction(
    u: &[Wide3],
    real: Option<&[Mask]>,
    b: &PixelBatch,
    [share_a, share_b]: [Wide; 2],
    stakes: &[Wide; 4],
    lobe: Mask,
) -> (Wide, Wide) {
    let st = Stakes {
        a: lobe.select(stakes[0], Wide::ZERO),
        b: lobe.select(stakes[1], Wide::ZERO),
        diffuse: stakes[2],
        others: stakes[3],
    };
    lobe_factors_lanes(u, real, &b.corr, share_a, share_b, &st)
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
        let ns = [0, 1, 2].map(|k| Wide::from_fn(|l| cases[l].0[k]));
        let wos = [0, 1, 2].map(|k| Wide::from_fn(|l| cases[l].1[k]));
        let (rows, cos_v) = frames(&ns, &wos);
        for (l, &(n, wo)) in cases.iter().enumerate() {
            let want = ShadingBasis::from_normal_view(n, wo);
            let got = rows.map(|r| Vec3::new(r[0].0[l], r[1].0[l], r[2].0[l]));
            assert_eq!(got, [want.x, want.y, want.z], "n {n}, wo {wo}");
            assert_eq!(cos_v.0[l].to_bits(), n.dot(wo).to_bits(), "n {n}, wo {wo}");
        }
    }
}

//! The project's own LTC fit for exactly the BRDF in `brdf` (GGX, Smith
//! height-correlated G2, Schlick Fresnel split into two lobes, see `ltc`).
//!
//! Per cell (roughness, cos θv), with the view `V = (sin θv, 0, cos θv)`, and
//! for each lobe (`A = f_spec(F=1) cos`, `B = A (1 - V.h)^5`):
//! 1. 256² stratified VNDF samples (shared by both lobes) give the lobe's
//!    integral (`mag` or `fres`), its mean direction (angle `phi`) and
//!    reference integrals of the lobe over a set of test polygons (below).
//! 2. `M = R(phi + dphi) * [[m11, 0, m13], [0, m22, 0], [0, 0, 1]]` (R rotates
//!    +Z about +Y to the mean direction, plus a fitted correction `dphi`),
//!    mixed with weight `mix` in [0, 1] with the clamped cosine about the
//!    normal (see `ltc`); `(m11, m22, m13, dphi, mix)` minimise the squared
//!    relative error of the model's integrals over the test polygons, the
//!    LTC part computed exactly as the renderer computes U (clip to the
//!    horizon, transform by `M^-1`, clip again, edge integrals, times
//!    `mag / hmass`).
//!    The objective is aimed at what U uses, polygon integrals, instead of a
//!    pointwise norm of `lobe - LTC`: the previous L3 pointwise fit reached a
//!    median relative error of 2.1% on polygon lights (F0 = 1, roughness >=
//!    0.2, tests/ltc_accuracy.rs), because a pointwise norm spends the fit on
//!    the peak and lets the integral over any finite light drift.
//!    With the two lobes and this objective that median is 1.17% for
//!    F0 = 1 and 1.45% for the worst of F0 = 1, 0.5, 0.04 (1% not reached).
//! 3. Test polygons: squares on the plane tangent to the unit sphere at the
//!    mean direction (gnomonic projection, so each is a spherical polygon
//!    with great-circle edges, like a light), in two grids sized to the lobe:
//!    8x8 over +-2 r50 and 4x4 over +-6 r50 (r50: the half-width of the
//!    square holding half the lobe), each with its 2x2 / 4x4 / whole-grid
//!    unions (106 polygons from a near-pinpoint light to half the
//!    hemisphere); plus the upper half of a cube cut into squares (57,
//!    `add_cube`), so that no mass can move where the lobe has none: 163.
//!    Relative error is taken against `R + 1% of the lobe`, so polygons that
//!    hold almost nothing count as absolute error.
//! 4. Nelder-Mead (our own, `nelder_mead`), started from the better of the
//!    fits of the two neighbouring cells (one step less rough, one step less
//!    grazing; see `fit_cell`). At normal incidence the lobe is isotropic, so
//!    the first cell of each roughness fits `m11 = m22` and `mix` only, from
//!    `alpha`. Anti-diagonals of the table run in parallel over rayon and the
//!    result is deterministic (fixed stratified sample sets, no random
//!    numbers, each cell's seeds fixed).
//!
//! Regenerate the committed table with `make fit-ltc`, i.e.
//! `penumbra fit-ltc --size 64 --out data/ltc_64.bin --heatmap docs/ltc-fit-error.png`.
//! The per-cell `err` (and the heat map) is the RMS relative error over the
//! test polygons holding >= 1% of the lobe, the larger of the two lobes.

use crate::nelder_mead;
use crate::shading::brdf;
use crate::shading::ltc::{LtcCell, LtcTable};
use crate::shading::polygon::{Polygon, cosine_integral};
use glam::{DMat3, DVec3, Vec3};
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Stratified VNDF samples per axis for the reference integrals.
const K_REF: usize = 256;
/// The last row is cos θv = 0, where the view is exactly grazing; fit it at
/// this cosine instead (the lobe has a finite limit there).
pub const FIT_MIN_COS_VIEW: f32 = 1e-3;
/// Test polygons with less of the lobe than this share weigh as absolute
/// error (relative to this share of the lobe).
const SHARE_FLOOR: f64 = 0.01;
/// Nelder-Mead budgets (evaluations) and relative tolerance.
const EVALS_ISO: usize = 200;
/// The least share of a fitted distribution above the horizon (`hmass`).
/// U divides each lobe's polygon integral by it, so a cell whose fit hides
/// most of its cosine below the horizon multiplies the rounding of that
/// integral by `1 / hmass`: unconstrained, 172 cells of the Schlick lobe
/// and 4 of the F0 lobe fell below 1e-3, many to 1e-6 (a factor of 1e6). The floor keeps the factor <= 20, so the
/// integral can be summed in `f32`; the fit pays for it only where the lobe
/// carries almost nothing (near-normal views, where `(1 - wo.h)^5` ~ 0).
pub const HMASS_FLOOR: f64 = 0.05;
/// How steeply the objective rises below the floor (per squared relative
/// shortfall): far above any fit error, so the minimiser stays above it.
const HMASS_PENALTY: f64 = 1e3;
const EVALS_ANISO: usize = 600;
const FTOL: f64 = 1e-7;

/// A linearly transformed cosine.
#[derive(Clone, Copy, Debug)]
pub struct Ltc {
    pub m: DMat3,
    pub minv: DMat3,
    /// Mass of the untruncated distribution above the horizon.
    pub hmass: f64,
}

impl Ltc {
    pub fn new(m11: f64, m22: f64, m13: f64, phi: f64) -> Ltc {
        let (s, c) = phi.sin_cos();
        let r = DMat3::from_cols(DVec3::new(c, 0.0, -s), DVec3::Y, DVec3::new(s, 0.0, c));
        let sh = DMat3::from_cols(
            DVec3::new(m11.abs().max(1e-7), 0.0, 0.0),
            DVec3::new(0.0, m22.abs().max(1e-7), 0.0),
            DVec3::new(m13, 0.0, 1.0),
        );
        let m = r * sh;
        let minv = m.inverse();
        // w = M w' is above the horizon iff (row 2 of M) . w' >= 0; the
        // clamped cosine's mass on the half-space {w' . a >= 0} is (1 + a_z)/2.
        let row2 = DVec3::new(m.x_axis.z, m.y_axis.z, m.z_axis.z).normalize();
        Ltc {
            m,
            minv,
            hmass: (0.5 * (1.0 + row2.z)).max(1e-6),
        }
    }

    /// `∫_P D` over the upper-hemisphere part of a polygon, renormalised by
    /// `hmass`: what the renderer multiplies by the lobe's magnitude.
    pub fn polygon_integral(&self, poly: &Polygon) -> f64 {
        let lp = poly.clip_upper().transformed(&self.minv).clip_upper();
        cosine_integral(&lp) / self.hmass
    }
}

/// One VNDF sample of the view: its direction and the two lobes' integrands
/// over the sampling density.
#[derive(Clone, Copy)]
struct Sample {
    w: DVec3,
    a: f64,
    b: f64,
}

/// Which of the two specular lobes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Part {
    /// `f_spec(F=1) cos`, weighted by F0.
    F0,
    /// `f_spec(F=1) cos (1 - V.h)^5`, weighted by `1 - F0`.
    Schlick,
}

fn view_samples(alpha: f32, cos_view: f32) -> Vec<Sample> {
    let c = cos_view.clamp(FIT_MIN_COS_VIEW, 1.0);
    let view = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
    let mut out = Vec::with_capacity(K_REF * K_REF);
    for_grid(K_REF, |u1, u2| {
        let h = brdf::sample_vndf(alpha, view, u1 as f32, u2 as f32);
        let w = brdf::reflect(view, h);
        if w.z <= 0.0 {
            return;
        }
        let (f1, cos_oh) = brdf::spec_local(alpha, w, view);
        let pdf = brdf::vndf_pdf(alpha, w, view);
        if pdf > 0.0 && f1 > 0.0 {
            let a = (f1 * w.z / pdf) as f64;
            out.push(Sample {
                w: w.as_dvec3().normalize(),
                a,
                b: a * brdf::schlick_weight(cos_oh) as f64,
            });
        }
    });
    out
}

/// One lobe at a fixed view: its integral, mean direction and reference
/// integrals over the test polygons.
struct Lobe {
    mag: f64,
    phi: f64,
    polys: Vec<Polygon>,
    reference: Vec<f64>,
    /// Each polygon's form factor: the integral of the cosine part.
    cosine: Vec<f64>,
}

impl Lobe {
    fn new(samples: &[Sample], part: Part) -> Lobe {
        let n = (K_REF * K_REF) as f64;
        let weight = |s: &Sample| if part == Part::F0 { s.a } else { s.b };
        let (mut mag, mut mean) = (0.0, DVec3::ZERO);
        for s in samples {
            mag += weight(s);
            mean += weight(s) * s.w;
        }
        let phi = mean.x.atan2(mean.z);
        let d = DVec3::new(phi.sin(), 0.0, phi.cos());
        let t1 = DVec3::new(phi.cos(), 0.0, -phi.sin());
        let t2 = DVec3::Y;
        // Gnomonic coordinates of each sample around the mean direction.
        let proj: Vec<(f64, f64, f64)> = samples
            .iter()
            .filter_map(|s| {
                let z = s.w.dot(d);
                (z > 0.0).then(|| (s.w.dot(t1) / z, s.w.dot(t2) / z, weight(s)))
            })
            .collect();
        let r50 = half_mass_radius(&proj, mag).clamp(1e-5, 0.6);
        let mut lobe = Lobe {
            mag: mag / n,
            phi,
            polys: Vec::new(),
            reference: Vec::new(),
            cosine: Vec::new(),
        };
        for (extent, g) in [(2.0 * r50, 8), (6.0 * r50, 4)] {
            lobe.add_grid(&proj, n, [d, t1, t2], extent, g);
        }
        let dirs: Vec<(DVec3, f64)> = samples.iter().map(|s| (s.w, weight(s))).collect();
        lobe.add_cube(&dirs, n);
        lobe
    }

    /// The upper half of a cube around the point, its faces cut into
    /// squares (top: 4x4 and 2x2 and whole; each side: 4 x 2 and whole):
    /// polygons over the whole hemisphere, so the fit cannot move mass to
    /// where the lobe has none (e.g. overhead at grazing views).
    fn add_cube(&mut self, dirs: &[(DVec3, f64)], n: f64) {
        const G: usize = 4;
        // Face 0 = top (u, v) = (x, y) / z in [-1, 1]^2; faces 1..=4 = sides
        // +x, -x, +y, -y with (u, v) = (the other horizontal, z) / |axis| in
        // [-1, 1] x [0, 1].
        let mut fine = [[0.0; G * G]; 5];
        for &(w, wgt) in dirs {
            let (ax, ay) = (w.x.abs(), w.y.abs());
            let (face, u, v) = if w.z >= ax && w.z >= ay {
                (0, w.x / w.z, w.y / w.z)
            } else if ax >= ay {
                (if w.x > 0.0 { 1 } else { 2 }, w.y / ax, w.z / ax)
            } else {
                (if w.y > 0.0 { 3 } else { 4 }, w.x / ay, w.z / ay)
            };
            let rows = if face == 0 { G } else { G / 2 };
            let v0 = if face == 0 { (v + 1.0) / 2.0 } else { v };
            let i = (((u + 1.0) / 2.0 * G as f64) as usize).min(G - 1);
            let j = ((v0 * rows as f64) as usize).min(rows - 1);
            fine[face][j * G + i] += wgt;
        }
        let corner = |face: usize, u: f64, v: f64| match face {
            0 => DVec3::new(u, v, 1.0),
            1 => DVec3::new(1.0, u, v),
            2 => DVec3::new(-1.0, u, v),
            3 => DVec3::new(u, 1.0, v),
            _ => DVec3::new(u, -1.0, v),
        };
        for (face, bins) in fine.iter().enumerate() {
            let rows = if face == 0 { G } else { G / 2 };
            let (v_lo, v_span) = if face == 0 { (-1.0, 2.0) } else { (0.0, 1.0) };
            let mut size = 1;
            while size <= G {
                for bj in (0..rows).step_by(size.min(rows)) {
                    for bi in (0..G).step_by(size) {
                        let bh = size.min(rows);
                        let mut sum = 0.0;
                        for j in bj..bj + bh {
                            for i in bi..bi + size {
                                sum += bins[j * G + i];
                            }
                        }
                        let u0 = -1.0 + 2.0 * bi as f64 / G as f64;
                        let u1 = u0 + 2.0 * size as f64 / G as f64;
                        let v0 = v_lo + v_span * bj as f64 / rows as f64;
                        let v1 = v0 + v_span * bh as f64 / rows as f64;
                        let poly = Polygon::from_points(&[
                            corner(face, u0, v0),
                            corner(face, u1, v0),
                            corner(face, u1, v1),
                            corner(face, u0, v1),
                        ]);
                        self.cosine.push(cosine_integral(&poly.clip_upper()));
                        self.polys.push(poly);
                        self.reference.push(sum / n);
                    }
                }
                // Sides: the 4 x 2 cells, then the whole face.
                size = if face == 0 {
                    size * 2
                } else if size == 1 {
                    G
                } else {
                    2 * G
                };
            }
        }
    }

    /// Squares of a `g x g` grid over `[-e, e]^2` on the tangent plane, and
    /// their 2x2, 4x4, ... unions, with their reference integrals.
    fn add_grid(&mut self, proj: &[(f64, f64, f64)], n: f64, axes: [DVec3; 3], e: f64, g: usize) {
        let mut fine = vec![0.0; g * g];
        let cell = 2.0 * e / g as f64;
        for &(a, b, wgt) in proj {
            let (i, j) = (((a + e) / cell).floor(), ((b + e) / cell).floor());
            if i >= 0.0 && j >= 0.0 && i < g as f64 && j < g as f64 {
                fine[j as usize * g + i as usize] += wgt;
            }
        }
        let [d, t1, t2] = axes;
        let mut size = 1;
        while size <= g {
            for bj in (0..g).step_by(size) {
                for bi in (0..g).step_by(size) {
                    let mut sum = 0.0;
                    for j in bj..bj + size {
                        for i in bi..bi + size {
                            sum += fine[j * g + i];
                        }
                    }
                    let (a0, b0) = (-e + bi as f64 * cell, -e + bj as f64 * cell);
                    let (a1, b1) = (a0 + size as f64 * cell, b0 + size as f64 * cell);
                    let at = |a: f64, b: f64| d + a * t1 + b * t2;
                    let poly =
                        Polygon::from_points(&[at(a0, b0), at(a1, b0), at(a1, b1), at(a0, b1)]);
                    self.cosine.push(cosine_integral(&poly.clip_upper()));
                    self.polys.push(poly);
                    self.reference.push(sum / n);
                }
            }
            size *= 2;
        }
    }

    /// The model's integral over test polygon `k`.
    #[inline]
    fn model(&self, ltc: &Ltc, mix: f64, k: usize) -> f64 {
        self.mag * ((1.0 - mix) * ltc.polygon_integral(&self.polys[k]) + mix * self.cosine[k])
    }

    /// The fit objective: mean squared relative error, each against
    /// `reference + SHARE_FLOOR * mag`.
    fn objective(&self, ltc: &Ltc, mix: f64) -> f64 {
        let short = ((HMASS_FLOOR - ltc.hmass) / HMASS_FLOOR).max(0.0);
        let mut sum = HMASS_PENALTY * short * short * self.polys.len() as f64;
        for (k, &r) in self.reference.iter().enumerate() {
            let den = (r + SHARE_FLOOR * self.mag).max(1e-300);
            let e = (self.model(ltc, mix, k) - r) / den;
            sum += e * e;
        }
        sum / self.polys.len() as f64
    }

    /// RMS relative error over the polygons holding >= 1% of the lobe.
    fn report(&self, ltc: &Ltc, mix: f64) -> f64 {
        let (mut sum, mut count) = (0.0, 0usize);
        for (k, &r) in self.reference.iter().enumerate() {
            if r >= SHARE_FLOOR * self.mag && r > 0.0 {
                let e = (self.model(ltc, mix, k) - r) / r;
                sum += e * e;
                count += 1;
            }
        }
        if count == 0 {
            0.0
        } else {
            (sum / count as f64).sqrt()
        }
    }
}

/// Half-width of the (gnomonic) square around the mean direction that holds
/// half of `total`, from a log-spaced histogram of `max(|a|, |b|)`.
fn half_mass_radius(proj: &[(f64, f64, f64)], total: f64) -> f64 {
    const BINS: usize = 96;
    const LO: f64 = 1e-6;
    const DECADES: f64 = 8.0;
    let mut hist = [0.0; BINS];
    for &(a, b, w) in proj {
        let r = a.abs().max(b.abs()).max(LO);
        let k = ((r / LO).log10() / DECADES * BINS as f64) as usize;
        hist[k.min(BINS - 1)] += w;
    }
    let mut acc = 0.0;
    for (k, h) in hist.iter().enumerate() {
        acc += h;
        if acc >= 0.5 * total {
            return LO * 10f64.powf((k + 1) as f64 / BINS as f64 * DECADES);
        }
    }
    1.0
}

/// Calls `f` on the midpoints of a k x k grid over [0,1)^2.
fn for_grid(k: usize, mut f: impl FnMut(f64, f64)) {
    for j in 0..k {
        for i in 0..k {
            f((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
        }
    }
}

/// The cosine weight from its free parameter: clamped to [0, 1], so the
/// model stays a mixture of two distributions (never negative).
fn mix_of(p: f64) -> f64 {
    p.clamp(0.0, 1.0)
}

/// Fits one lobe, starting from the best of `seeds` (parameters of
/// neighbouring cells); no seeds means normal incidence (isotropic fit).
/// Returns the LTC, the cosine weight and the parameters
/// `(m11, m22, m13, dphi, mix)`.
fn fit_lobe(lobe: &Lobe, alpha: f32, seeds: &[[f64; 5]]) -> (Ltc, f64, [f64; 5]) {
    let phi = lobe.phi;
    let err5 = |p: [f64; 5]| lobe.objective(&Ltc::new(p[0], p[1], p[2], phi + p[3]), mix_of(p[4]));
    let best = seeds
        .iter()
        .map(|s| (err5(*s), *s))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, s)| s);
    let params = match best {
        None => {
            let a = alpha as f64;
            let (p, _) = nelder_mead::minimize(
                |p: &[f64; 2]| err5([p[0], p[0], 0.0, 0.0, p[1]]),
                [a, 0.0],
                [0.3 * a, 0.1],
                FTOL,
                EVALS_ISO,
            );
            [p[0].abs(), p[0].abs(), 0.0, 0.0, mix_of(p[1])]
        }
        Some(s) => {
            let scale = s[0].abs().max(s[1].abs()).max(1e-6);
            let step = [
                0.1 * s[0].abs().max(0.1 * scale),
                0.1 * s[1].abs().max(0.1 * scale),
                0.1 * scale,
                0.02,
                0.05,
            ];
            let (p, _) = nelder_mead::minimize(|p: &[f64; 5]| err5(*p), s, step, FTOL, EVALS_ANISO);
            [p[0].abs(), p[1].abs(), p[2], p[3], mix_of(p[4])]
        }
    };
    (
        Ltc::new(params[0], params[1], params[2], phi + params[3]),
        params[4],
        params,
    )
}

/// `M^-1` normalised by its middle element: `(m00, m02, m20, m22)`.
fn normalised_inverse(ltc: &Ltc) -> [f32; 4] {
    let mi = ltc.minv;
    let c = mi.y_axis.y;
    [
        (mi.x_axis.x / c) as f32,
        (mi.z_axis.x / c) as f32,
        (mi.x_axis.z / c) as f32,
        (mi.z_axis.z / c) as f32,
    ]
}

/// Fits one cell (both lobes). `seeds` holds the fitted parameters (per
/// lobe) of the neighbouring cells already done (one step less rough, one
/// step less grazing); none at normal incidence. The Schlick lobe may also
/// start from this cell's F0 lobe: at grazing views the two are alike, and
/// a chain of Schlick fits alone can stay stuck in the wide, ring-shaped
/// optimum of near-normal views.
fn fit_cell(roughness: f32, cos_view: f32, seeds: &[[[f64; 5]; 2]]) -> (LtcCell, [[f64; 5]; 2]) {
    let alpha = brdf::alpha_from_roughness(roughness);
    let samples = view_samples(alpha, cos_view);
    let la = Lobe::new(&samples, Part::F0);
    let lb = Lobe::new(&samples, Part::Schlick);
    let seeds_a: Vec<[f64; 5]> = seeds.iter().map(|s| s[0]).collect();
    let (a, mix_a, pa) = fit_lobe(&la, alpha, &seeds_a);
    let mut seeds_b: Vec<[f64; 5]> = seeds.iter().map(|s| s[1]).collect();
    if !seeds_b.is_empty() {
        seeds_b.push(pa);
    }
    let (b, mix_b, pb) = fit_lobe(&lb, alpha, &seeds_b);
    let [m00, m02, m20, m22] = normalised_inverse(&a);
    let [f00, f02, f20, f22] = normalised_inverse(&b);
    let cell = LtcCell {
        m00,
        m02,
        m20,
        m22,
        mag: la.mag as f32,
        hmass: a.hmass as f32,
        mix: mix_a as f32,
        f00,
        f02,
        f20,
        f22,
        fres: lb.mag as f32,
        fhmass: b.hmass as f32,
        fmix: mix_b as f32,
        err: la.report(&a, mix_a).max(lb.report(&b, mix_b)) as f32,
    };
    (cell, [pa, pb])
}

/// Fits a `size x size` table (see the module comment). `progress(done, total)`
/// is called after each cell, from worker threads.
pub fn fit_table(size: usize, progress: &(dyn Fn(usize, usize) + Sync)) -> LtcTable {
    assert!(size >= 2, "an LTC table needs at least 2x2 cells");
    let total = size * size;
    let done = AtomicUsize::new(0);
    let mut cells = vec![LtcCell::default(); total];
    let mut params = vec![[[0.0; 5]; 2]; total];
    // Cell (i, j) starts from (i - 1, j) and (i, j - 1): anti-diagonals are
    // independent, so each runs in parallel, and neighbouring cells in both
    // directions come from the same basin (they are interpolated between).
    for diag in 0..2 * size - 1 {
        let lo = diag.saturating_sub(size - 1);
        let hi = diag.min(size - 1);
        let fitted: Vec<(usize, LtcCell, [[f64; 5]; 2])> = (lo..=hi)
            .into_par_iter()
            .map(|i| {
                let j = diag - i;
                let mut seeds = Vec::new();
                if j > 0 {
                    seeds.push(params[(j - 1) * size + i]);
                    if i > 0 {
                        seeds.push(params[j * size + i - 1]);
                    }
                }
                let roughness = LtcTable::roughness_at(size, i);
                let (cell, p) = fit_cell(roughness, LtcTable::cos_view_at(size, j), &seeds);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
                (j * size + i, cell, p)
            })
            .collect();
        for (k, cell, p) in fitted {
            cells[k] = cell;
            params[k] = p;
        }
    }
    LtcTable { size, cells }
}

/// Summary of the per-cell errors: (median, p90, max, worst cell
/// as (roughness, θv in degrees)).
pub fn error_summary(table: &LtcTable) -> (f32, f32, f32, (f32, f32)) {
    let mut e: Vec<f32> = table.cells.iter().map(|c| c.err).collect();
    e.sort_by(f32::total_cmp);
    let q = |p: f64| e[((e.len() - 1) as f64 * p).round() as usize];
    let (mut wi, mut wj, mut w) = (0, 0, f32::MIN);
    for j in 0..table.size {
        for i in 0..table.size {
            if table.cell(i, j).err > w {
                (wi, wj, w) = (i, j, table.cell(i, j).err);
            }
        }
    }
    let worst = (
        LtcTable::roughness_at(table.size, wi),
        LtcTable::cos_view_at(table.size, wj).acos().to_degrees(),
    );
    (q(0.5), q(0.9), q(1.0), worst)
}

/// Per-cell fit error as an RGB image: x = roughness (0 left, 1 right),
/// y = sqrt(1 - cos θv) (normal view at the top, grazing at the bottom),
/// colour = log10 of the cell's `err` from 1e-3 (dark blue) to 1 (red).
pub fn fit_error_heatmap(table: &LtcTable, path: &Path) -> image::ImageResult<()> {
    const PX: u32 = 8;
    let n = table.size as u32;
    let img = image::RgbImage::from_fn(n * PX, n * PX, |x, y| {
        let e = table
            .cell((x / PX) as usize, (y / PX) as usize)
            .err
            .max(1e-6);
        let t = ((e.log10() + 3.0) / 3.0).clamp(0.0, 1.0);
        // Blue -> cyan -> yellow -> red.
        let (r, g, b) = if t < 1.0 / 3.0 {
            let s = t * 3.0;
            (0.0, s, 0.5 + 0.5 * s)
        } else if t < 2.0 / 3.0 {
            let s = t * 3.0 - 1.0;
            (s, 1.0, 1.0 - s)
        } else {
            let s = t * 3.0 - 2.0;
            (1.0, 1.0 - s, 0.0)
        };
        image::Rgb([(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8])
    });
    img.save(path)
}

/// CLI entry point: fits, prints a progress bar and a summary to stderr,
/// writes the table (and optionally the heatmap).
pub fn run_fit(size: usize, out: &Path, heatmap: Option<&Path>) -> anyhow::Result<()> {
    anyhow::ensure!(size >= 2, "--size must be at least 2");
    let start = Instant::now();
    let bar = crate::report::progress::bar((size * size) as u64, "fit-ltc", "cells");
    let table = fit_table(size, &|done, _| bar.set_position(done as u64));
    bar.finish_and_clear();
    let secs = start.elapsed().as_secs_f64();
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(out, table.to_bytes()).map_err(|e| anyhow::anyhow!("{}: {e}", out.display()))?;
    let (med, p90, max, (wr, wt)) = error_summary(&table);
    eprintln!(
        "fitted {size}x{size} LTC table in {secs:.1} s ({} threads) -> {}",
        rayon::current_num_threads(),
        out.display()
    );
    eprintln!(
        "RMS relative error on the test polygons: median {med:.4}, p90 {p90:.4}, max {max:.4} (roughness {wr:.3}, view {wt:.1} deg)"
    );
    if let Some(h) = heatmap {
        fit_error_heatmap(&table, h).map_err(|e| anyhow::anyhow!("{}: {e}", h.display()))?;
        eprintln!("error heatmap -> {}", h.display());
    }
    Ok(())
}

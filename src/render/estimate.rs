//! Per-pixel light estimates: analytic `U`, and the stochastic `U_N`, `S_N`
//! made from the SAME samples (only `S_N` multiplies by visibility).
//!
//! A sample is drawn in three steps, all from the pixel's low-discrepancy
//! stream: a light, chosen in proportion to its analytic `U` (so the shadow
//! ray budget does not grow with the number of lights); a strategy, light or
//! BRDF sampling (one-sample MIS, balance heuristic); a direction. Its
//! weight `f · L · cos / (P_light · p_mis)` goes to `U_N`, and to `S_N` once
//! its shadow ray comes back unoccluded.

use super::gbuffer::{GSample, PixelKind};
use super::shadow::{ShadowBatch, ShadowRay};
use super::world::World;
use crate::color::{LUMA, luminance};
use crate::sampling::brdf_sample::{brdf_pdf_local, sample_brdf, spec_lobe_probability};
use crate::sampling::light::{LightSampler, sample_light_area_uniform};
use crate::sampling::sequence::{sample_1d, sample_2d};
use crate::scene::Light;
use crate::shading::SurfacePoint;
use crate::shading::brdf::{ShadingBasis, alpha_from_roughness, eval_local};
use crate::shading::far_light::{WidePoints, form_factor_rounding, form_factors, ggx_bounds};
use crate::shading::light_bound::{FarView, LobeBound, PointGroup};
use crate::shading::u_batch::{
    LANES, LaneCounts, LaneLobes, PixelBatch, diffuse_batch, lobes_batch,
};
use glam::Vec3;

/// Dimensions of the per-pixel sample stream.
const DIM_LIGHT: u32 = 0;
const DIM_STRATEGY: u32 = 1;
const DIM_LOBE: u32 = 2;
const DIM_DIR: u32 = 3;
/// Sub-pixel position of the reference's camera rays.
pub const DIM_JITTER: u32 = 4;

/// Share of light choice spread uniformly over the lights, so a light whose
/// analytic `U` is (wrongly or barely) zero still gets samples: the
/// estimator stays unbiased whatever `U` says.
const UNIFORM_LIGHT_SHARE: f32 = 0.1;

#[inline]
pub fn surface_point(g: &GSample) -> SurfacePoint {
    SurfacePoint {
        p: g.position,
        n: g.ns,
        wo: g.wo,
        diffuse: g.diffuse,
        specular: g.specular,
        roughness: g.roughness,
    }
}

/// Columns and rows of the tiles over which the `U` stage culls lights.
pub const CULL_COLUMNS: usize = 8;
pub const CULL_ROWS: usize = 8;

/// The share of the culling budget the left-out GGX lobes may take; the
/// lights culled whole take the rest.
const GGX_SHARE: f32 = 0.8;

/// Scenes with fewer lights evaluate every light everywhere: on room's two
/// lights the culling's per-tile work cost more than it saved (`penumbra
/// bench scenes/room.toml --only unshadowed --light-tolerance T`, 0.02 and 0
/// alternated twice: U 224 and 230 against 205 and 214 ns per pixel).
const CULL_MIN_LIGHTS: usize = 3;

/// How the `U` stage's (pixel, light) pairs of surface pixels went.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UCounts {
    /// The lanes of the batched path (`shading::u_batch`).
    pub lanes: LaneCounts,
    /// Pairs with both lobes evaluated.
    pub full: u64,
    /// Pairs whose GGX lobe was left out, its bound being negligible.
    pub diffuse_only: u64,
    /// Of those, the pairs whose Lambert lobe the wide `f32` kernel gave
    /// (`shading::far_light`).
    pub lambert_wide: u64,
    /// Pairs left out, their bound being negligible (or zero).
    pub culled: u64,
}

/// Analytic unshadowed light of every light at every pixel of a band (the
/// frame's `U` stage), `LANES` pixels at a time through the batched `U`
/// (`shading::u_batch`; the lanes it cannot vouch for take the scalar
/// path inside it): `per_light[k * lights + i]` gets light `i` at
/// pixel `k`, `u[k]` their sum and `spec_share[k]` the specular lobe's share
/// of it (luminance; 0 where `U` is 0). Zero off surfaces. `gbuf` holds rows
/// of `row_len` pixels.
///
/// Light culling, per tile of `CULL_COLUMNS` x `CULL_ROWS` pixels: the
/// lights are taken in decreasing order of their bound over the tile
/// (`shading::light_bound`), and the rest are left out (zero) once their
/// bounds, with what the lobes left out before may cost, sum to at most
/// `tolerance` times the smallest `U` so far of a surface pixel of the
/// tile. A light's GGX lobe is left out while the lobes left out stay under
/// `GGX_SHARE` of that budget: over the whole tile by the tile's bound, or
/// per run of `LANES` pixels by each point's own bound when the light is
/// far (`shading::far_light`, which then also gives its Lambert lobe). So
/// every surface pixel's `U` (luminance) is within `tolerance` of what
/// every light would give it. `tolerance` 0, or fewer than
/// `CULL_MIN_LIGHTS` lights, evaluates every light at every pixel.
pub fn analytic_u_band(
    world: &World,
    gbuf: &[GSample],
    row_len: usize,
    tolerance: f32,
    per_light: &mut [Vec3],
    u: &mut [Vec3],
    spec_share: &mut [f32],
) -> UCounts {
    let n = world.lights.len();
    let mut counts = UCounts::default();
    per_light[..gbuf.len() * n].fill(Vec3::ZERO);
    u[..gbuf.len()].fill(Vec3::ZERO);
    // The specular luminance until the end, then its share.
    spec_share[..gbuf.len()].fill(0.0);
    if n == 0 || gbuf.is_empty() {
        return counts;
    }
    let row_len = row_len.clamp(1, gbuf.len());
    let rows = gbuf.len().div_ceil(row_len);
    let mut tile = Tile::default();
    let mut out = TileOut {
        per_light,
        u,
        spec_share,
        lights: n,
    };
    for r0 in (0..rows).step_by(CULL_ROWS) {
        for x0 in (0..row_len).step_by(CULL_COLUMNS) {
            tile.gather(gbuf, row_len, (r0, (r0 + CULL_ROWS).min(rows)), x0);
            if !tile.points.is_empty() {
                tile.shade(world, tolerance, &mut out, &mut counts);
            }
        }
    }
    for (share, total) in out.spec_share.iter_mut().zip(&out.u[..gbuf.len()]) {
        let lt = luminance(*total);
        *share = if lt > 0.0 { *share / lt } else { 0.0 };
    }
    counts
}

/// Where a tile's `U` goes (see `analytic_u_band`).
struct TileOut<'a> {
    per_light: &'a mut [Vec3],
    u: &'a mut [Vec3],
    spec_share: &'a mut [f32],
    lights: usize,
}

impl TileOut<'_> {
    #[inline]
    fn add(&mut self, k: usize, light: usize, d: Vec3, s: Vec3) {
        self.per_light[k * self.lights + light] = d + s;
        self.u[k] += d + s;
        self.spec_share[k] += luminance(s);
    }
}

/// Up to `LANES` pixels of a row, as the batched path reads them.
struct Run {
    /// Its first pixel in the band, and how many pixels it spans.
    k0: usize,
    len: usize,
    /// Its surface points: `points[first..first + count]` of the tile.
    first: usize,
    count: usize,
    batch: PixelBatch,
}

impl Run {
    /// The tile's point index and the lane of each surface point.
    fn lanes(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        (self.first..).zip((0..self.len).filter(|&l| self.batch.point(l).is_some()))
    }
}

/// One tile of the `U` stage: its surface points as the batched path, the
/// bounds and the wide Lambert kernel read them, and the working state of
/// its light loop; reused from tile to tile.
#[derive(Default)]
struct Tile {
    /// The runs of up to `LANES` pixels of a row that hold surface points.
    runs: Vec<Run>,
    points: Vec<SurfacePoint>,
    /// The pixel of each point.
    pixels: Vec<usize>,
    wide: WidePoints,
    form_factors: Vec<f32>,
    order: Vec<(usize, LobeBound)>,
    /// `rest[j]`: the bounds of the lights from `order[j]` on.
    rest: Vec<f32>,
    /// `U` so far at each point (luminance).
    kept: Vec<f32>,
    /// What the lobes left out at each point may cost (luminance).
    spent: Vec<f32>,
    /// Per point, the bound on one far light's GGX lobe.
    ggx: Vec<f32>,
    /// Per run: whether it leaves the light's GGX lobe out.
    leave_out: Vec<bool>,
    /// Whether `wide` holds this tile's points.
    wide_ready: bool,
}

impl Tile {
    /// The surface pixels of rows `rows` and columns `x0..x0 + CULL_COLUMNS`.
    fn gather(&mut self, gbuf: &[GSample], row_len: usize, rows: (usize, usize), x0: usize) {
        self.runs.clear();
        self.points.clear();
        self.pixels.clear();
        for r in rows.0..rows.1 {
            let row = r * row_len;
            for c0 in (x0..(x0 + CULL_COLUMNS).min(row_len)).step_by(LANES) {
                let k0 = row + c0;
                if k0 >= gbuf.len() {
                    break;
                }
                let len = LANES.min(row_len - c0).min(gbuf.len() - k0);
                let lane: [Option<SurfacePoint>; LANES] = std::array::from_fn(|l| {
                    (l < len)
                        .then(|| &gbuf[k0 + l])
                        .filter(|g| g.kind == PixelKind::Surface)
                        .map(surface_point)
                });
                if lane.iter().all(Option::is_none) {
                    continue;
                }
                let first = self.points.len();
                for (l, sp) in lane.iter().enumerate() {
                    if let Some(sp) = sp {
                        self.points.push(*sp);
                        self.pixels.push(k0 + l);
                    }
                }
                self.runs.push(Run {
                    k0,
                    len,
                    first,
                    count: self.points.len() - first,
                    batch: PixelBatch::new(&lane),
                });
            }
        }
    }

    /// The tile's points in `wide`, once per tile.
    fn prepare_wide(&mut self) {
        if self.wide_ready {
            return;
        }
        self.wide.clear();
        for sp in &self.points {
            let alpha = alpha_from_roughness(sp.roughness);
            self.wide
                .push(sp.p, sp.n, sp.wo, alpha, sp.specular.max_element());
        }
        self.wide.finish();
        let count = self.points.len();
        self.form_factors.resize(count, 0.0);
        self.ggx.resize(count, 0.0);
        self.wide_ready = true;
    }

    /// Every light's `U` at the tile's points, culled to `tolerance`.
    fn shade(&mut self, world: &World, tolerance: f32, out: &mut TileOut, counts: &mut UCounts) {
        let lights = world.lights.batch();
        let extents = world.lights.extents();
        let n = lights.len();
        let group = (tolerance > 0.0 && n >= CULL_MIN_LIGHTS)
            .then(|| PointGroup::new(&self.points))
            .flatten();
        let tolerance = if group.is_some() { tolerance } else { 0.0 };
        self.order.clear();
        match &group {
            Some(g) => {
                self.order
                    .extend(extents.iter().map(|e| g.bound(e)).enumerate());
                self.order
                    .sort_unstable_by(|a, b| b.1.total().total_cmp(&a.1.total()));
            }
            None => self.order.extend((0..n).map(|i| (i, LobeBound::NONE))),
        }
        // Summed from the smallest bound up, so no large bound is ever
        // subtracted from a small remainder.
        self.rest.clear();
        self.rest.resize(n + 1, 0.0);
        for j in (0..n).rev() {
            self.rest[j] = self.rest[j + 1] + self.order[j].1.total();
        }
        let count = self.points.len();
        self.kept.clear();
        self.kept.resize(count, 0.0);
        self.spent.clear();
        self.spent.resize(count, 0.0);
        let has_ggx = self.points.iter().any(|sp| sp.specular.max_element() > 0.0);
        self.wide_ready = false;
        // The smallest `U` so far, and the most any point's left-out
        // lobes may cost.
        let (mut smallest, mut most_spent) = (0.0f32, 0.0f32);
        let mut evaluated = 0;
        for j in 0..n {
            let (i, bound) = self.order[j];
            let budget = tolerance * smallest;
            if tolerance > 0.0 {
                if self.rest[j] + most_spent <= budget {
                    break;
                }
                if bound.total() == 0.0 {
                    continue;
                }
            }
            evaluated += 1;
            // The tile's bound may leave the GGX lobe out everywhere.
            let tile_drop = tolerance > 0.0 && most_spent + bound.specular <= GGX_SHARE * budget;
            let light = &world.lights.declared()[i];
            let far = group.as_ref().and_then(|g| g.far_view(&extents[i]));
            // Where the tile's bound cannot leave the GGX lobe out, each
            // point's own bound (it holds for any light) may, run by run.
            let per_point = has_ggx && !tile_drop && group.is_some();
            if far.is_some() || per_point {
                self.prepare_wide();
            }
            if per_point {
                ggx_bounds(&self.wide, &extents[i], &mut self.ggx);
            }
            let rounding = match (&group, far) {
                (Some(g), Some(view)) => bound_of_rounding(g.albedo(), light, view),
                _ => 0.0,
            };
            let radiance = luminance(light.radiance);
            let cost = |q: usize| {
                rounding
                    + if tile_drop {
                        bound.specular
                    } else if per_point {
                        radiance * self.ggx[q]
                    } else {
                        0.0
                    }
            };
            // Which runs leave the GGX lobe out, decided before any lobe is
            // computed: a far light's wide Lambert values only where some run
            // takes them; the other runs take the f64 batch (clipped).
            self.leave_out.clear();
            for run in &self.runs {
                let points = run.first..run.first + run.count;
                let leave = tile_drop
                    || (far.is_some() && !has_ggx)
                    || (per_point
                        && points.clone().all(|q| {
                            self.spent[q] + cost(q) <= GGX_SHARE * tolerance * self.kept[q]
                        }));
                self.leave_out.push(leave);
            }
            let wide = far.is_some() && self.leave_out.contains(&true);
            if wide {
                form_factors(&self.wide, &light.vertices, &mut self.form_factors);
            }
            let mut lobes = LaneLobes::default();
            for (run, &leave) in self.runs.iter_mut().zip(&self.leave_out) {
                let points = run.count as u64;
                if leave && wide {
                    for q in run.first..run.first + run.count {
                        let d = self.points[q].diffuse * light.radiance * self.form_factors[q];
                        out.add(self.pixels[q], i, d, Vec3::ZERO);
                        self.kept[q] += luminance(d);
                        self.spent[q] += cost(q);
                    }
                    counts.diffuse_only += points;
                    counts.lambert_wide += points;
                    continue;
                }
                let mut others = [0.0; LANES];
                for (q, l) in run.lanes() {
                    others[l] = self.kept[q];
                }
                run.batch.set_others(others);
                let c = if leave {
                    diffuse_batch(&run.batch, &lights[i], &mut lobes)
                } else {
                    lobes_batch(&run.batch, &lights[i], &mut lobes)
                };
                counts.lanes.fast += c.fast;
                counts.lanes.scalar += c.scalar;
                for (q, l) in run.lanes() {
                    let (d, s) = lobes.lane(l);
                    out.add(run.k0 + l, i, d, s);
                    self.kept[q] += luminance(d + s);
                    if leave {
                        self.spent[q] += cost(q);
                    }
                }
                if leave {
                    counts.diffuse_only += points;
                } else {
                    counts.full += points;
                }
            }
            smallest = self.kept.iter().fold(f32::INFINITY, |a, &b| a.min(b));
            most_spent = self.spent.iter().fold(0.0f32, |a, &b| a.max(b));
        }
        counts.culled += (n - evaluated) as u64 * count as u64;
    }
}

/// What the wide kernel's rounding may cost a tile whose largest albedo
/// channel is `albedo` (luminance).
fn bound_of_rounding(albedo: f32, light: &Light, view: FarView) -> f32 {
    albedo
        * luminance(light.radiance)
        * form_factor_rounding(light.vertices.len(), view.near, view.scale)
}

/// Which light a sample goes to: in proportion to the luminance of the
/// lights' analytic `U`, mixed with a uniform share.
#[inline]
fn pick_light(per_light: &[Vec3], xi: f32) -> (usize, f32) {
    let n = per_light.len();
    let total: f32 = per_light.iter().map(|u| u.dot(LUMA)).sum();
    let uniform = if total > 0.0 {
        UNIFORM_LIGHT_SHARE
    } else {
        1.0
    };
    let prob = |u: Vec3| {
        uniform / n as f32
            + (1.0 - uniform)
                * if total > 0.0 {
                    u.dot(LUMA) / total
                } else {
                    0.0
                }
    };
    let mut acc = 0.0;
    for (k, u) in per_light.iter().enumerate() {
        let p = prob(*u);
        acc += p;
        if xi < acc || k + 1 == n {
            return (k, p);
        }
    }
    (n - 1, prob(per_light[n - 1]))
}

/// Where a sample's shadow ray starts: off the surface along the geometric
/// normal (which faces the camera), by an amount that grows with the
/// magnitude of the coordinates (float spacing) and the hit distance. Always
/// on the camera's side: a direction below the geometric surface, allowed by
/// a bent shading normal, must cross the surface and be shadowed by it.
#[inline]
pub fn shadow_origin(g: &GSample) -> Vec3 {
    let scale = g.position.abs().max_element().max(g.depth).max(1.0);
    g.position + g.ng * (2e-5 * scale)
}

/// Which estimator a pixel's samples feed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Estimator {
    /// MIS of light and BRDF sampling: `U_N` and `S_N` (ratio, stochastic, reference).
    Mis,
    /// Uniform points on the light's area, each weighted by the pixel's
    /// total `U`: `S_N / U_N` is the plain average visibility (soft-shadow).
    AreaVisibility,
}

/// Where a pixel's samples lie in its sequence: every random number of a
/// sample is a function of (pixel, sample index, dimension, seed), so these
/// four numbers replay the pixel's samples exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SampleStream {
    /// Index of the pixel in the frame, row-major.
    pub pixel: u32,
    /// Index of the first sample drawn.
    pub first: u32,
    /// How many samples are drawn.
    pub count: u32,
    pub seed: u32,
}

/// Where a pixel's drawn samples go: weights add to `un`, shadow rays queue
/// in `batch` tagged with `slot`, and with `trace` every sample is recorded
/// (the pixel replay).
pub struct SampleSink<'a> {
    pub un: &'a mut Vec3,
    pub batch: &'a mut ShadowBatch,
    pub slot: u32,
    pub trace: Option<&'a mut Vec<SampleRecord>>,
}

/// How a sample chose its direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// A point on the light (MIS light strategy).
    Light,
    /// The BRDF's lobes (MIS BRDF strategy).
    Brdf,
    /// A uniform point on the light's area (soft-shadow).
    Area,
}

/// One sample of a pixel as the estimator saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleRecord {
    /// Index in the pixel's sequence.
    pub index: u32,
    pub light: usize,
    /// Probability of choosing `light`.
    pub p_choose: f32,
    /// Probability of the light strategy (1 for soft-shadow).
    pub p_light_strategy: f32,
    pub strategy: Strategy,
    /// Direction to the light and distance to its surface (0 when none).
    pub wi: Vec3,
    pub dist: f32,
    /// Solid-angle pdfs of the light and BRDF strategies, and of the
    /// one-sample MIS mixture.
    pub pdf_light: f32,
    pub pdf_brdf: f32,
    pub pdf: f32,
    /// BRDF value (times nothing: cosine and radiance are in `weight`).
    pub f: Vec3,
    /// What the sample adds to `U_N`, and to `S_N` when its shadow ray is
    /// unoccluded.
    pub weight: Vec3,
    /// Why it added nothing (`None`: it queued a shadow ray).
    pub dropped: Option<&'static str>,
}

impl SampleRecord {
    fn new(index: u32, light: usize, p_choose: f32, strategy: Strategy) -> SampleRecord {
        SampleRecord {
            index,
            light,
            p_choose,
            p_light_strategy: 1.0,
            strategy,
            wi: Vec3::ZERO,
            dist: 0.0,
            pdf_light: 0.0,
            pdf_brdf: 0.0,
            pdf: 0.0,
            f: Vec3::ZERO,
            weight: Vec3::ZERO,
            dropped: None,
        }
    }
}

impl SampleSink<'_> {
    #[inline]
    fn record(&mut self, r: impl FnOnce() -> SampleRecord) {
        if let Some(t) = self.trace.as_deref_mut() {
            t.push(r());
        }
    }
}

/// Draws `stream.count` samples for one pixel into `sink`: their weights
/// add to `U_N`, their shadow rays (to be added to `S_N` when unoccluded)
/// queue in its batch.
pub fn draw_samples(
    world: &World,
    g: &GSample,
    per_light: &[Vec3],
    u_total: Vec3,
    estimator: Estimator,
    stream: SampleStream,
    sink: &mut SampleSink,
) {
    let SampleStream {
        pixel,
        first,
        count: spp,
        seed,
    } = stream;
    if g.kind != PixelKind::Surface || world.lights.is_empty() || spp == 0 {
        return;
    }
    let inv_spp = 1.0 / spp as f32;
    let n = g.ns;
    let wo = g.wo;
    let alpha = alpha_from_roughness(g.roughness);
    let p_spec = spec_lobe_probability(g.diffuse, g.specular, n.dot(wo));
    // Rough solid angle of the reflected GGX lobe, for the strategy choice.
    let lobe_solid_angle = 4.0 * std::f32::consts::PI * (2.0 * alpha).powi(2);
    // One local frame per pixel for both the BRDF and its pdf (the pdf is
    // isotropic, so it does not care which frame), instead of two per sample.
    let frame = ShadingBasis::from_normal_view(n, wo);
    let wo_l = frame.to_local(wo);
    // The light sampler of the last light chosen: its setup is per (light,
    // point). Kept in place and borrowed: the sampler is large enough that
    // moving it around per sample was a measurable share of this function.
    let mut cached_light = usize::MAX;
    let mut cached: Option<LightSampler> = None;
    for s in 0..spp {
        let index = first.wrapping_add(s);
        let (li, p_choose) = pick_light(per_light, sample_1d(pixel, index, DIM_LIGHT, seed));
        let light = &world.lights.declared()[li];
        let dir_u = sample_2d(pixel, index, DIM_DIR, seed);
        if estimator == Estimator::AreaVisibility {
            let q = sample_light_area_uniform(light, dir_u);
            let to = q - g.position;
            let dist = to.length();
            let base = || SampleRecord::new(index, li, p_choose, Strategy::Area);
            if !(dist > 0.0 && dist.is_finite()) {
                sink.record(|| SampleRecord {
                    dropped: Some("the light point is the shading point"),
                    ..base()
                });
                continue;
            }
            let wi = to / dist;
            let w = u_total * inv_spp;
            *sink.un += w;
            sink.batch
                .push(ShadowRay::new(shadow_origin(g), wi, dist, sink.slot, w));
            sink.record(|| SampleRecord {
                wi,
                dist,
                weight: w,
                ..base()
            });
            continue;
        }
        if cached_light != li {
            cached_light = li;
            cached = LightSampler::new(&world.lights.sampling()[li], g.position);
        }
        let Some(sampler) = cached.as_ref() else {
            sink.record(|| SampleRecord {
                dropped: Some("the light is behind the point or degenerate"),
                ..SampleRecord::new(index, li, p_choose, Strategy::Light)
            });
            continue;
        };
        let p_light_strategy =
            light_strategy_probability(p_spec, lobe_solid_angle, sampler.solid_angle());
        let use_light = sample_1d(pixel, index, DIM_STRATEGY, seed) < p_light_strategy;
        let strategy = if use_light {
            Strategy::Light
        } else {
            Strategy::Brdf
        };
        let base = || SampleRecord {
            p_light_strategy,
            ..SampleRecord::new(index, li, p_choose, strategy)
        };
        let picked = if use_light {
            sampler.sample(dir_u).map(|ls| (ls.wi, ls.dist, ls.pdf))
        } else {
            let lobe = sample_1d(pixel, index, DIM_LOBE, seed);
            sample_brdf(n, wo, alpha, p_spec, lobe, dir_u)
                .and_then(|bs| sampler.pdf(bs.wi).map(|(pdf, d)| (bs.wi, d, pdf)))
        };
        let Some((wi, dist, pdf_light)) = picked else {
            sink.record(|| SampleRecord {
                dropped: Some(if use_light {
                    "no point of the light was sampled"
                } else {
                    "the BRDF direction misses the light"
                }),
                ..base()
            });
            continue;
        };
        let cos = n.dot(wi);
        if cos <= 0.0 {
            sink.record(|| SampleRecord {
                wi,
                dist,
                pdf_light,
                dropped: Some("below the shading normal's horizon"),
                ..base()
            });
            continue;
        }
        let wi_l = frame.to_local(wi);
        let pdf_brdf = if p_light_strategy < 1.0 {
            brdf_pdf_local(wo_l, wi_l, alpha, p_spec)
        } else {
            0.0
        };
        let pdf = p_light_strategy * pdf_light + (1.0 - p_light_strategy) * pdf_brdf;
        let f = eval_local(wi_l, wo_l, g.diffuse, g.specular, g.roughness);
        let w = f * light.radiance * (cos * inv_spp / (p_choose * pdf));
        let full = || SampleRecord {
            wi,
            dist,
            pdf_light,
            pdf_brdf,
            pdf,
            f,
            weight: w,
            ..base()
        };
        if !(pdf > 0.0 && pdf.is_finite()) {
            sink.record(|| SampleRecord {
                dropped: Some("zero or non-finite pdf"),
                weight: Vec3::ZERO,
                ..full()
            });
            continue;
        }
        if !w.is_finite() || w.max_element() <= 0.0 {
            sink.record(|| SampleRecord {
                dropped: Some("zero or non-finite weight"),
                ..full()
            });
            continue;
        }
        *sink.un += w;
        sink.batch
            .push(ShadowRay::new(shadow_origin(g), wi, dist, sink.slot, w));
        sink.record(full);
    }
}

/// How often one-sample MIS draws from the light rather than the BRDF.
/// Light sampling serves the diffuse lobe, and a specular lobe wider than
/// the light; BRDF sampling a lobe narrower than the light (a near mirror).
/// Any value in (0, 1] keeps the estimator unbiased (light sampling covers
/// the whole light); the clamp keeps both strategies alive for MIS.
#[inline]
fn light_strategy_probability(p_spec: f32, lobe_solid_angle: f32, light_solid_angle: f32) -> f32 {
    if p_spec <= 0.0 {
        return 1.0;
    }
    let spec = (lobe_solid_angle / (lobe_solid_angle + light_solid_angle)).clamp(0.1, 0.9);
    (1.0 - p_spec) + p_spec * spec
}

/// `S_N / U_N` per channel, defined as 1 (fully lit) where `U_N` carries no
/// energy: no sample saw the light there, so the samples say nothing about
/// its visibility, and the frame falls back to the analytic `U`.
#[inline]
pub fn ratio(sn: Vec3, un: Vec3) -> Vec3 {
    let r = |s: f32, u: f32| {
        if u > 1e-20 {
            (s / u).clamp(0.0, 1.0)
        } else {
            1.0
        }
    };
    Vec3::new(r(sn.x, un.x), r(sn.y, un.y), r(sn.z, un.z))
}

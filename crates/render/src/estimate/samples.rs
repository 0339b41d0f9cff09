//! The stochastic estimates `U_N`, `S_N` of a pixel from the same samples:
//! a light chosen in proportion to its analytic `U`, a strategy (light or
//! BRDF sampling, one-sample MIS), a direction, and a shadow ray whose
//! answer decides `S_N` alone.

use crate::gbuffer::{GSample, PixelKind};
use crate::shadow::{ShadowBatch, ShadowRay};
use crate::world::World;
use glam::{Vec2, Vec3};
use penumbra_isa::Kernel;
use penumbra_kernels::sampling::brdf_sample::{brdf_pdf_local, sample_brdf, spec_lobe_probability};
use penumbra_kernels::sampling::draw_lanes::{
    DrawLanesIn, DrawLanesOut, LanesLight, draw_fan_lanes, draw_rect_lanes,
};
use penumbra_kernels::sampling::lanes8::{N as LANES, lane3, set3};
use penumbra_kernels::sampling::light::{
    LOBE_OFF_LIGHT_SHARE, LightSampler, PreparedLight, sample_light_area_uniform,
};
use penumbra_kernels::sampling::sequence::{StreamBatch, sample_1d, sample_2d};
use penumbra_kernels::shading::brdf::{ShadingBasis, alpha_from_roughness, eval_local};
use penumbra_scene::Light;
use penumbra_scene::color::LUMA;

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

/// Where a draw's per-sample records go: the pixel replay keeps them, the
/// frame's own draws drop them. A type parameter rather than a run-time
/// test, so the frame's draws carry no record building at all while both
/// run the one body of arithmetic (the replay explains the frame's values
/// exactly because they are the same code).
trait Recorder {
    fn record(&mut self, r: impl FnOnce() -> SampleRecord);
}

/// The frame's draws: nothing is recorded.
struct NoRecord;

impl Recorder for NoRecord {
    #[inline(always)]
    fn record(&mut self, _: impl FnOnce() -> SampleRecord) {}
}

impl Recorder for Vec<SampleRecord> {
    #[inline]
    fn record(&mut self, r: impl FnOnce() -> SampleRecord) {
        self.push(r());
    }
}

/// Draws `stream.count` samples for one pixel into `sink`: their weights
/// add to `U_N`, their shadow rays (to be added to `S_N` when unoccluded)
/// queue in its batch. The frame's bands draw through `draw_samples`,
/// which gives the same values; this is the one-pixel form (the pixel
/// replay, the orphans of the quarter rate).
pub fn draw_pixel_samples(
    world: &World,
    g: &GSample,
    per_light: &[Vec3],
    u_total: Vec3,
    estimator: Estimator,
    stream: SampleStream,
    sink: &mut SampleSink,
) {
    let SampleSink {
        un,
        batch,
        slot,
        trace,
    } = sink;
    let out = Out {
        un,
        batch,
        slot: *slot,
    };
    let streams = PixelStreams(stream);
    match trace.as_deref_mut() {
        Some(t) => draw(
            world,
            g,
            per_light,
            u_total,
            estimator,
            stream,
            0..stream.count,
            &streams,
            out,
            t,
        ),
        None => draw(
            world,
            g,
            per_light,
            u_total,
            estimator,
            stream,
            0..stream.count,
            &streams,
            out,
            &mut NoRecord,
        ),
    }
}

/// The random numbers a pixel's samples draw, by sample index `s` (from
/// 0) within its stream: computed on the spot for one pixel, or read from
/// a band's batch (`BandStreams`), the same values either way.
trait Streams {
    fn light(&self, s: u32) -> f32;
    fn strategy(&self, s: u32) -> f32;
    fn lobe(&self, s: u32) -> f32;
    fn dir(&self, s: u32) -> Vec2;
}

/// One pixel's streams, hashed when asked.
struct PixelStreams(SampleStream);

impl PixelStreams {
    /// Sample `s`'s value in dimension `dim` of this pixel's stream.
    #[inline(always)]
    fn at(&self, s: u32, dim: u32) -> f32 {
        let t = self.0;
        sample_1d(t.pixel, t.first.wrapping_add(s), dim, t.seed)
    }
}

impl Streams for PixelStreams {
    #[inline(always)]
    fn light(&self, s: u32) -> f32 {
        self.at(s, DIM_LIGHT)
    }
    #[inline(always)]
    fn strategy(&self, s: u32) -> f32 {
        self.at(s, DIM_STRATEGY)
    }
    #[inline(always)]
    fn lobe(&self, s: u32) -> f32 {
        self.at(s, DIM_LOBE)
    }
    #[inline(always)]
    fn dir(&self, s: u32) -> Vec2 {
        let t = self.0;
        sample_2d(t.pixel, t.first.wrapping_add(s), DIM_DIR, t.seed)
    }
}

/// Per-thread working memory of `draw_samples`, reused across bands (no
/// allocation once the largest band has been seen): the frame indices of
/// the drawn pixels and their streams' values, one array per dimension,
/// sample-major (`[s * n + j]` for the `j`-th drawn pixel).
#[derive(Default)]
pub struct SampleScratch {
    pixels: Vec<u32>,
    light: Vec<f32>,
    strategy: Vec<f32>,
    lobe: Vec<f32>,
    dir_x: Vec<f32>,
    dir_y: Vec<f32>,
    /// Per sample, pixel-major (`j * spp + s`): the light chosen and its
    /// probability (`NO_LIGHT`: the pixel draws nothing), and the lane that
    /// draws it (`NOT_IN_LANES`: the scalar code does).
    chosen: Vec<(u32, f32)>,
    lane_of: Vec<u32>,
    /// Per light: its samples, then the next free lane of its chunks.
    per_light: Vec<u32>,
    /// The lights' runs of chunks: (light, first chunk, end chunk).
    groups: Vec<(u32, u32, u32)>,
    /// The lane kernel's samples, eight per entry, grouped by light, and
    /// what it drew for them.
    lanes_in: Vec<DrawLanesIn>,
    lanes_out: Vec<DrawLanesOut>,
}

/// The `j`-th drawn pixel's streams in a band's batch of `n`.
struct BandStreams<'a> {
    scratch: &'a SampleScratch,
    j: usize,
    n: usize,
}

impl BandStreams<'_> {
    #[inline(always)]
    fn at(&self, s: u32) -> usize {
        s as usize * self.n + self.j
    }
}

impl Streams for BandStreams<'_> {
    #[inline(always)]
    fn light(&self, s: u32) -> f32 {
        self.scratch.light[self.at(s)]
    }
    #[inline(always)]
    fn strategy(&self, s: u32) -> f32 {
        self.scratch.strategy[self.at(s)]
    }
    #[inline(always)]
    fn lobe(&self, s: u32) -> f32 {
        self.scratch.lobe[self.at(s)]
    }
    #[inline(always)]
    fn dir(&self, s: u32) -> Vec2 {
        let i = self.at(s);
        Vec2::new(self.scratch.dir_x[i], self.scratch.dir_y[i])
    }
}

/// What a band's pixels draw: their G-buffer, `U` per light (`lights` per
/// pixel) and in all, the estimator, and where the samples lie in each
/// pixel's sequence (band pixel `k` is frame pixel `base + k`).
pub struct BandDraw<'a> {
    pub gbuf: &'a [GSample],
    pub per_light: &'a [Vec3],
    pub u: &'a [Vec3],
    pub estimator: Estimator,
    pub base: u32,
    pub first: u32,
    pub spp: u32,
    pub seed: u32,
}

/// Draws the samples of a band's pixels `drawn`, pairs of an index into
/// the band and the slot `m` its samples add to: weights to `un[m]`,
/// shadow rays into `batch` tagged `m`. The streams' hashing runs first
/// over every drawn pixel in lanes (`StreamBatch`), then each pixel's
/// samples.
// Out of line: a stage of `make profile` (scripts/profile.py).
#[inline(never)]
pub fn draw_samples(
    world: &World,
    band: &BandDraw,
    drawn: &[(usize, usize)],
    un: &mut [Vec3],
    batch: &mut ShadowBatch,
    scratch: &mut SampleScratch,
) {
    let (n, spp) = (drawn.len(), band.spp);
    if n == 0 || spp == 0 || world.lights.is_empty() {
        return;
    }
    scratch.pixels.clear();
    scratch
        .pixels
        .extend(drawn.iter().map(|&(k, _)| band.base.wrapping_add(k as u32)));
    let len = n * spp as usize;
    for v in [
        &mut scratch.light,
        &mut scratch.strategy,
        &mut scratch.lobe,
        &mut scratch.dir_x,
        &mut scratch.dir_y,
    ] {
        v.resize(len, 0.0);
    }
    for s in 0..spp {
        let r = s as usize * n..(s as usize + 1) * n;
        penumbra_isa::run(StreamBatch {
            pixels: &scratch.pixels,
            sample_index: band.first.wrapping_add(s),
            seed: band.seed,
            dims_1d: [DIM_LIGHT, DIM_STRATEGY, DIM_LOBE],
            out_1d: [
                &mut scratch.light[r.clone()],
                &mut scratch.strategy[r.clone()],
                &mut scratch.lobe[r.clone()],
            ],
            dim_2d: DIM_DIR,
            out_2d: [&mut scratch.dir_x[r.clone()], &mut scratch.dir_y[r]],
        });
    }
    let lights = world.lights.len();
    if band.estimator == Estimator::Mis {
        draw_in_lanes(world, band, drawn, un, batch, scratch);
        return;
    }
    for (j, &(k, m)) in drawn.iter().enumerate() {
        let stream = SampleStream {
            pixel: scratch.pixels[j],
            first: band.first,
            count: spp,
            seed: band.seed,
        };
        draw(
            world,
            &band.gbuf[k],
            &band.per_light[k * lights..(k + 1) * lights],
            band.u[k],
            band.estimator,
            stream,
            0..spp,
            &BandStreams { scratch, j, n },
            Out {
                un: &mut un[m],
                batch,
                slot: m as u32,
            },
            &mut NoRecord,
        );
    }
}

/// `SampleScratch::chosen` of a pixel that draws nothing.
const NO_LIGHT: u32 = u32::MAX;
/// `SampleScratch::lane_of` of a sample the scalar code draws.
const NOT_IN_LANES: u32 = u32::MAX;

/// The MIS samples of a band in lanes: the samples are grouped by the light
/// they chose, eight to a chunk of one light, so the light's data is read
/// once per chunk instead of copied into every lane, and each is a lane of
/// `draw_rect_lanes` or `draw_fan_lanes`, whose handled lanes hold exactly
/// what the scalar `draw` computes for them, a sample or a drop (the same
/// operations in the same order); every other sample (area sampling of a
/// tiny solid angle, a light of fewer than three vertices) is drawn by
/// `draw` itself, and a pixel that is no surface draws nothing. Results go
/// out in the scalar order, pixel by pixel and sample by sample, so `U_N`
/// and the shadow batch are the same bits as the scalar loop's.
fn draw_in_lanes(
    world: &World,
    band: &BandDraw,
    drawn: &[(usize, usize)],
    un: &mut [Vec3],
    batch: &mut ShadowBatch,
    scratch: &mut SampleScratch,
) {
    let (n, spp) = (drawn.len(), band.spp as usize);
    let lights = world.lights.len();
    let samplers = world.lights.sampling();
    let total = n * spp;
    scratch.chosen.resize(total, (NO_LIGHT, 0.0));
    scratch.lane_of.clear();
    scratch.lane_of.resize(total, NOT_IN_LANES);
    scratch.per_light.clear();
    scratch.per_light.resize(lights, 0);
    // The light of every sample, and how many each light's lanes take.
    for (j, &(k, _)) in drawn.iter().enumerate() {
        let chosen = &mut scratch.chosen[j * spp..(j + 1) * spp];
        if band.gbuf[k].kind != PixelKind::Surface {
            chosen.fill((NO_LIGHT, 0.0));
            continue;
        }
        let per_light = &band.per_light[k * lights..(k + 1) * lights];
        for (s, c) in chosen.iter_mut().enumerate() {
            let (li, p_choose) = pick_light(per_light, scratch.light[s * n + j]);
            *c = (li as u32, p_choose);
            if samplers[li].in_lanes() {
                scratch.per_light[li] += 1;
            }
        }
    }
    // Each light's run of chunks; its last chunk's spare lanes inactive.
    scratch.groups.clear();
    let mut chunks = 0u32;
    for (li, count) in scratch.per_light.iter_mut().enumerate() {
        if *count == 0 {
            continue;
        }
        let end = chunks + count.div_ceil(LANES as u32);
        scratch.groups.push((li as u32, chunks, end));
        *count = chunks * LANES as u32;
        chunks = end;
    }
    scratch
        .lanes_in
        .resize(chunks as usize, DrawLanesIn::default());
    scratch
        .lanes_out
        .resize(chunks as usize, DrawLanesOut::default());
    for &(_, _, end) in &scratch.groups {
        scratch.lanes_in[end as usize - 1].active.0 = [0.0; LANES];
    }
    for (j, &(k, _)) in drawn.iter().enumerate() {
        let g = &band.gbuf[k];
        let alpha = alpha_from_roughness(g.roughness);
        // Whether the lobe points away from a light depends on the pixel
        // and the light only: once per light a pixel's samples chose in a
        // row, as the scalar draw does it.
        let mut off_for = (NO_LIGHT, false);
        for s in 0..spp {
            let e = j * spp + s;
            let (li, p_choose) = scratch.chosen[e];
            if li == NO_LIGHT || !samplers[li as usize].in_lanes() {
                continue;
            }
            if off_for.0 != li {
                let off = samplers[li as usize].lobe_misses(g.position, g.ns, g.wo, alpha);
                off_for = (li, off);
            }
            let lane = scratch.per_light[li as usize];
            scratch.per_light[li as usize] += 1;
            scratch.lane_of[e] = lane;
            let (c, l) = (
                &mut scratch.lanes_in[lane as usize / LANES],
                lane as usize % LANES,
            );
            let i = s * n + j;
            c.active.0[l] = 1.0;
            set3(&mut c.p, l, g.position);
            set3(&mut c.ns, l, g.ns);
            set3(&mut c.wo, l, g.wo);
            set3(&mut c.diffuse, l, g.diffuse);
            set3(&mut c.specular, l, g.specular);
            c.roughness.0[l] = g.roughness;
            c.p_choose.0[l] = p_choose;
            c.lobe_off.0[l] = if off_for.1 { 1.0 } else { 0.0 };
            c.u_strategy.0[l] = scratch.strategy[i];
            c.u_lobe.0[l] = scratch.lobe[i];
            c.ux.0[l] = scratch.dir_x[i];
            c.uy.0[l] = scratch.dir_y[i];
        }
    }
    DrawLanesBatch {
        lights: samplers,
        declared: world.lights.declared(),
        inv_spp: 1.0 / band.spp as f32,
        groups: &scratch.groups,
        input: &scratch.lanes_in,
        out: &mut scratch.lanes_out,
    }
    .run();
    for (j, &(k, m)) in drawn.iter().enumerate() {
        let g = &band.gbuf[k];
        if g.kind != PixelKind::Surface {
            continue;
        }
        let stream = SampleStream {
            pixel: scratch.pixels[j],
            first: band.first,
            count: band.spp,
            seed: band.seed,
        };
        for s in 0..spp {
            let lane = scratch.lane_of[j * spp + s];
            if lane != NOT_IN_LANES {
                let (o, l) = (
                    &scratch.lanes_out[lane as usize / LANES],
                    lane as usize % LANES,
                );
                if o.handled.0[l] != 0.0 {
                    if o.emit.0[l] == 0.0 {
                        // Dropped, as the scalar draw drops it.
                        continue;
                    }
                    let w = lane3(&o.weight, l);
                    un[m] += w;
                    let wi = lane3(&o.wi, l);
                    batch.push(ShadowRay::new(
                        shadow_origin(g),
                        wi,
                        o.dist.0[l],
                        m as u32,
                        w,
                    ));
                    continue;
                }
            }
            let s = s as u32;
            draw(
                world,
                g,
                &band.per_light[k * lights..(k + 1) * lights],
                band.u[k],
                band.estimator,
                stream,
                s..s + 1,
                &BandStreams { scratch, j, n },
                Out {
                    un: &mut un[m],
                    batch,
                    slot: m as u32,
                },
                &mut NoRecord,
            );
        }
    }
}

/// The lane draw over a band's chunks, light by light, at the run-time
/// ISA level.
struct DrawLanesBatch<'a> {
    lights: &'a [PreparedLight],
    declared: &'a [Light],
    inv_spp: f32,
    groups: &'a [(u32, u32, u32)],
    input: &'a [DrawLanesIn],
    out: &'a mut [DrawLanesOut],
}

impl DrawLanesBatch<'_> {
    fn run(self) {
        for &(li, a, b) in self.groups {
            let light = LanesLight {
                light: &self.lights[li as usize],
                radiance: self.declared[li as usize].radiance,
                inv_spp: self.inv_spp,
            };
            let (a, b) = (a as usize, b as usize);
            let chunks = LightChunks {
                light,
                input: &self.input[a..b],
                out: &mut self.out[a..b],
            };
            if light.light.is_rect() {
                penumbra_isa::run(RectChunks(chunks));
            } else {
                penumbra_isa::run(FanChunks(chunks));
            }
        }
    }
}

/// One light's run of chunks.
struct LightChunks<'a> {
    light: LanesLight<'a>,
    input: &'a [DrawLanesIn],
    out: &'a mut [DrawLanesOut],
}

/// A rectangle light's chunks. The two samplers are separate kernels, so
/// each is compiled as its own function per ISA level: one function holding
/// both took the optimiser several times as long as the two apart.
struct RectChunks<'a>(LightChunks<'a>);

impl Kernel for RectChunks<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let c = self.0;
        for (i, o) in c.input.iter().zip(c.out.iter_mut()) {
            *o = draw_rect_lanes(&c.light, i);
        }
    }
}

/// A fan light's chunks.
struct FanChunks<'a>(LightChunks<'a>);

impl Kernel for FanChunks<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let c = self.0;
        for (i, o) in c.input.iter().zip(c.out.iter_mut()) {
            *o = draw_fan_lanes(&c.light, i);
        }
    }
}

/// The sums a pixel's samples feed.
struct Out<'a> {
    un: &'a mut Vec3,
    batch: &'a mut ShadowBatch,
    slot: u32,
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn draw(
    world: &World,
    g: &GSample,
    per_light: &[Vec3],
    u_total: Vec3,
    estimator: Estimator,
    stream: SampleStream,
    samples: std::ops::Range<u32>,
    streams: &impl Streams,
    out: Out,
    rec: &mut impl Recorder,
) {
    let SampleStream {
        first, count: spp, ..
    } = stream;
    if g.kind != PixelKind::Surface || world.lights.is_empty() || spp == 0 {
        return;
    }
    let inv_spp = 1.0 / spp as f32;
    let origin = shadow_origin(g);
    if estimator == Estimator::AreaVisibility {
        let w = u_total * inv_spp;
        for s in samples {
            let index = first.wrapping_add(s);
            let (li, p_choose) = pick_light(per_light, streams.light(s));
            let light = &world.lights.declared()[li];
            let dir_u = streams.dir(s);
            let q = sample_light_area_uniform(light, dir_u);
            let to = q - g.position;
            let dist = to.length();
            let base = || SampleRecord::new(index, li, p_choose, Strategy::Area);
            if !(dist > 0.0 && dist.is_finite()) {
                rec.record(|| SampleRecord {
                    dropped: Some("the light point is the shading point"),
                    ..base()
                });
                continue;
            }
            let wi = to / dist;
            *out.un += w;
            out.batch
                .push(ShadowRay::new(origin, wi, dist, out.slot, w));
            rec.record(|| SampleRecord {
                wi,
                dist,
                weight: w,
                ..base()
            });
        }
        return;
    }
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
    let samplers = world.lights.sampling();
    let lights = world.lights.declared();
    // The light sampler of the last light chosen: its setup is per (light,
    // point). Kept in place and borrowed: the sampler is large enough that
    // moving it around per sample was a measurable share of this function.
    let mut cached_light = usize::MAX;
    let mut cached: Option<LightSampler> = None;
    let mut lobe_off = false;
    for s in samples {
        let index = first.wrapping_add(s);
        let (li, p_choose) = pick_light(per_light, streams.light(s));
        let light = &lights[li];
        if cached_light != li {
            cached_light = li;
            cached = LightSampler::new(&samplers[li], g.position);
            lobe_off = samplers[li].lobe_misses(g.position, n, wo, alpha);
        }
        let Some(sampler) = cached.as_ref() else {
            rec.record(|| SampleRecord {
                dropped: Some("the light is behind the point or degenerate"),
                ..SampleRecord::new(index, li, p_choose, Strategy::Light)
            });
            continue;
        };
        let dir_u = streams.dir(s);
        let p_light_strategy =
            light_strategy_probability(p_spec, lobe_solid_angle, sampler.solid_angle(), lobe_off);
        // At probability 1 every u in [0, 1) picks the light: the strategy's
        // stream is only drawn where it can decide anything.
        let use_light = p_light_strategy >= 1.0 || streams.strategy(s) < p_light_strategy;
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
            let lobe = streams.lobe(s);
            sample_brdf(n, wo, alpha, p_spec, lobe, dir_u)
                .and_then(|bs| sampler.pdf(bs.wi).map(|(pdf, d)| (bs.wi, d, pdf)))
        };
        let Some((wi, dist, pdf_light)) = picked else {
            rec.record(|| SampleRecord {
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
            rec.record(|| SampleRecord {
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
            rec.record(|| SampleRecord {
                dropped: Some("zero or non-finite pdf"),
                weight: Vec3::ZERO,
                ..full()
            });
            continue;
        }
        if !w.is_finite() || w.max_element() <= 0.0 {
            rec.record(|| SampleRecord {
                dropped: Some("zero or non-finite weight"),
                ..full()
            });
            continue;
        }
        *out.un += w;
        out.batch
            .push(ShadowRay::new(origin, wi, dist, out.slot, w));
        rec.record(full);
    }
}

/// How often one-sample MIS draws from the light rather than the BRDF.
/// Light sampling serves the diffuse lobe, a specular lobe wider than the
/// light, and one that points away from the light (`lobe_off`: the light
/// lies in the lobe's tail, `LOBE_OFF_LIGHT_SHARE`); BRDF
/// sampling a lobe narrower than the light around its peak (a near mirror
/// reflecting it). Any value in (0, 1] keeps the estimator unbiased (light
/// sampling covers the whole light); the clamp keeps both strategies alive
/// for MIS.
#[inline]
fn light_strategy_probability(
    p_spec: f32,
    lobe_solid_angle: f32,
    light_solid_angle: f32,
    lobe_off: bool,
) -> f32 {
    if p_spec <= 0.0 {
        return 1.0;
    }
    let spec = if lobe_off {
        LOBE_OFF_LIGHT_SHARE
    } else {
        (lobe_solid_angle / (lobe_solid_angle + light_solid_angle)).clamp(0.1, 0.9)
    };
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

//! The stochastic estimates `U_N`, `S_N` of a pixel from the same samples:
//! a light chosen in proportion to its analytic `U`, a strategy (light or
//! BRDF sampling, one-sample MIS), a direction, and a shadow ray whose
//! answer decides `S_N` alone.

use crate::gbuffer::{GSample, PixelKind};
use crate::shadow::{ShadowBatch, ShadowRay};
use crate::world::World;
use glam::Vec3;
use penumbra_kernels::sampling::brdf_sample::{brdf_pdf_local, sample_brdf, spec_lobe_probability};
use penumbra_kernels::sampling::light::{LightSampler, sample_light_area_uniform};
use penumbra_kernels::sampling::sequence::{sample_1d, sample_2d};
use penumbra_kernels::shading::brdf::{ShadingBasis, alpha_from_roughness, eval_local};
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
// Out of line: a stage of `make profile` (scripts/profile.py).
#[inline(never)]
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

//! The pixel replay: every sample one pixel drew in the last frame, with
//! its light, strategy, pdfs, weight and visibility, so a wrong pixel can
//! be explained. Exact because every random number is a function of the
//! pixel, the sample index, the dimension and the seed, and the frame keeps
//! the G-buffer its samples were drawn on.

use super::estimate::{SampleRecord, SampleSink, SampleStream, Strategy, analytic_u_band, ratio};
use super::frame::{BAND_ROWS, Frame};
use super::gbuffer::{GSample, PixelKind};
use super::plan::FramePlan;
use super::quads::{QUAD_ORDER, sampled_pixel};
use super::settings::RenderSettings;
use super::settings::VisibilityRate;
use super::shadow::ShadowBatch;
use super::world::World;
use glam::Vec3;
use std::fmt::Write;

/// One pixel of the last frame, replayed.
pub struct PixelReplay {
    pub x: u32,
    pub y: u32,
    pub g: GSample,
    /// Analytic `U` of each light, as the frame's `U` stage computed it.
    pub per_light: Vec<Vec3>,
    /// What drew samples at this pixel in the last frame (empty: none; at
    /// the quarter rate a pixel may be upsampled from its quad instead).
    pub draws: Vec<Draw>,
    /// Why nothing was drawn, when `draws` is empty.
    pub note: Option<String>,
    /// The frame's buffers at the pixel (after denoising and upsampling).
    pub frame_u: Vec3,
    pub frame_un: Vec3,
    pub frame_sn: Vec3,
    pub frame_color: Vec3,
}

/// One set of samples the pixel drew: its stream, every sample, whether
/// each queued shadow ray reached the light, and the sums they make.
pub struct Draw {
    pub why: &'static str,
    pub stream: SampleStream,
    pub samples: Vec<SampleRecord>,
    /// Per sample: `Some(visible)` for a traced shadow ray, `None` for a
    /// sample that was dropped.
    pub visible: Vec<Option<bool>>,
    pub un: Vec3,
    pub sn: Vec3,
}

/// Replays pixel `(x, y)` of the last frame `frame` rendered of `world`
/// with `settings`.
pub fn replay_pixel(
    world: &World,
    frame: &Frame,
    settings: &RenderSettings,
    x: u32,
    y: u32,
) -> Result<PixelReplay, String> {
    if x >= frame.width || y >= frame.height {
        return Err(format!(
            "--debug-pixel {x},{y} lies outside the {}x{} frame",
            frame.width, frame.height
        ));
    }
    if frame.frame_index == 0 {
        return Err("no frame has been rendered".into());
    }
    let plan = FramePlan::of(settings);
    let k = (y * frame.width + x) as usize;
    let g = frame.gbuf[k];
    let lights = world.lights.len();
    // `U` per light over the pixel's whole band, as the band pass computed
    // it: its light culling works per tile of the band.
    let width = frame.width as usize;
    let band_pixels = BAND_ROWS as usize * width;
    let band0 = k / band_pixels * band_pixels;
    let band = &frame.gbuf[band0..(band0 + band_pixels).min(frame.gbuf.len())];
    let mut band_lights = vec![Vec3::ZERO; band.len() * lights];
    let (mut u, mut share) = (vec![Vec3::ZERO; band.len()], vec![0.0; band.len()]);
    analytic_u_band(
        world,
        band,
        width,
        settings.light_tolerance,
        &mut band_lights,
        &mut u,
        &mut share,
    );
    let m = k - band0;
    let per_light = band_lights[m * lights..(m + 1) * lights].to_vec();
    let mut out = PixelReplay {
        x,
        y,
        g,
        per_light,
        draws: Vec::new(),
        note: None,
        frame_u: frame.u[k],
        frame_un: frame.un[k],
        frame_sn: frame.sn[k],
        frame_color: frame.color[k],
    };
    if g.kind != PixelKind::Surface {
        out.note = Some("not a receiver surface: no samples".into());
        return Ok(out);
    }
    let last = frame.frame_index.wrapping_sub(1);
    let spp = settings.spp;
    let Some(estimator) = plan.estimator else {
        out.note = Some(format!("{} draws no samples", settings.mode));
        return Ok(out);
    };
    if plan.reference {
        out.note = Some(
            "reference gives every sample its own jittered camera ray; replay ratio, \
             stochastic or soft-shadow instead"
                .into(),
        );
        return Ok(out);
    }
    let stream = |first: u32| SampleStream {
        pixel: k as u32,
        first,
        count: spp,
        seed: settings.seed,
    };
    let mut streams = Vec::new();
    match plan.rate {
        VisibilityRate::Full => {
            streams.push(("the frame's samples", stream(last.wrapping_mul(spp))));
        }
        VisibilityRate::Quarter => {
            let offset = QUAD_ORDER[(last % 4) as usize];
            // Clamped into the frame: an odd last row or column samples itself.
            let (sx, sy) = sampled_pixel(x / 2, y / 2, offset, frame.width, frame.height);
            if (sx, sy) == (x, y) {
                streams.push(("its quad's samples", stream((last / 4).wrapping_mul(spp))));
            }
            if frame.sampled_itself(k) {
                streams.push((
                    "its own samples (no quad vouched for it, or its lobe is too narrow)",
                    stream(last.wrapping_mul(spp)),
                ));
            }
            if streams.is_empty() {
                out.note = Some(format!(
                    "at the quarter rate this frame's samples of its quad were drawn at \
                     pixel ({sx}, {sy}); this pixel's ratio is upsampled from the quads around it"
                ));
            }
        }
    }
    for (why, s) in streams {
        let mut d = draw(
            world,
            &g,
            &out.per_light,
            u[m],
            estimator,
            s,
            settings.packet,
        );
        d.why = why;
        out.draws.push(d);
    }
    Ok(out)
}

fn draw(
    world: &World,
    g: &GSample,
    per_light: &[Vec3],
    u: Vec3,
    estimator: super::estimate::Estimator,
    stream: SampleStream,
    packet: super::shadow::PacketWidth,
) -> Draw {
    let (mut un, mut batch, mut samples) = (Vec3::ZERO, ShadowBatch::default(), Vec::new());
    super::estimate::draw_pixel_samples(
        world,
        g,
        per_light,
        u,
        estimator,
        stream,
        &mut SampleSink {
            un: &mut un,
            batch: &mut batch,
            slot: 0,
            trace: Some(&mut samples),
        },
    );
    // One slot per ray: the queued samples, in order.
    for (i, r) in batch.rays.iter_mut().enumerate() {
        r.slot = i as u32;
    }
    let mut reached = vec![false; batch.rays.len()];
    let mut sn = Vec3::ZERO;
    batch.trace(&world.rt, packet, |r| {
        reached[r.slot as usize] = true;
        sn += r.weight;
    });
    let mut rays = reached.into_iter();
    let visible = samples
        .iter()
        .map(|s| match s.dropped {
            None => rays.next(),
            Some(_) => None,
        })
        .collect();
    Draw {
        why: "",
        stream,
        samples,
        visible,
        un,
        sn,
    }
}

impl PixelReplay {
    /// The replay as text, one sample a line.
    pub fn report(&self, world: &World) -> String {
        let mut s = String::new();
        let v = |c: Vec3| format!("({:.6}, {:.6}, {:.6})", c.x, c.y, c.z);
        let g = &self.g;
        let _ = writeln!(s, "pixel ({}, {})", self.x, self.y);
        match g.kind {
            PixelKind::Surface => {
                let name = world
                    .scene
                    .materials
                    .get(g.material as usize)
                    .map_or("?", |m| m.name.as_str());
                let _ = writeln!(
                    s,
                    "  surface: material \"{name}\", depth {:.6}, position {}",
                    g.depth,
                    v(g.position)
                );
                let _ = writeln!(
                    s,
                    "  normals: shading {}, geometric {}; to eye {}",
                    v(g.ns),
                    v(g.ng),
                    v(g.wo)
                );
                let _ = writeln!(
                    s,
                    "  material: diffuse {}, specular {}, roughness {:.4}",
                    v(g.diffuse),
                    v(g.specular),
                    g.roughness
                );
            }
            PixelKind::Light => {
                let _ = writeln!(s, "  a light, emission {}", v(g.emission));
            }
            PixelKind::Miss => {
                let _ = writeln!(s, "  no hit");
            }
        }
        for (i, u) in self.per_light.iter().enumerate() {
            let _ = writeln!(s, "  U of light {i}: {}", v(*u));
        }
        if let Some(n) = &self.note {
            let _ = writeln!(s, "  {n}");
        }
        for d in &self.draws {
            let st = &d.stream;
            let _ = writeln!(
                s,
                "  {}: pixel index {}, samples {}..{}, seed {}",
                d.why,
                st.pixel,
                st.first,
                st.first.wrapping_add(st.count),
                st.seed
            );
            for (r, vis) in d.samples.iter().zip(&d.visible) {
                let strategy = match r.strategy {
                    Strategy::Light => "light",
                    Strategy::Brdf => "brdf",
                    Strategy::Area => "area",
                };
                let _ = write!(
                    s,
                    "    #{} light {} (p {:.4}), {strategy} (p_light {:.4}): wi {}, dist {:.5}, \
                     pdf light {:.6e} brdf {:.6e} mix {:.6e}, f {}, weight {}",
                    r.index,
                    r.light,
                    r.p_choose,
                    r.p_light_strategy,
                    v(r.wi),
                    r.dist,
                    r.pdf_light,
                    r.pdf_brdf,
                    r.pdf,
                    v(r.f),
                    v(r.weight)
                );
                let _ = match (r.dropped, vis) {
                    (Some(why), _) => writeln!(s, ": dropped, {why}"),
                    (None, Some(true)) => writeln!(s, ": visible"),
                    (None, _) => writeln!(s, ": occluded"),
                };
            }
            let _ = writeln!(
                s,
                "    U_N {}, S_N {}, S_N / U_N {}",
                v(d.un),
                v(d.sn),
                v(ratio(d.sn, d.un))
            );
        }
        let _ = writeln!(
            s,
            "  frame (denoised, upsampled as the plan says): U {}, U_N {}, S_N {}, colour {}",
            v(self.frame_u),
            v(self.frame_un),
            v(self.frame_sn),
            v(self.frame_color)
        );
        s
    }
}

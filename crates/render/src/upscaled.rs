//! A frame rendered below its output's size and brought to the output by
//! the temporal upscale (`denoise::upscale`): the viewer's dynamic
//! resolution and `render --render-scale`. Every stage of the frame runs at
//! the render size; only the upscale's history has the output's size, so a
//! change of render size keeps it.

use super::frame::{Frame, PhaseTimes};
use super::gbuffer::{GSample, PixelKind};
use super::plan::FramePlan;
use super::primary::trace_pixels;
use super::settings::RenderSettings;
use super::world::World;
use glam::{Vec2, Vec3};
use penumbra_denoise::{CameraMotion, DenoiseSettings, EdgeHit, ResolveSettings, Upscale};
use penumbra_scene::{Camera, Light};
use rayon::prelude::*;
use std::time::Instant;

/// The render size for an output of `width` x `height` at `scale` of each
/// side: at least 8 pixels a side (or the output's side, if smaller), at
/// most the output's.
pub fn scaled_size(width: u32, height: u32, scale: f32) -> (u32, u32) {
    let scale = if scale.is_finite() {
        scale.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let side = |n: u32| ((n as f32 * scale).round() as u32).clamp(8.min(n), n);
    (side(width), side(height))
}

/// Renders one frame of `camera` into `frame`, upscaled into `target`'s
/// output when there is one: the one step every caller (render, view,
/// bench) takes, whichever way it shows frames.
pub fn render_frame(
    frame: &mut Frame,
    target: Option<&mut Upscaled>,
    world: &World,
    camera: &Camera,
    settings: &RenderSettings,
) -> PhaseTimes {
    match target {
        Some(t) => t.render(frame, world, camera, settings),
        None => frame.render(world, camera, settings),
    }
}

/// The linear radiance shown: `target`'s output when there is one, else
/// the frame's. (After [`Upscaled::render_rows`], call
/// [`Upscaled::linear`] first.)
pub fn shown<'a>(frame: &'a Frame, target: Option<&'a Upscaled>) -> &'a [Vec3] {
    target.map_or(&frame.color, |t| &t.color)
}

/// The output side of an upscaled frame: the upscale's history and the
/// output's colour. The frame itself stays its owner's, at the render size.
pub struct Upscaled {
    upscale: Upscale,
    /// The output's linear radiance (after [`Upscaled::render`]).
    pub color: Vec<Vec3>,
    prev_camera: Option<Camera>,
    /// The previous frame's lights: new lights drop the output history as
    /// they drop the frame's.
    prev_lights: Vec<Light>,
    /// Seconds of the last frame's output pass (upscale and `emit`).
    pub upscale_seconds: f64,
    /// The output pixels traced at the output's resolution this frame
    /// (`Upscale::edge_pixels`), what their rays found, and that as the
    /// upscale reads it.
    edge_pixels: Vec<u32>,
    edge_samples: Vec<GSample>,
    edges: Vec<EdgeHit>,
}

impl Upscaled {
    /// An output of `width` x `height`.
    pub fn new(width: u32, height: u32) -> Upscaled {
        Upscaled {
            upscale: Upscale::new(width, height),
            color: vec![Vec3::ZERO; width as usize * height as usize],
            prev_camera: None,
            prev_lights: Vec::new(),
            upscale_seconds: 0.0,
            edge_pixels: Vec::new(),
            edge_samples: Vec::new(),
            edges: Vec::new(),
        }
    }

    pub fn output_size(&self) -> (u32, u32) {
        self.upscale.size()
    }

    /// Forgets the output history (the frame's is its own to drop).
    pub fn reset_history(&mut self) {
        self.upscale.reset();
        self.prev_camera = None;
    }

    /// Renders one frame of `camera` into `frame` (any size up to the
    /// output's; a new size keeps the output history) and upscales it into
    /// `color`. The upscale's time is added to the resolve's. Must run
    /// inside the rayon pool that should do the work.
    pub fn render(
        &mut self,
        frame: &mut Frame,
        world: &World,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> PhaseTimes {
        let mut color = std::mem::take(&mut self.color);
        let ow = self.output_size().0 as usize;
        let times = self.render_rows(
            frame,
            world,
            camera,
            settings,
            color.par_chunks_mut(ow.max(1)),
            |row: &mut &mut [Vec3], texels: &[Texel], _| {
                for (o, t) in row.iter_mut().zip(texels) {
                    *o = Vec3::new(t[0], t[1], t[2]);
                }
            },
        );
        self.color = color;
        times
    }

    /// [`Upscaled::render`], but each finished output row goes to `emit`
    /// (with the matching item of `rows`, and whether it may have changed:
    /// `Upscale::resolve_rows`) instead of `color`, in the same pass: the
    /// viewer's display transform. `color` is left as it was
    /// ([`Upscaled::linear`] fills it). `upscale_seconds` holds the time of
    /// the output pass, `emit` included.
    pub fn render_rows<R, E>(
        &mut self,
        frame: &mut Frame,
        world: &World,
        camera: &Camera,
        settings: &RenderSettings,
        rows: R,
        emit: E,
    ) -> PhaseTimes
    where
        R: IndexedParallelIterator,
        E: Fn(&mut R::Item, &[Texel], bool) + Sync,
    {
        let settings = RenderSettings {
            upscaled: true,
            ..*settings
        };
        if world.lights.declared() != self.prev_lights {
            self.upscale.reset();
            self.prev_lights = world.lights.declared().to_vec();
        }
        let mut times = frame.render(world, camera, &settings);
        let t = Instant::now();
        let motion = FramePlan::of(&settings).jitter.then(|| {
            if self.prev_camera == Some(*camera) {
                CameraMotion::Still
            } else {
                CameraMotion::Moved
            }
        });
        self.upscale_rows(frame, world, camera, frame.jitter, motion, rows, emit);
        self.prev_camera = Some(*camera);
        let upscale = t.elapsed().as_secs_f64();
        self.upscale_seconds = upscale;
        times.resolve += upscale;
        times.wall += upscale;
        times
    }

    /// The output pass alone, for `frame` rendered of `camera` with its
    /// rays through `jitter`: the camera rays at the output's resolution
    /// where the frame's taps mix surfaces, then the upscale, each finished
    /// row to `emit` (see [`Upscaled::render_rows`]).
    #[allow(clippy::too_many_arguments)]
    pub fn upscale_rows<R, E>(
        &mut self,
        frame: &Frame,
        world: &World,
        camera: &Camera,
        jitter: Vec2,
        motion: Option<CameraMotion>,
        rows: R,
        emit: E,
    ) where
        R: IndexedParallelIterator,
        E: Fn(&mut R::Item, &[Texel], bool) + Sync,
    {
        let surface = DenoiseSettings::default();
        let guides = frame.guides();
        self.upscale
            .edge_pixels(&guides, jitter, &mut self.edge_pixels);
        let (ow, oh) = self.upscale.size();
        let cam = camera.frame(ow, oh);
        let n = self.edge_pixels.len();
        self.edge_samples.resize(n, GSample::default());
        self.edge_samples
            .par_chunks_mut(EDGE_CHUNK)
            .zip(self.edge_pixels.par_chunks(EDGE_CHUNK))
            .for_each(|(out, pixels)| trace_pixels(world, &cam, pixels, out));
        self.edges.clear();
        self.edges.extend(
            self.edge_pixels
                .iter()
                .zip(&self.edge_samples)
                .map(|(&index, g)| match g.kind {
                    PixelKind::Surface => EdgeHit {
                        index,
                        depth: g.depth,
                        emission: Vec3::ZERO,
                    },
                    _ => EdgeHit {
                        index,
                        depth: 0.0,
                        emission: g.emission,
                    },
                }),
        );
        self.upscale.resolve_rows(
            &guides,
            &frame.color,
            jitter,
            motion,
            &ResolveSettings::default(),
            &surface,
            &self.edges,
            rows,
            emit,
        );
    }

    /// Output pixels whose camera rays were traced in the last frame.
    pub fn edge_count(&self) -> usize {
        self.edges.len()
    }

    /// The output's linear radiance after the last frame (whichever way it
    /// was rendered).
    pub fn linear(&mut self) -> &[Vec3] {
        self.upscale.color_into(&mut self.color);
        &self.color
    }
}

/// Edge pixels a worker traces at a time (16-ray packets).
const EDGE_CHUNK: usize = 256;

/// One output pixel's upscaled history: linear `r, g, b` and the samples
/// averaged.
pub type Texel = [f32; 4];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaled_sizes_stay_between_eight_pixels_and_the_output() {
        assert_eq!(scaled_size(1280, 720, 0.5), (640, 360));
        assert_eq!(scaled_size(1280, 720, 1.0), (1280, 720));
        assert_eq!(scaled_size(1280, 720, 0.001), (8, 8));
        assert_eq!(scaled_size(4, 720, 0.5), (4, 360));
        assert_eq!(scaled_size(1280, 720, f32::NAN), (1280, 720));
        assert_eq!(scaled_size(1280, 720, 7.0), (1280, 720));
    }
}

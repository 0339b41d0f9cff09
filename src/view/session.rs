//! The viewer's state between frames, apart from the window itself: what is
//! rendered (settings, camera, frame buffers), what is shown (window pixels,
//! overlay), and the figures of the frames so far.

use super::controls::Flyer;
use super::input::{Action, FrameInput};
use super::overlay::{self, FrameTiming, Readout};
use super::present;
use super::scale::{DynamicScale, FrameCost};
use crate::display::DisplayMap;
use crate::render::{Frame, FramePlan, Mode, PhaseTimes, RenderSettings, Upscaled, World};
use crate::scene::Camera;
use glam::Vec3;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Look sensitivity: radians per pixel dragged, and per second of arrow key.
const DRAG_RADIANS: f32 = 0.005;
const ARROW_RADIANS: f32 = 1.5;
/// Speed steps (scroll notch, +/-) and the samples-per-frame range.
const SPEED_STEP: f32 = 1.25;
const MAX_SPP: u32 = 256;
/// How long a status message stays in the overlay.
const STATUS_FOR: Duration = Duration::from_secs(4);

pub struct Session {
    pub settings: RenderSettings,
    pub flyer: Flyer,
    /// The frame at the render size.
    pub frame: Frame,
    /// Under a target frame rate: the output at the window's size, which
    /// the frame is upscaled to (`None`: the frame is the window's size).
    pub upscaled: Option<Upscaled>,
    /// The window's pixels, 0RGB, the shown size (see `shown_size`).
    pub pixels: Vec<u32>,
    /// The display transform at the session's exposure.
    display: DisplayMap,
    pub overlay: bool,
    help: bool,
    /// `reference`: samples per pixel accumulated on the current view.
    accumulated: u32,
    last_camera: Option<Camera>,
    status: Option<(String, Instant)>,
    /// Every shown frame's figures, for the closing summary.
    pub timings: Vec<FrameTiming>,
    smoothed: FrameTiming,
    /// Pixels that came out of the renderer non-finite (shown black).
    pub non_finite: u64,
    /// The window's size; the frame's is this, or its dynamic scale.
    window: (u32, u32),
    /// Holds a target frame rate by the render resolution (`--target-fps`).
    pub dynamic: Option<DynamicScale>,
    /// The last frame's fused upscale and display transform, in seconds
    /// (0 when the frame is the window's size: `compose` transforms it).
    output_pass: f64,
    /// Whether the last frame's camera differs from the one before.
    moved: bool,
    /// The window pixels hold the upscale's last output but for the rows
    /// the overlay drew over (`overlay_rows`): rows the upscale did not
    /// change need no display transform.
    fresh: bool,
    overlay_rows: std::ops::Range<usize>,
}

impl Session {
    pub fn new(
        settings: RenderSettings,
        camera: &Camera,
        width: u32,
        height: u32,
        exposure: f32,
        overlay: bool,
    ) -> Session {
        let frame = Frame::new(width, height);
        Session {
            settings,
            flyer: Flyer::from_camera(camera),
            pixels: vec![0; frame.pixel_count()],
            frame,
            upscaled: None,
            display: DisplayMap::new(exposure.exp2()),
            overlay,
            help: false,
            accumulated: 0,
            last_camera: None,
            status: None,
            timings: Vec::new(),
            smoothed: FrameTiming::default(),
            non_finite: 0,
            window: (width, height),
            dynamic: None,
            output_pass: 0.0,
            moved: false,
            fresh: false,
            overlay_rows: 0..0,
        }
    }

    /// Holds `dynamic`'s frame rate from now on: the frame is rendered at
    /// its scale of the window and upscaled to the window's size.
    pub fn hold(&mut self, dynamic: DynamicScale) {
        let (w, h) = self.window;
        self.dynamic = Some(dynamic);
        self.upscaled = Some(Upscaled::new(w, h));
        let (rw, rh) = self.render_size();
        self.resize(rw, rh);
        self.fit_pixels();
    }

    /// The window changed size: render at its new size (or its scale).
    /// A size the renderer refuses (e.g. a minimised window) is ignored.
    pub fn resize_window(&mut self, width: u32, height: u32) -> bool {
        if (width, height) == self.window || crate::scene::check_resolution(width, height).is_err()
        {
            return false;
        }
        self.window = (width, height);
        if let Some(u) = self.upscaled.as_mut() {
            *u = Upscaled::new(width, height);
        }
        let (w, h) = self.render_size();
        self.resize(w, h);
        self.fit_pixels();
        true
    }

    /// Sizes the window pixels to what is shown.
    fn fit_pixels(&mut self) {
        let (w, h) = self.shown_size();
        let n = w as usize * h as usize;
        if self.pixels.len() != n {
            self.pixels = vec![0; n];
            self.fresh = false;
        }
    }

    /// Takes the last recorded frame's figures; under a target frame rate,
    /// rescales the render when the controller says so.
    pub fn hold_frame_rate(&mut self) {
        let Some(t) = self.timings.last() else {
            return;
        };
        let cost = FrameCost {
            total: t.total,
            output: t.output,
            moving: self.moved,
        };
        if self.dynamic.as_mut().is_some_and(|d| d.observe(cost)) {
            let (w, h) = self.render_size();
            self.resize(w, h);
        }
    }

    fn render_size(&self) -> (u32, u32) {
        let (w, h) = self.window;
        self.dynamic.as_ref().map_or((w, h), |d| d.size(w, h))
    }

    /// The render size.
    pub fn size(&self) -> (u32, u32) {
        (self.frame.width, self.frame.height)
    }

    /// The size of what is shown: the window's under a target frame rate,
    /// else the frame's.
    pub fn shown_size(&self) -> (u32, u32) {
        self.upscaled
            .as_ref()
            .map_or(self.size(), Upscaled::output_size)
    }

    /// The linear radiance shown, at `shown_size`.
    pub fn shown(&mut self) -> &[Vec3] {
        match self.upscaled.as_mut() {
            Some(u) => u.linear(),
            None => &self.frame.color,
        }
    }

    /// Carries out a command. Returns `false` for `Quit`. A screenshot
    /// request is left to the caller, who knows what was shown.
    pub fn apply(&mut self, action: Action) -> bool {
        match action {
            Action::Mode(m) if m != self.settings.mode => {
                self.settings.mode = m;
                self.reset();
            }
            Action::Mode(_) => {}
            Action::ToggleDenoise => {
                self.settings.denoise = !self.settings.denoise;
                // The history was not kept up while off: start it afresh.
                self.reset();
            }
            Action::ToggleTaa => {
                self.settings.taa = !self.settings.taa;
                // A resolve history built from unjittered frames (or the
                // reverse) is not the box filter: start it afresh.
                self.reset();
            }
            Action::CycleVisibility => {
                // The frame drops the denoiser's history itself (it was
                // built at the other rate).
                self.settings.visibility = self.settings.visibility.next();
            }
            Action::FewerSamples => self.settings.spp = (self.settings.spp / 2).max(1),
            Action::MoreSamples => self.settings.spp = (self.settings.spp * 2).min(MAX_SPP),
            Action::Faster => self.flyer.speed = (self.flyer.speed * SPEED_STEP).min(1e4),
            Action::Slower => self.flyer.speed = (self.flyer.speed / SPEED_STEP).max(1e-3),
            Action::Reset => self.reset(),
            Action::Help => self.help = !self.help,
            Action::Overlay => self.overlay = !self.overlay,
            Action::Screenshot => {}
            Action::Quit => return false,
        }
        true
    }

    /// Restarts temporal history and `reference` accumulation.
    fn reset(&mut self) {
        self.frame.reset_history();
        if let Some(u) = self.upscaled.as_mut() {
            u.reset_history();
        }
        self.accumulated = 0;
    }

    /// Moves and turns the camera by this frame's held keys and drag.
    pub fn steer(&mut self, input: &FrameInput, dt: f32) {
        let (right, up, forward) = input.travel();
        self.flyer.travel(right, up, forward, dt);
        let (yaw, pitch) = input.turn();
        self.flyer.look(
            yaw * dt * ARROW_RADIANS + input.drag.0 * DRAG_RADIANS,
            pitch * dt * ARROW_RADIANS - input.drag.1 * DRAG_RADIANS,
        );
    }

    /// Re-allocates the frame state for a new render size (its history
    /// starts afresh; an upscaled output's is kept). A size the renderer
    /// refuses (e.g. a minimised window) is ignored.
    pub fn resize(&mut self, width: u32, height: u32) -> bool {
        if (width, height) == self.size() || crate::scene::check_resolution(width, height).is_err()
        {
            return false;
        }
        self.frame = Frame::new(width, height);
        self.fit_pixels();
        self.accumulated = 0;
        self.last_camera = None;
        true
    }

    /// Renders one frame of the current camera. Must run inside the rayon
    /// pool that should do the work.
    pub fn render(&mut self, world: &World) -> PhaseTimes {
        let camera = self.flyer.camera();
        if self.settings.mode == Mode::Reference {
            // The same rule as the frame's: a moved camera restarts the sum.
            if self.last_camera.is_some_and(|c| c != camera) {
                self.accumulated = 0;
            }
            self.accumulated += self.settings.spp;
        }
        self.moved = self.last_camera != Some(camera);
        self.last_camera = Some(camera);
        let Some(up) = self.upscaled.as_mut() else {
            self.output_pass = 0.0;
            return self.frame.render(world, &camera, &self.settings);
        };
        // The upscale hands each finished row to the display transform:
        // one pass over the window's pixels, and none over rows that kept
        // their pixels.
        let (w, _) = up.output_size();
        let map = &self.display;
        let (fresh, overlay) = (self.fresh, self.overlay_rows.clone());
        let times = up.render_rows(
            &mut self.frame,
            world,
            &camera,
            &self.settings,
            self.pixels.par_chunks_mut(w as usize).enumerate(),
            |(y, row): &mut (usize, &mut [u32]), texels: &[[f32; 4]], changed: bool| {
                if changed || !fresh || overlay.contains(y) {
                    map.row(texels, row);
                }
            },
        );
        self.fresh = true;
        self.output_pass = up.upscale_seconds;
        times
    }

    /// Tonemaps the frame into the window pixels (unless the upscale did)
    /// and draws the overlay. Must run inside the rayon pool.
    pub fn compose(&mut self) {
        // The upscale replaces non-finite samples by 0 before averaging, so
        // only a frame at the window's size can show any.
        if self.upscaled.is_none() {
            let bad = present::to_display(&self.frame.color, &self.display, &mut self.pixels);
            if bad > 0 && self.non_finite == 0 {
                eprintln!(
                    "penumbra: the renderer produced non-finite pixels; they are shown black"
                );
            }
            self.non_finite += bad as u64;
        }
        self.overlay_rows = 0..0;
        if self.overlay {
            let lines = self.readout().lines();
            let (w, h) = self.shown_size();
            let (_, y, _, bh) = overlay::draw(&mut self.pixels, w as usize, h as usize, &lines);
            self.overlay_rows = y..y + bh;
        }
    }

    /// Records a shown frame's figures: `present` is the overlay, the
    /// display transform when the upscale did not fuse it, and the copy to
    /// the window.
    pub fn record(&mut self, times: &PhaseTimes, present: f64, total: f64) {
        let primary = self.frame.pixel_count() as u64
            * match self.settings.mode {
                Mode::Reference => self.settings.spp as u64,
                _ => 1,
            };
        let (ow, oh) = self.shown_size();
        let t = FrameTiming {
            render: (times.wall - times.denoise - self.output_pass).max(0.0),
            denoise: times.denoise,
            output: self.output_pass + present,
            upscale: self.output_pass,
            total,
            rays: primary + times.shadow_rays,
            scale: self.dynamic.as_ref().map_or(1.0, |d| d.scale()),
            output_pixels: ow as u64 * oh as u64,
        };
        self.timings.push(t);
        // An exponential average keeps the numbers readable while moving.
        let s = &mut self.smoothed;
        if self.timings.len() == 1 {
            *s = t;
        } else {
            let a = 0.2;
            s.render += a * (t.render - s.render);
            s.denoise += a * (t.denoise - s.denoise);
            s.output += a * (t.output - s.output);
            s.upscale += a * (t.upscale - s.upscale);
            s.total += a * (t.total - s.total);
            s.rays = t.rays;
            s.scale = t.scale;
            s.output_pixels = t.output_pixels;
        }
    }

    pub fn set_status(&mut self, message: String) {
        self.status = Some((message, Instant::now()));
    }

    pub fn readout(&self) -> Readout {
        let mode = self.settings.mode;
        let uses_denoiser = matches!(mode, Mode::Ratio | Mode::Stochastic | Mode::SoftShadow);
        let (width, height) = self.size();
        Readout {
            mode,
            denoise: uses_denoiser.then_some(self.settings.denoise),
            taa: (mode != Mode::Reference).then_some(self.settings.taa),
            visibility: FramePlan::of(&self.settings)
                .denoise
                .then_some(self.settings.visibility),
            scale: self.dynamic.as_ref().map(|d| d.scale()),
            spp: self.settings.spp,
            accumulated: (mode == Mode::Reference).then_some(self.accumulated),
            width,
            height,
            timing: self.smoothed,
            speed: self.flyer.speed,
            status: self
                .status
                .as_ref()
                .filter(|(_, at)| at.elapsed() < STATUS_FOR)
                .map(|(s, _)| s.clone()),
            help: self.help,
        }
    }

    /// One line for stderr: medians over the shown frames after the first
    /// (which pays for warm-up).
    pub fn summary(&self) -> String {
        let frames = if self.timings.len() > 1 {
            &self.timings[1..]
        } else {
            &self.timings[..]
        };
        let median = |f: &dyn Fn(&FrameTiming) -> f64| {
            let mut v: Vec<f64> = frames.iter().map(f).collect();
            v.sort_by(f64::total_cmp);
            v.get(v.len() / 2).copied().unwrap_or(0.0)
        };
        let total = median(&|t| t.total);
        let output = median(&|t| t.output);
        let (w, h) = self.shown_size();
        let (rw, rh) = self.size();
        let scale = match &self.dynamic {
            Some(d) => format!(
                "target {:.0} fps, settled at scale {:.0}% ({rw}x{rh})",
                d.target_fps(),
                d.scale() * 100.0
            ),
            None => "no target (full size)".to_string(),
        };
        let pixels = w as f64 * h as f64;
        format!(
            "penumbra view: {} frames at {w}x{h}, {} mode, last spp {}, {scale}; median of {} \
             frames: frame {:.1} ms ({:.2} fps), render {:.1} ms, denoise {:.1} ms, output {:.1} \
             ms ({:.1} ns/px; upscale+display {:.1} ms, overlay+copy {:.1} ms), {:.2} Mrays/s; \
             non-finite pixels shown black: {}",
            self.timings.len(),
            self.settings.mode,
            self.settings.spp,
            frames.len(),
            total * 1e3,
            if total > 0.0 { 1.0 / total } else { 0.0 },
            median(&|t| t.render) * 1e3,
            median(&|t| t.denoise) * 1e3,
            output * 1e3,
            output * 1e9 / pixels.max(1.0),
            median(&|t| t.upscale) * 1e3,
            median(&|t| t.output - t.upscale) * 1e3,
            median(&|t| t.mrays_per_s()),
            self.non_finite
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn session() -> Session {
        let camera = Camera {
            eye: Vec3::new(0.0, 1.0, -5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: 40.0,
        };
        Session::new(RenderSettings::default(), &camera, 32, 18, 0.0, true)
    }

    #[test]
    fn brackets_halve_and_double_samples_within_bounds() {
        let mut s = session();
        s.apply(Action::FewerSamples);
        assert_eq!(s.settings.spp, 1);
        for _ in 0..20 {
            s.apply(Action::MoreSamples);
        }
        assert_eq!(s.settings.spp, MAX_SPP);
    }

    #[test]
    fn speed_steps_up_and_down_by_the_same_factor() {
        let mut s = session();
        let v = s.flyer.speed;
        s.apply(Action::Faster);
        assert!((s.flyer.speed / v - SPEED_STEP).abs() < 1e-6);
        s.apply(Action::Slower);
        assert!((s.flyer.speed / v - 1.0).abs() < 1e-6);
    }

    #[test]
    fn toggles_flip_denoiser_taa_help_and_overlay_and_quit_stops() {
        let mut s = session();
        assert!(s.settings.denoise && s.overlay && !s.help);
        s.apply(Action::ToggleDenoise);
        s.apply(Action::Help);
        s.apply(Action::Overlay);
        assert!(!s.settings.denoise && !s.overlay && s.help);
        let taa = s.settings.taa;
        s.apply(Action::ToggleTaa);
        assert_eq!(s.settings.taa, !taa);
        assert!(s.apply(Action::Mode(Mode::SoftShadow)));
        assert_eq!(s.settings.mode, Mode::SoftShadow);
        assert!(!s.apply(Action::Quit));
    }

    #[test]
    fn resizing_reallocates_frame_and_window_pixels() {
        let mut s = session();
        assert!(s.resize(64, 36));
        assert_eq!(s.size(), (64, 36));
        assert_eq!(s.frame.color.len(), 64 * 36);
        assert_eq!(s.pixels.len(), 64 * 36);
        assert!(
            !s.resize(0, 36),
            "a zero-sized (minimised) window is ignored"
        );
        assert_eq!(s.size(), (64, 36));
    }

    #[test]
    fn dragging_right_turns_the_view_right() {
        let mut s = session();
        let before = s.flyer.forward();
        let input = FrameInput {
            drag: (40.0, 0.0),
            ..FrameInput::default()
        };
        s.steer(&input, 1.0 / 30.0);
        let after = s.flyer.forward();
        let right = before.cross(Vec3::Y);
        assert!(after.dot(right) > 0.1, "{before} -> {after}");
    }
}

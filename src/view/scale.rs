//! Dynamic resolution: the viewer renders at a fraction of the window's
//! size, chosen from a short ladder to hold a target frame rate, and the
//! frame is upscaled to the window's size (`render::upscaled`), whose
//! history accumulates the jittered samples of every scale at the window's
//! pixels: a still camera converges to the full-size image at any step.
//!
//! The controller models a frame as a part at the window's size (the
//! output pass: upscale, display transform, overlay, copy to the window;
//! measured each frame) plus a part that grows with the render's pixels,
//! i.e. with the square of the scale. From the smoothed frame it predicts
//! each step's time, so a frame rate far off the target is fixed in one
//! jump, not one step every few frames.
//!
//! - Down: while the smoothed frame is over the target for `DOWN_AFTER`
//!   frames (moving or not), to the largest step predicted to fit.
//! - Up: only while the camera is still (a move starts the count again),
//!   one step after `UP_AFTER` still frames, when that step is predicted
//!   to fit with room (`UP_FIT`). A still camera is cheaper (settled tiles
//!   draw no shadow rays, nothing is reprojected), so the scale rises when
//!   the camera stops and falls back when it moves again.
//!
//! The first frame after a change pays for allocation and is not judged.

/// Scales of the window's width and height, largest first.
pub const LADDER: [f32; 9] = [1.0, 0.85, 0.7, 0.6, 0.5, 0.42, 0.35, 0.3, 0.25];
/// The step the viewer starts at: cheap enough to show the first frames
/// quickly at any size, from where one jump finds the right step.
const START: usize = 4;
/// Frames over the target before stepping down.
const DOWN_AFTER: u32 = 2;
/// Still frames before stepping up.
const UP_AFTER: u32 = 8;
/// Over the target above this fraction of its frame time.
const OVER: f64 = 1.05;
/// A step fits when predicted within this fraction of the target (down),
/// and within the second to step up (room for noise: one step up costs
/// about 1.2x to 1.45x the render part).
const FIT: f64 = 0.95;
const UP_FIT: f64 = 0.85;
/// Weight of a new frame in the smoothed figures.
const SMOOTHING: f64 = 0.5;

/// The figures of one shown frame the controller reads.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameCost {
    /// The whole frame, in seconds.
    pub total: f64,
    /// Its part at the window's size (the output pass), in seconds.
    pub output: f64,
    /// Whether the camera moved since the frame before.
    pub moving: bool,
}

#[derive(Debug, Clone)]
pub struct DynamicScale {
    target_seconds: f64,
    step: usize,
    /// Frames at this step (judged ones), and still ones since the last
    /// move or change.
    since_change: u32,
    still: u32,
    /// Smoothed frame time and output part at this step.
    smoothed: Option<(f64, f64)>,
}

impl DynamicScale {
    /// `None` unless `fps` is a positive, finite rate.
    pub fn new(fps: f32) -> Option<DynamicScale> {
        (fps.is_finite() && fps > 0.0).then(|| DynamicScale {
            target_seconds: 1.0 / fps as f64,
            step: START,
            since_change: 0,
            still: 0,
            smoothed: None,
        })
    }

    pub fn target_fps(&self) -> f64 {
        1.0 / self.target_seconds
    }

    pub fn scale(&self) -> f32 {
        LADDER[self.step]
    }

    /// The render size for a window of `width` x `height`: the scale of
    /// each side, at least 8 pixels.
    pub fn size(&self, width: u32, height: u32) -> (u32, u32) {
        crate::render::scaled_size(width, height, self.scale())
    }

    /// The time the smoothed frame would take at step `to`.
    fn predict(&self, (total, output): (f64, f64), to: usize) -> f64 {
        let ratio = (LADDER[to] / LADDER[self.step]) as f64;
        output + (total - output).max(0.0) * ratio * ratio
    }

    /// Takes a shown frame's figures; returns true when the scale changed.
    pub fn observe(&mut self, frame: FrameCost) -> bool {
        let FrameCost {
            total,
            output,
            moving,
        } = frame;
        self.still = if moving { 0 } else { self.still + 1 };
        if !(total.is_finite() && total > 0.0 && output.is_finite()) {
            return false;
        }
        self.since_change += 1;
        if self.since_change == 1 {
            // The first frame at a step pays for allocation.
            return false;
        }
        let output = output.clamp(0.0, total);
        let s = match self.smoothed {
            Some((t, o)) => (t + SMOOTHING * (total - t), o + SMOOTHING * (output - o)),
            None => (total, output),
        };
        self.smoothed = Some(s);
        let judged = self.since_change - 1;
        let target = self.target_seconds;
        let next = if s.0 > target * OVER && judged >= DOWN_AFTER {
            // The largest step predicted to fit, at least one down.
            (self.step + 1..LADDER.len())
                .find(|&k| self.predict(s, k) <= target * FIT)
                .unwrap_or(LADDER.len() - 1)
        } else if self.step > 0
            && self.still >= UP_AFTER
            && judged >= UP_AFTER
            && self.predict(s, self.step - 1) <= target * UP_FIT
        {
            self.step - 1
        } else {
            return false;
        };
        if next == self.step {
            return false;
        }
        self.step = next;
        self.since_change = 0;
        self.smoothed = None;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic machine: `output` seconds at the window's size and
    /// `full` seconds for a full-size render, scaling with the pixels.
    fn cost(d: &DynamicScale, output: f64, full: f64, moving: bool) -> FrameCost {
        let s = d.scale() as f64;
        FrameCost {
            total: output + full * s * s,
            output,
            moving,
        }
    }

    /// Runs `frames` frames; returns the scales after each.
    fn run(d: &mut DynamicScale, frames: usize, full: f64, moving: bool) -> Vec<f32> {
        (0..frames)
            .map(|_| {
                let c = cost(d, 0.003, full, moving);
                d.observe(c);
                d.scale()
            })
            .collect()
    }

    #[test]
    fn a_slow_moving_frame_jumps_down_to_the_step_that_fits() {
        // 1280x720 on two cores: ~400 ms a full-size frame, 3 ms output.
        let mut d = DynamicScale::new(30.0).expect("valid rate");
        let scales = run(&mut d, 4, 0.4, true);
        // Frame 0 is not judged, frames 1 and 2 are over: down after
        // frame 2, straight to the step whose prediction fits 33 ms: 0.25
        // (0.3 would take 3 + 36 ms).
        assert_eq!(scales, [0.5, 0.5, 0.25, 0.25]);
        // Moving, it never steps up, however cheap the frames get.
        assert!(run(&mut d, 50, 0.01, true).iter().all(|&s| s == 0.25));
    }

    #[test]
    fn a_still_camera_steps_back_up_and_a_move_steps_down_again() {
        let mut d = DynamicScale::new(30.0).expect("valid rate");
        run(&mut d, 4, 0.4, true);
        assert_eq!(d.scale(), 0.25);
        // Still: settled tiles make the frame cheaper (200 ms full size).
        // Up one step every UP_AFTER + 1 frames while the next step is
        // predicted within 85 % of 33 ms: 0.3 (21 ms), 0.35 (27.5 ms);
        // 0.42 would take 38 ms.
        let scales = run(&mut d, 60, 0.2, false);
        assert_eq!(scales[UP_AFTER as usize - 2], 0.25);
        assert_eq!(scales[UP_AFTER as usize - 1], 0.3);
        assert_eq!(*scales.last().unwrap(), 0.35);
        let mut steps = scales.clone();
        steps.dedup();
        assert_eq!(steps, [0.25, 0.3, 0.35], "one step at a time, up only");
        // Moving again: 3 + 400 * 0.35^2 = 52 ms, over: back to 0.25.
        let scales = run(&mut d, 4, 0.4, true);
        assert_eq!(*scales.last().unwrap(), 0.25);
    }

    #[test]
    fn a_fast_machine_climbs_to_full_size_when_still() {
        let mut d = DynamicScale::new(30.0).expect("valid rate");
        let scales = run(&mut d, 100, 0.01, false);
        assert_eq!(*scales.last().unwrap(), 1.0);
    }

    #[test]
    fn the_scale_never_leaves_the_ladder() {
        let mut d = DynamicScale::new(1000.0).expect("valid rate");
        for _ in 0..1000 {
            d.observe(FrameCost {
                total: 1.0,
                output: 0.5,
                moving: true,
            });
        }
        assert_eq!(d.scale(), *LADDER.last().unwrap());
        assert_eq!(d.size(1280, 720), (320, 180));
        assert_eq!(d.size(4, 4), (4, 4));
    }

    #[test]
    fn rates_that_are_not_positive_and_finite_are_refused() {
        for fps in [0.0, -5.0, f32::NAN, f32::INFINITY] {
            assert!(DynamicScale::new(fps).is_none(), "{fps}");
        }
    }

    #[test]
    fn a_frame_time_that_is_not_finite_changes_nothing() {
        let mut d = DynamicScale::new(30.0).expect("valid rate");
        for total in [f64::NAN, f64::INFINITY, -1.0, 0.0] {
            for _ in 0..100 {
                assert!(!d.observe(FrameCost {
                    total,
                    output: 0.001,
                    moving: false,
                }));
            }
        }
        assert_eq!(d.scale(), LADDER[START]);
    }
}

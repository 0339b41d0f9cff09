//! Dynamic resolution: the viewer renders at a fraction of the window's
//! size, chosen from a short ladder to hold a target frame rate, and the
//! frame is upscaled to the window's size (`render::upscaled`).
//!
//! Each change of scale starts the frame's histories afresh (they describe
//! other pixels; the upscaled output's is kept), so the controller changes
//! seldom: down as soon as a few frames are clearly over budget, up only
//! after many frames well under it.

/// Scales of the window's width and height, largest first.
pub const LADDER: [f32; 9] = [1.0, 0.85, 0.7, 0.6, 0.5, 0.42, 0.35, 0.3, 0.25];
/// Frames between changes: down, and (longer) up.
const DOWN_AFTER: u32 = 6;
const UP_AFTER: u32 = 30;
/// Over budget above this fraction of the target frame time; room to grow
/// below the second (one step up costs about 1 / 0.85^2 = 1.4x the time).
const OVER: f64 = 1.05;
const UNDER: f64 = 0.6;
/// Weight of a new frame in the smoothed frame time.
const SMOOTHING: f64 = 0.3;

#[derive(Debug, Clone)]
pub struct DynamicScale {
    target_seconds: f64,
    step: usize,
    since_change: u32,
    smoothed: Option<f64>,
}

impl DynamicScale {
    /// `None` unless `fps` is a positive, finite rate.
    pub fn new(fps: f32) -> Option<DynamicScale> {
        (fps.is_finite() && fps > 0.0).then(|| DynamicScale {
            target_seconds: 1.0 / fps as f64,
            step: 0,
            since_change: 0,
            smoothed: None,
        })
    }

    pub fn scale(&self) -> f32 {
        LADDER[self.step]
    }

    /// The render size for a window of `width` x `height`: the scale of
    /// each side, at least 8 pixels.
    pub fn size(&self, width: u32, height: u32) -> (u32, u32) {
        crate::render::scaled_size(width, height, self.scale())
    }

    /// Takes a shown frame's time; returns true when the scale changed.
    pub fn observe(&mut self, frame_seconds: f64) -> bool {
        if !(frame_seconds.is_finite() && frame_seconds > 0.0) {
            return false;
        }
        let s = match self.smoothed {
            Some(s) => s + SMOOTHING * (frame_seconds - s),
            None => frame_seconds,
        };
        self.smoothed = Some(s);
        self.since_change += 1;
        let over = s > self.target_seconds * OVER;
        let under = s < self.target_seconds * UNDER;
        let next = if over && self.since_change >= DOWN_AFTER && self.step + 1 < LADDER.len() {
            self.step + 1
        } else if under && self.since_change >= UP_AFTER && self.step > 0 {
            self.step - 1
        } else {
            return false;
        };
        // The next frame at the new size pays for allocation: judge the
        // new scale from frames after it, not from the smoothed old ones.
        self.step = next;
        self.since_change = 0;
        self.smoothed = None;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_slow_frame_rate_steps_the_scale_down_after_a_few_frames() {
        let mut d = DynamicScale::new(30.0).expect("valid rate");
        let changed: Vec<bool> = (0..DOWN_AFTER).map(|_| d.observe(0.1)).collect();
        assert_eq!(changed.iter().filter(|c| **c).count(), 1);
        assert_eq!(d.scale(), LADDER[1]);
    }

    #[test]
    fn a_fast_frame_rate_steps_back_up_only_after_many_frames() {
        let mut d = DynamicScale::new(30.0).expect("valid rate");
        for _ in 0..DOWN_AFTER {
            d.observe(0.1);
        }
        for _ in 0..UP_AFTER - 1 {
            assert!(!d.observe(0.001));
        }
        assert!(d.observe(0.001));
        assert_eq!(d.scale(), 1.0);
    }

    #[test]
    fn the_scale_never_leaves_the_ladder() {
        let mut d = DynamicScale::new(1000.0).expect("valid rate");
        for _ in 0..1000 {
            d.observe(1.0);
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
        for _ in 0..100 {
            assert!(!d.observe(f64::NAN));
        }
        assert_eq!(d.scale(), 1.0);
    }
}

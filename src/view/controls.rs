//! Camera flying: WASD + Q/E move, mouse drag or arrow keys look.

use crate::scene::Camera;
use glam::Vec3;

/// Yaw/pitch flight state derived from a scene camera.
#[derive(Debug, Clone, Copy)]
pub struct Flyer {
    pub eye: Vec3,
    yaw: f32,
    pitch: f32,
    /// Distance kept from eye to target, so the camera's target stays meaningful.
    focus: f32,
    pub fov_y: f32,
    /// Scene units per second.
    pub speed: f32,
    /// The scene's camera, shown exactly until the user first moves.
    start: Option<Camera>,
}

impl Flyer {
    pub fn from_camera(c: &Camera) -> Flyer {
        let d = c.target - c.eye;
        let focus = d.length().max(1e-3);
        let f = d / focus;
        Flyer {
            eye: c.eye,
            yaw: f.x.atan2(f.z),
            pitch: f.y.clamp(-1.0, 1.0).asin(),
            focus,
            fov_y: c.fov_y,
            speed: focus * 0.5,
            start: Some(*c),
        }
    }

    pub fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(sy * cp, sp, cy * cp)
    }

    pub fn camera(&self) -> Camera {
        if let Some(c) = self.start {
            return c;
        }
        Camera {
            eye: self.eye,
            target: self.eye + self.forward() * self.focus,
            up: Vec3::Y,
            fov_y: self.fov_y,
        }
    }

    /// Moves by (right, up, forward) in camera axes, scaled by speed and dt.
    pub fn travel(&mut self, right: f32, up: f32, forward: f32, dt: f32) {
        if right == 0.0 && up == 0.0 && forward == 0.0 {
            return;
        }
        self.start = None;
        let f = self.forward();
        let r = f.cross(Vec3::Y).normalize_or(Vec3::X);
        self.eye += (r * right + Vec3::Y * up + f * forward) * self.speed * dt;
    }

    /// Turns by angles in radians; pitch stays short of the poles so the
    /// camera's up vector is never parallel to the view.
    pub fn look(&mut self, d_yaw: f32, d_pitch: f32) {
        if d_yaw == 0.0 && d_pitch == 0.0 {
            return;
        }
        self.start = None;
        self.yaw -= d_yaw;
        self.pitch = (self.pitch + d_pitch).clamp(-1.5, 1.5);
    }
}

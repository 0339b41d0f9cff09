use glam::Vec3;

/// Pinhole camera exactly as docs/scene-format.md defines it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Full vertical field of view in degrees, in (0, 180).
    pub fov_y: f32,
}

/// The camera's orthonormal frame and image-plane scale, precomputed once a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraFrame {
    pub eye: Vec3,
    pub forward: Vec3,
    pub right: Vec3,
    pub up: Vec3,
    /// tan(fov_y / 2)
    pub tan_half: f32,
    pub aspect: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// The camera with its eye turned about the target by `degrees` around
    /// the `up` axis through the target (right-hand rule: positive turns
    /// counter-clockwise seen from above). Target, up and field of view are
    /// kept, and so is the eye's distance to the target, so an orbit keeps
    /// the subject framed; `render --orbit` uses it once per frame.
    pub fn orbit(&self, degrees: f32) -> Camera {
        let axis = self.up.normalize();
        let turn = glam::Quat::from_axis_angle(axis, degrees.to_radians());
        Camera {
            eye: self.target + turn * (self.eye - self.target),
            ..*self
        }
    }

    pub fn frame(&self, width: u32, height: u32) -> CameraFrame {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        CameraFrame {
            eye: self.eye,
            forward,
            right,
            up,
            tan_half: (self.fov_y.to_radians() * 0.5).tan(),
            aspect: width as f32 / height as f32,
            width,
            height,
        }
    }
}

impl CameraFrame {
    /// Unit direction of the ray through pixel (i, j) at sub-pixel offset
    /// (sx, sy) in [0,1)^2; row 0 is the top row.
    #[inline]
    pub fn ray_dir(&self, i: u32, j: u32, sx: f32, sy: f32) -> Vec3 {
        let x = (2.0 * (i as f32 + sx) / self.width as f32 - 1.0) * self.tan_half * self.aspect;
        let y = (1.0 - 2.0 * (j as f32 + sy) / self.height as f32) * self.tan_half;
        (self.forward + x * self.right + y * self.up).normalize()
    }

    /// Continuous pixel coordinates (i + sx, j + sy) where a world point
    /// projects, or `None` behind the eye. Inverse of `ray_dir`; used for
    /// motion vectors.
    #[inline]
    pub fn project(&self, p: Vec3) -> Option<(f32, f32)> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        if z <= 1e-6 {
            return None;
        }
        let x = d.dot(self.right) / z;
        let y = d.dot(self.up) / z;
        let px = (x / (self.tan_half * self.aspect) + 1.0) * 0.5 * self.width as f32;
        let py = (1.0 - y / self.tan_half) * 0.5 * self.height as f32;
        Some((px, py))
    }
}

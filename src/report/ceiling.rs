//! The ceiling a frame is measured against: Embree alone tracing the same
//! camera rays, in the same packets, with no shading.

use crate::embree::Rays16;
use crate::render::World;
use crate::render::primary::{PACKET_H, PACKET_W};
use crate::scene::Camera;
use rayon::prelude::*;
use std::time::Instant;

/// Seconds to trace every camera ray of a `width` x `height` frame as 4x4
/// packets over the current rayon pool; the ray directions are generated
/// outside the timed region.
pub fn primary_ray_time(world: &World, camera: &Camera, width: u32, height: u32) -> f64 {
    let cam = camera.frame(width, height);
    let mut packets = Vec::new();
    for py in (0..height).step_by(PACKET_H as usize) {
        for px in (0..width).step_by(PACKET_W as usize) {
            let mut rays = Rays16::default();
            for lane in 0..16u32 {
                let (i, j) = (px + lane % PACKET_W, py + lane / PACKET_W);
                if i >= width || j >= height {
                    continue;
                }
                let d = cam.ray_dir(i, j, 0.5, 0.5);
                let l = lane as usize;
                (rays.ox[l], rays.oy[l], rays.oz[l]) = (cam.eye.x, cam.eye.y, cam.eye.z);
                (rays.dx[l], rays.dy[l], rays.dz[l]) = (d.x, d.y, d.z);
                rays.tnear[l] = 0.0;
                rays.tfar[l] = f32::INFINITY;
                rays.active |= 1 << lane;
            }
            packets.push(rays);
        }
    }
    let start = Instant::now();
    let hits: u32 = packets
        .par_iter()
        .map(|r| {
            let h = world.rt.intersect16(r, true);
            h.geom_id.iter().filter(|&&g| g != crate::embree::INVALID_ID).count() as u32
        })
        .sum();
    std::hint::black_box(hits);
    start.elapsed().as_secs_f64()
}

//! The ceiling a frame is measured against: Embree alone tracing as many
//! rays as the frame does, in the same packets, with no shading.

use crate::embree::{INVALID_ID, Rays16};
use crate::render::World;
use crate::render::primary::{PACKET_H, PACKET_W};
use crate::sampling::light::sample_light_area_uniform;
use crate::sampling::sequence::sample_2d;
use crate::scene::Camera;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Seconds Embree takes for a frame's rays on the current rayon pool.
#[derive(Debug, Clone, Copy, Default)]
pub struct Ceiling {
    /// Every camera ray as 4x4 packets.
    pub primary: f64,
    /// `spp` shadow rays per surface pixel toward points on the lights, as
    /// 16-wide packets in pixel order (as the renderer queues them).
    pub shadow: f64,
    pub shadow_rays: usize,
}

impl Ceiling {
    pub fn total(&self) -> f64 {
        self.primary + self.shadow
    }
}

fn camera_packets(camera: &Camera, width: u32, height: u32) -> Vec<Rays16> {
    let cam = camera.frame(width, height);
    let mut packets = Vec::new();
    for py in (0..height).step_by(PACKET_H as usize) {
        for px in (0..width).step_by(PACKET_W as usize) {
            let mut rays = Rays16::default();
            for lane in 0..16u32 {
                let (i, j) = (px + lane % PACKET_W, py + lane / PACKET_W);
                if i < width && j < height {
                    rays.set(
                        lane as usize,
                        cam.eye,
                        cam.ray_dir(i, j, 0.5, 0.5),
                        0.0,
                        f32::INFINITY,
                    );
                }
            }
            packets.push(rays);
        }
    }
    packets
}

/// Times Embree alone on the rays of one frame; ray generation is outside
/// the timed regions.
pub fn ray_ceiling(world: &World, camera: &Camera, width: u32, height: u32, spp: u32) -> Ceiling {
    let packets = camera_packets(camera, width, height);
    let start = Instant::now();
    let hits: Vec<_> = packets
        .par_iter()
        .map(|r| world.rt.intersect16(r, true))
        .collect();
    let primary = start.elapsed().as_secs_f64();

    let lights = world.lights.declared();
    let mut shadow_rays: Vec<(Vec3, Vec3, f32)> = Vec::new();
    if !lights.is_empty() {
        for (p, (rays, h)) in packets.iter().zip(&hits).enumerate() {
            for lane in 0..16 {
                if h.geom_id[lane] == INVALID_ID || !rays.is_active(lane) {
                    continue;
                }
                let d = Vec3::new(rays.dx[lane], rays.dy[lane], rays.dz[lane]);
                let ng = Vec3::new(h.ngx[lane], h.ngy[lane], h.ngz[lane]).normalize_or(-d);
                let ng = if ng.dot(d) > 0.0 { -ng } else { ng };
                let hit = camera.eye + d * h.t[lane] + ng * 1e-4;
                for s in 0..spp {
                    let pixel = (p * 16 + lane) as u32;
                    let light = &lights[(pixel as usize + s as usize) % lights.len()];
                    let q = sample_light_area_uniform(light, sample_2d(pixel, s, 0, 0));
                    let to = q - hit;
                    let dist = to.length();
                    shadow_rays.push((hit, to / dist, dist * 0.9999));
                }
            }
        }
    }
    let shadow_packets: Vec<Rays16> = shadow_rays
        .chunks(16)
        .map(|c| {
            let mut r = Rays16::default();
            for (l, (o, d, t)) in c.iter().enumerate() {
                r.set(l, *o, *d, 0.0, *t);
            }
            r
        })
        .collect();
    let start = Instant::now();
    let occluded: u32 = shadow_packets
        .par_iter()
        .map(|r| world.rt.occluded16(r).count_ones())
        .sum();
    let shadow = start.elapsed().as_secs_f64();
    std::hint::black_box(occluded);
    Ceiling {
        primary,
        shadow,
        shadow_rays: shadow_rays.len(),
    }
}

//! Primary visibility without rasterisation: camera rays in 4x4-pixel
//! packets through `rtcIntersect16`, resolved into G-buffer samples.

use super::gbuffer::{GSample, resolve_hit};
use super::world::World;
use glam::{Vec2, Vec3};
use penumbra_embree::{INVALID_ID, Rays16};
use penumbra_scene::CameraFrame;

/// Packet footprint in pixels.
pub const PACKET_W: u32 = 4;
pub const PACKET_H: u32 = 4;

/// Sub-pixel position of a camera ray: the pixel centre, one offset for the
/// whole frame (the temporal resolve's per-frame jitter), or a per-pixel,
/// per-sample position for the reference's box filter.
#[derive(Debug, Clone, Copy)]
pub enum PixelOffset {
    Centre,
    Frame(Vec2),
    Jitter { seed: u32, sample: u32 },
}

impl PixelOffset {
    #[inline]
    fn at(self, pixel: u32) -> Vec2 {
        match self {
            PixelOffset::Centre => Vec2::splat(0.5),
            PixelOffset::Frame(o) => o,
            PixelOffset::Jitter { seed, sample } => {
                penumbra_kernels::sampling::sequence::sample_2d(
                    pixel,
                    sample,
                    super::estimate::DIM_JITTER,
                    seed,
                )
            }
        }
    }
}

/// Traces the camera rays of rows `y0 .. y0 + out.len() / width` into `out`
/// (row-major, `width` samples a row).
// Out of line: a stage of `make profile` (scripts/profile.py).
#[inline(never)]
pub fn trace_rows(
    world: &World,
    cam: &CameraFrame,
    prev: &CameraFrame,
    y0: u32,
    offset: PixelOffset,
    out: &mut [GSample],
) {
    let width = cam.width;
    let rows = (out.len() / width as usize) as u32;
    let mut rays = Rays16::default();
    // `CameraFrame::ray_dir`'s image-plane coordinates, term for term, for
    // an offset shared by every pixel.
    let o = offset.at(0);
    let plane_x =
        |i: u32| (2.0 * (i as f32 + o.x) / cam.width as f32 - 1.0) * cam.tan_half * cam.aspect;
    let plane_y = |j: u32| (1.0 - 2.0 * (j as f32 + o.y) / cam.height as f32) * cam.tan_half;
    for py in (0..rows).step_by(PACKET_H as usize) {
        let ys: [f32; PACKET_H as usize] = std::array::from_fn(|k| plane_y(y0 + py + k as u32));
        for px in (0..width).step_by(PACKET_W as usize) {
            let xs: [f32; PACKET_W as usize] = std::array::from_fn(|k| plane_x(px + k as u32));
            rays.active = 0;
            for lane in 0..16u32 {
                let (i, r) = (px + lane % PACKET_W, py + lane / PACKET_W);
                if i >= width || r >= rows {
                    continue;
                }
                let j = y0 + r;
                let d = match offset {
                    // One sub-pixel position for every pixel: the image-plane
                    // coordinates are a column's and a row's, computed once.
                    PixelOffset::Centre | PixelOffset::Frame(_) => {
                        let (x, y) = (
                            xs[(lane % PACKET_W) as usize],
                            ys[(lane / PACKET_W) as usize],
                        );
                        (cam.forward + x * cam.right + y * cam.up).normalize()
                    }
                    PixelOffset::Jitter { .. } => {
                        let o = offset.at(j * width + i);
                        cam.ray_dir(i, j, o.x, o.y)
                    }
                };
                let l = lane as usize;
                (rays.ox[l], rays.oy[l], rays.oz[l]) = (cam.eye.x, cam.eye.y, cam.eye.z);
                (rays.dx[l], rays.dy[l], rays.dz[l]) = (d.x, d.y, d.z);
                rays.tnear[l] = 0.0;
                rays.tfar[l] = f32::INFINITY;
                rays.active |= 1 << lane;
            }
            let hits = world.rt.intersect16(&rays, true);
            for lane in 0..16usize {
                if rays.active & (1 << lane) == 0 {
                    continue;
                }
                let (i, r) = (px + lane as u32 % PACKET_W, py + lane as u32 / PACKET_W);
                let dir = Vec3::new(rays.dx[lane], rays.dy[lane], rays.dz[lane]);
                let mut sample = if hits.geom_id[lane] == INVALID_ID {
                    let mut s = GSample {
                        wo: -dir,
                        ..GSample::default()
                    };
                    // A miss has no surface to reproject; it keeps its pixel.
                    s.prev_pixel = Vec2::new(i as f32 + 0.5, (y0 + r) as f32 + 0.5);
                    s
                } else {
                    resolve_hit(
                        world,
                        hits.geom_id[lane],
                        hits.prim_id[lane],
                        hits.u[lane],
                        hits.v[lane],
                        hits.t[lane],
                        dir,
                        prev,
                    )
                };
                if let PixelOffset::Frame(o) = offset {
                    // Motion vectors of the unjittered camera: the point seen
                    // at (i + o) moved by prev_pixel - (i + o), and that motion
                    // starts from the pixel centre, so a still camera
                    // reprojects every pixel onto itself whatever the jitter.
                    if sample.prev_valid {
                        sample.prev_pixel -= o - Vec2::splat(0.5);
                    }
                }
                out[(r * width + i) as usize] = sample;
            }
        }
    }
}

//! Primary visibility without rasterisation: camera rays in 4x4-pixel
//! packets through `rtcIntersect16`, resolved into G-buffer samples.

use super::gbuffer::{GSample, resolve_hit};
use super::world::World;
use glam::{Vec2, Vec3};
use penumbra_embree::{Hits16, INVALID_ID, Rays16};
use penumbra_isa::Kernel;
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
    // Compiled once per ISA level: the resolve is scalar f32 arithmetic
    // (no `mul_add`, no contraction), so every level gives the same bytes,
    // and the wider levels spend fewer instructions on it.
    penumbra_isa::run(TraceRows {
        world,
        cam,
        prev,
        y0,
        offset,
        out,
    });
}

struct TraceRows<'a, 'd> {
    world: &'a World<'d>,
    cam: &'a CameraFrame,
    prev: &'a CameraFrame,
    y0: u32,
    offset: PixelOffset,
    out: &'a mut [GSample],
}

impl Kernel for TraceRows<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let TraceRows {
            world,
            cam,
            prev,
            y0,
            offset,
            out,
        } = self;
        trace_packets(world, cam, prev, y0, offset, out);
    }
}

/// Lane `l` of a 4x4 packet: its column and row inside the packet.
const LANE_COL: [u32; 16] = [0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3];
const LANE_ROW: [u32; 16] = [0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3];

#[inline(always)]
fn trace_packets(
    world: &World,
    cam: &CameraFrame,
    prev: &CameraFrame,
    y0: u32,
    offset: PixelOffset,
    out: &mut [GSample],
) {
    let width = cam.width;
    let rows = (out.len() / width as usize) as u32;
    // Origin and interval are the same for every camera ray: set once, the
    // packet loop writes directions and the active mask only.
    let mut rays = Rays16 {
        ox: [cam.eye.x; 16],
        oy: [cam.eye.y; 16],
        oz: [cam.eye.z; 16],
        ..Rays16::default()
    };
    // `CameraFrame::ray_dir`'s image-plane coordinates, term for term, for
    // an offset shared by every pixel.
    let o = offset.at(0);
    let plane_x =
        |i: u32| (2.0 * (i as f32 + o.x) / cam.width as f32 - 1.0) * cam.tan_half * cam.aspect;
    let plane_y = |j: u32| (1.0 - 2.0 * (j as f32 + o.y) / cam.height as f32) * cam.tan_half;
    let shared = matches!(offset, PixelOffset::Centre | PixelOffset::Frame(_));
    let still = cam == prev;
    for py in (0..rows).step_by(PACKET_H as usize) {
        let ys: [f32; PACKET_H as usize] = std::array::from_fn(|k| plane_y(y0 + py + k as u32));
        for px in (0..width).step_by(PACKET_W as usize) {
            let xs: [f32; PACKET_W as usize] = std::array::from_fn(|k| plane_x(px + k as u32));
            let mut active = 0u16;
            for lane in 0..16 {
                let (i, r) = (px + LANE_COL[lane], py + LANE_ROW[lane]);
                active |= u16::from(i < width && r < rows) << lane;
            }
            rays.active = active;
            if shared {
                // One sub-pixel position for every pixel: the image-plane
                // coordinates are a column's and a row's, and the direction
                // is `ray_dir`'s (forward + x right + y up, normalised)
                // in lanes, operation for operation.
                for l in 0..16 {
                    let (x, y) = (xs[l % 4], ys[l / 4]);
                    let dx = cam.forward.x + x * cam.right.x + y * cam.up.x;
                    let dy = cam.forward.y + x * cam.right.y + y * cam.up.y;
                    let dz = cam.forward.z + x * cam.right.z + y * cam.up.z;
                    let rcp = 1.0 / (dx * dx + dy * dy + dz * dz).sqrt();
                    (rays.dx[l], rays.dy[l], rays.dz[l]) = (dx * rcp, dy * rcp, dz * rcp);
                }
            } else {
                for lane in 0..16 {
                    let (i, r) = (px + LANE_COL[lane], py + LANE_ROW[lane]);
                    if active & (1 << lane) == 0 {
                        continue;
                    }
                    let j = y0 + r;
                    let o = offset.at(j * width + i);
                    let d = cam.ray_dir(i, j, o.x, o.y);
                    (rays.dx[lane], rays.dy[lane], rays.dz[lane]) = (d.x, d.y, d.z);
                }
            }
            let hits = world.rt.intersect16(&rays, true);
            for lane in 0..16usize {
                if active & (1 << lane) == 0 {
                    continue;
                }
                let (i, r) = (px + LANE_COL[lane], py + LANE_ROW[lane]);
                let dir = Vec3::new(rays.dx[lane], rays.dy[lane], rays.dz[lane]);
                let Some(sample) = out.get_mut((r * width + i) as usize) else {
                    continue;
                };
                let centre = Vec2::new(i as f32 + 0.5, (y0 + r) as f32 + 0.5);
                resolve_lane(
                    world,
                    &hits,
                    lane,
                    dir,
                    (!still).then_some(prev),
                    centre,
                    sample,
                );
                if still && sample.prev_valid {
                    // A still camera moves nothing: every pixel reprojects
                    // exactly onto itself (the projection's rounding would
                    // spread each history tap over four), whatever the jitter.
                    sample.prev_pixel = Vec2::new(i as f32 + 0.5, (y0 + r) as f32 + 0.5);
                } else if let PixelOffset::Frame(o) = offset {
                    // Motion vectors of the unjittered camera: the point seen
                    // at (i + o) moved by prev_pixel - (i + o), and that motion
                    // starts from the pixel centre.
                    if sample.prev_valid {
                        sample.prev_pixel -= o - Vec2::splat(0.5);
                    }
                }
            }
        }
    }
}

/// Traces the camera rays through the centres of the pixels `pixels`
/// (row-major indices into `cam`'s image) into `out`, one sample each: the
/// output-resolution rays of an upscaled frame where its render taps mix
/// surfaces (`denoise::Upscale::edge_pixels`). Packets of 16 consecutive
/// entries; the motion vector is left unset.
pub fn trace_pixels(world: &World, cam: &CameraFrame, pixels: &[u32], out: &mut [GSample]) {
    let width = cam.width.max(1);
    let mut rays = Rays16 {
        ox: [cam.eye.x; 16],
        oy: [cam.eye.y; 16],
        oz: [cam.eye.z; 16],
        ..Rays16::default()
    };
    for (pixels, out) in pixels.chunks(16).zip(out.chunks_mut(16)) {
        rays.active = 0;
        for (lane, &k) in pixels.iter().enumerate() {
            let d = cam.ray_dir(k % width, k / width, 0.5, 0.5);
            (rays.dx[lane], rays.dy[lane], rays.dz[lane]) = (d.x, d.y, d.z);
            rays.active |= 1 << lane;
        }
        let hits = world.rt.intersect16(&rays, true);
        for ((lane, sample), &k) in out.iter_mut().enumerate().zip(pixels) {
            let dir = Vec3::new(rays.dx[lane], rays.dy[lane], rays.dz[lane]);
            let centre = Vec2::new((k % width) as f32 + 0.5, (k / width) as f32 + 0.5);
            resolve_lane(world, &hits, lane, dir, None, centre, sample);
        }
    }
}

/// Lane `lane` of a packet's `hits` into `sample`: a miss keeps its pixel
/// `centre` as its motion (it has no surface to reproject), a hit is
/// resolved against the previous camera `prev` (`None`: the caller sets the
/// motion).
#[inline(always)]
fn resolve_lane(
    world: &World,
    hits: &Hits16,
    lane: usize,
    dir: Vec3,
    prev: Option<&CameraFrame>,
    centre: Vec2,
    sample: &mut GSample,
) {
    if hits.geom_id[lane] == INVALID_ID {
        *sample = GSample {
            wo: -dir,
            prev_pixel: centre,
            ..GSample::default()
        };
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
            sample,
        );
    }
}

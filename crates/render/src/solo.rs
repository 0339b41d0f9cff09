//! Pixels that draw their own visibility samples at a reduced rate: the
//! ones no quad around them vouches for, and the ones whose specular lobe
//! is so narrow that their visibility changes from one pixel to the next
//! (a near-mirror shows an occluder's edge as sharply as a mirror image, so
//! no neighbour's samples can stand in for the pixel's). Their samples are
//! averaged over frames in a per-pixel history, with no spatial filter: the
//! denoiser keeps no spatial neighbour for such a pixel either.

use super::gbuffer::GSample;
use glam::Vec3;

/// The longest history, as the denoiser's (`DenoiseSettings::max_history`).
const MAX_HISTORY: f32 = 32.0;
/// The reprojection tests of the denoiser's history: relative depth
/// change and normal agreement.
const MAX_DEPTH_CHANGE: f32 = 0.1;
const MIN_NORMAL_DOT: f32 = 0.9;

#[derive(Clone, Copy, Default)]
struct Record {
    un: Vec3,
    sn: Vec3,
    len: f32,
    depth: f32,
    normal: Vec3,
    /// The frame that wrote this record (0: none).
    stamp: u32,
}

/// Running averages of `U_N` and `S_N` of the pixels that sample
/// themselves, per full-resolution pixel. Only the pixels of a frame that
/// sampled themselves are written; a record counts as history only when
/// the previous frame wrote it.
pub struct SoloHistory {
    width: u32,
    height: u32,
    prev: Vec<Record>,
    cur: Vec<Record>,
    stamp: u32,
}

impl SoloHistory {
    pub fn new(width: u32, height: u32) -> SoloHistory {
        let n = width as usize * height as usize;
        SoloHistory {
            width,
            height,
            prev: vec![Record::default(); n],
            cur: vec![Record::default(); n],
            stamp: 0,
        }
    }

    /// Starts a frame: what the last frame wrote becomes the history.
    pub fn begin_frame(&mut self) {
        std::mem::swap(&mut self.prev, &mut self.cur);
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.reset();
        }
    }

    /// Forgets every record.
    pub fn reset(&mut self) {
        self.prev.fill(Record::default());
        self.cur.fill(Record::default());
        self.stamp = 1;
    }

    /// Adds this frame's samples of pixel `k` (G-buffer sample `g`) to its
    /// history and returns the averages.
    pub fn accumulate(&mut self, k: usize, g: &GSample, un: Vec3, sn: Vec3) -> (Vec3, Vec3) {
        let (un, sn) = (un.max(Vec3::ZERO), sn.max(Vec3::ZERO));
        let (un, sn, len) = match self.history(g) {
            Some(h) => {
                let len = (h.len + 1.0).min(MAX_HISTORY);
                let a = 1.0 / len;
                (h.un + (un - h.un) * a, h.sn + (sn - h.sn) * a, len)
            }
            None => (un, sn, 1.0),
        };
        self.cur[k] = Record {
            un,
            sn,
            len,
            depth: g.depth,
            normal: g.ng,
            stamp: self.stamp,
        };
        (un, sn)
    }

    /// The record of the previous frame at the pixel `g` came from, when it
    /// holds the same surface.
    fn history(&self, g: &GSample) -> Option<Record> {
        if !g.prev_valid || !g.prev_pixel.is_finite() {
            return None;
        }
        let p = g.prev_pixel.floor();
        let inside =
            p.x >= 0.0 && p.y >= 0.0 && p.x < self.width as f32 && p.y < self.height as f32;
        if !inside {
            return None;
        }
        let r = self.prev[p.y as usize * self.width as usize + p.x as usize];
        let fresh = r.stamp != 0 && r.stamp == self.stamp.wrapping_sub(1);
        let same = (r.depth - g.depth).abs() <= MAX_DEPTH_CHANGE * g.depth
            && r.normal.dot(g.ng) >= MIN_NORMAL_DOT;
        (fresh && same && r.len > 0.0 && r.un.is_finite() && r.sn.is_finite()).then_some(r)
    }
}

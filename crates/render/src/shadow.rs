//! Shadow rays gathered per band and traced as packets.

use glam::Vec3;
use penumbra_embree::{Rays8, Rays16, Scene};

/// One queued shadow ray and the weight it adds to `S_N` if unoccluded.
#[derive(Debug, Clone, Copy)]
pub struct ShadowRay {
    pub org: Vec3,
    pub dir: Vec3,
    pub tfar: f32,
    /// Pixel index within the band.
    pub slot: u32,
    pub weight: Vec3,
}

impl ShadowRay {
    /// A ray toward a light point `dist` away; it stops just short of the
    /// light (lights never occlude, but nothing behind them should either).
    #[inline]
    pub fn new(org: Vec3, dir: Vec3, dist: f32, slot: u32, weight: Vec3) -> ShadowRay {
        ShadowRay {
            org,
            dir,
            tfar: dist * (1.0 - 1e-4),
            slot,
            weight,
        }
    }
}

/// How shadow rays reach Embree; 16-wide packets by default, the others for
/// the benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PacketWidth {
    One,
    Eight,
    #[default]
    Sixteen,
}

#[derive(Default)]
pub struct ShadowBatch {
    pub rays: Vec<ShadowRay>,
}

impl ShadowBatch {
    #[inline]
    pub fn push(&mut self, r: ShadowRay) {
        self.rays.push(r);
    }

    pub fn clear(&mut self) {
        self.rays.clear();
    }

    /// Traces every queued ray and calls `visible(ray)` for each unoccluded one.
    // Out of line: a stage of `make profile` (scripts/profile.py).
    #[inline(never)]
    pub fn trace(&self, scene: &Scene, width: PacketWidth, mut visible: impl FnMut(&ShadowRay)) {
        match width {
            PacketWidth::One => {
                for r in &self.rays {
                    if !scene.occluded1(r.org, r.dir, 0.0, r.tfar) {
                        visible(r);
                    }
                }
            }
            PacketWidth::Eight => {
                for chunk in self.rays.chunks(8) {
                    let mut p = Rays8::default();
                    for (l, r) in chunk.iter().enumerate() {
                        p.set(l, r.org, r.dir, 0.0, r.tfar);
                    }
                    let occluded = scene.occluded8(&p);
                    for (l, r) in chunk.iter().enumerate() {
                        if occluded & (1 << l) == 0 {
                            visible(r);
                        }
                    }
                }
            }
            PacketWidth::Sixteen => {
                for chunk in self.rays.chunks(16) {
                    let mut p = Rays16::default();
                    for (l, r) in chunk.iter().enumerate() {
                        p.set(l, r.org, r.dir, 0.0, r.tfar);
                    }
                    let occluded = scene.occluded16(&p);
                    for (l, r) in chunk.iter().enumerate() {
                        if occluded & (1 << l) == 0 {
                            visible(r);
                        }
                    }
                }
            }
        }
    }
}

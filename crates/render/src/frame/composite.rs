//! The colour from the estimates (`U · S_N / U_N`, or the mode's own), and
//! its temporal resolve.

use super::Frame;
use crate::estimate::ratio;
use crate::gbuffer::GSample;
use crate::plan::{Composite, ResolveInput};
use glam::Vec3;
use penumbra_denoise::{CameraMotion, DenoiseSettings, ResolveSettings};
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// Pixels one lane pass takes at once (a parallel job holds several).
const LANES: usize = 64;

/// Pixels a parallel job takes: enough that the job's overhead is small.
const JOB: usize = 4096;

/// A pixel's colour from its estimates.
#[inline]
pub(super) fn shade(composite: Composite, g: &GSample, u: Vec3, un: Vec3, sn: Vec3) -> Vec3 {
    let lit = match composite {
        Composite::Unshadowed => u,
        Composite::Ratio => u * ratio(sn, un),
        Composite::Stochastic => sn,
    };
    finite_or_zero(g.emission + lit)
}

/// The last line of defence of the no-NaN rule: a non-finite value becomes 0.
#[inline]
pub fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() { v } else { Vec3::ZERO }
}

impl Frame {
    /// The temporal resolve (see `denoise::resolve`): averages over the
    /// jittered frames what no earlier stage has averaged. The denoiser's
    /// temporal history already averages `U_N` and `S_N` over the same
    /// jittered frames, so a denoised colour `U · dn(S_N) / dn(U_N)` is
    /// resolved as `resolve(U) · dn(S_N) / dn(U_N)`, and denoised
    /// `stochastic` as `resolve(emission) + dn(S_N)`: averaging the denoised
    /// colour again would weight the early frames' samples up to 20x more
    /// than the late ones' (a running mean of running means). Where the
    /// jitter (or the motion) crossed a geometric edge, the resolved `U`
    /// mixes surfaces that this frame's ratio does not describe, and the
    /// resolved colour is taken instead; an undenoised frame is resolved
    /// whole. The frame's composite is computed as before: this stage only
    /// averages it, or its per-frame noise-free factor, over frames.
    // Out of line: a stage of `make profile` (scripts/profile.py).
    #[inline(never)]
    pub(super) fn resolve_colour(&mut self, input: ResolveInput, motion: CameraMotion, taps: bool) {
        let guide = self.guide.buffers(&self.u);
        self.resolve.resolve(
            &guide,
            (&mut self.resolve_in, &mut self.color),
            motion,
            &ResolveSettings::default(),
            &DenoiseSettings::default(),
            if taps { self.denoiser.taps() } else { None },
        );
        if input == ResolveInput::Whole {
            return;
        }
        (
            self.color.par_chunks_mut(JOB),
            self.guide.depth.par_chunks(JOB),
            self.resolve_in.par_chunks(JOB),
            self.resolve.mixed().par_chunks(JOB),
            self.un.par_chunks(JOB),
            self.sn.par_chunks(JOB),
        )
            .into_par_iter()
            .for_each(|(color, depth, resolved, mixed, un, sn)| {
                isa::run(Refactor {
                    input,
                    color,
                    depth,
                    resolved,
                    mixed,
                    un,
                    sn,
                })
            });
    }

    // Out of line: a stage of `make profile` (scripts/profile.py).

    #[inline(never)]
    pub(super) fn composite(&mut self, composite: Composite) {
        (
            self.color.par_chunks_mut(JOB),
            self.gbuf.par_chunks(JOB),
            self.guide.depth.par_chunks(JOB),
            self.u.par_chunks(JOB),
            self.un.par_chunks(JOB),
            self.sn.par_chunks(JOB),
        )
            .into_par_iter()
            .for_each(|(color, gbuf, depth, u, un, sn)| {
                isa::run(Compose {
                    composite,
                    color,
                    gbuf,
                    depth,
                    u,
                    un,
                    sn,
                })
            });
    }
}

/// A pixel run's channels as lanes.
type Lanes3 = [[f32; LANES]; 3];

/// `v` per channel into lanes `0 .. v.len()`.
#[inline(always)]
fn load(v: &[Vec3], out: &mut Lanes3) {
    for (k, v) in v.iter().enumerate().take(LANES) {
        [out[0][k], out[1][k], out[2][k]] = v.to_array();
    }
}

/// [`ratio`] in lanes: `sn / un` per channel in [0, 1], 1 where `un` is
/// about 0 (NaN passes through, for `finite_or_zero` to catch).
#[inline(always)]
fn ratio_lanes(sn: &Lanes3, un: &Lanes3, out: &mut Lanes3) {
    for c in 0..3 {
        for k in 0..LANES {
            let (s, u) = (sn[c][k], un[c][k]);
            let q = s / u;
            let q = if q < 0.0 { 0.0 } else { q };
            let q = if q > 1.0 { 1.0 } else { q };
            out[c][k] = if u > 1e-20 { q } else { 1.0 };
        }
    }
}

/// Whether all three channels of lane `k` are finite, per lane.
#[inline(always)]
fn finite_lanes(v: &Lanes3, out: &mut [bool; LANES]) {
    for k in 0..LANES {
        out[k] = v[0][k].is_finite() & v[1][k].is_finite() & v[2][k].is_finite();
    }
}

/// The composite of a run of pixels ([`shade`] in lanes).
struct Compose<'a> {
    composite: Composite,
    color: &'a mut [Vec3],
    gbuf: &'a [GSample],
    /// The guides' depth: positive on the surfaces, whose emission is 0.
    depth: &'a [f32],
    u: &'a [Vec3],
    un: &'a [Vec3],
    sn: &'a [Vec3],
}

impl Kernel for Compose<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let Compose {
            composite,
            color,
            gbuf,
            depth,
            u,
            un,
            sn,
        } = self;
        let z = [[0.0f32; LANES]; 3];
        let (mut e, mut lu, mut lun, mut lsn, mut r, mut out) = (z, z, z, z, z, z);
        let mut ok = [false; LANES];
        let n = color
            .len()
            .min(gbuf.len())
            .min(depth.len())
            .min(u.len())
            .min(un.len())
            .min(sn.len());
        for i0 in (0..n).step_by(LANES) {
            let m = LANES.min(n - i0);
            // Only lights and misses are read from the G-buffer: a record
            // is over a hundred bytes, three times what this pass reads
            // of a pixel otherwise, and at the frame's size it comes from
            // memory.
            for (k, &d) in depth[i0..i0 + m].iter().enumerate() {
                let emission = if d > 0.0 {
                    Vec3::ZERO
                } else {
                    gbuf[i0 + k].emission
                };
                [e[0][k], e[1][k], e[2][k]] = emission.to_array();
            }
            load(&u[i0..i0 + m], &mut lu);
            load(&un[i0..i0 + m], &mut lun);
            load(&sn[i0..i0 + m], &mut lsn);
            match composite {
                Composite::Unshadowed => r = lu,
                Composite::Ratio => {
                    ratio_lanes(&lsn, &lun, &mut r);
                    for c in 0..3 {
                        for k in 0..LANES {
                            r[c][k] *= lu[c][k];
                        }
                    }
                }
                Composite::Stochastic => r = lsn,
            }
            for c in 0..3 {
                for k in 0..LANES {
                    out[c][k] = e[c][k] + r[c][k];
                }
            }
            finite_lanes(&out, &mut ok);
            for (k, c) in color[i0..i0 + m].iter_mut().enumerate() {
                let v = Vec3::new(out[0][k], out[1][k], out[2][k]);
                *c = if ok[k] { v } else { Vec3::ZERO };
            }
        }
    }
}

/// The resolved colour of a run of pixels from the resolved factor (see
/// `Frame::resolve_colour`), in lanes.
struct Refactor<'a> {
    input: ResolveInput,
    color: &'a mut [Vec3],
    depth: &'a [f32],
    resolved: &'a [Vec3],
    mixed: &'a [bool],
    un: &'a [Vec3],
    sn: &'a [Vec3],
}

impl Kernel for Refactor<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let Refactor {
            input,
            color,
            depth,
            resolved,
            mixed,
            un,
            sn,
        } = self;
        let z = [[0.0f32; LANES]; 3];
        let (mut b, mut lun, mut lsn, mut r, mut out) = (z, z, z, z, z);
        let mut ok = [false; LANES];
        let mut keep = [false; LANES];
        let n = color
            .len()
            .min(depth.len())
            .min(resolved.len())
            .min(mixed.len())
            .min(un.len())
            .min(sn.len());
        for i0 in (0..n).step_by(LANES) {
            let m = LANES.min(n - i0);
            load(&resolved[i0..i0 + m], &mut b);
            load(&sn[i0..i0 + m], &mut lsn);
            match input {
                ResolveInput::Modulated => {
                    load(&un[i0..i0 + m], &mut lun);
                    ratio_lanes(&lsn, &lun, &mut r);
                    // Surfaces (depth > 0 in the guides) carry a ratio;
                    // lights and misses are their emission alone.
                    for k in 0..m {
                        let surface = depth[i0 + k] > 0.0;
                        keep[k] = !surface;
                    }
                    for c in 0..3 {
                        for k in 0..LANES {
                            out[c][k] = b[c][k] * r[c][k];
                        }
                    }
                }
                ResolveInput::Additive => {
                    keep = [false; LANES];
                    for c in 0..3 {
                        for k in 0..LANES {
                            out[c][k] = b[c][k] + lsn[c][k];
                        }
                    }
                }
                ResolveInput::Whole => {
                    keep = [true; LANES];
                }
            }
            finite_lanes(&out, &mut ok);
            for (k, c) in color[i0..i0 + m].iter_mut().enumerate() {
                if mixed[i0 + k] {
                    continue;
                }
                let v = Vec3::new(out[0][k], out[1][k], out[2][k]);
                let v = if ok[k] { v } else { Vec3::ZERO };
                let own = Vec3::new(b[0][k], b[1][k], b[2][k]);
                *c = if keep[k] { own } else { v };
            }
        }
    }
}

//! Temporal resolve (TAA): a stage after the composite, separate from the
//! denoiser. It averages one signal over jittered frames: the colour, or
//! the noise-free factor of the colour that no earlier stage has averaged
//! (the renderer decides; see `render::frame`).
//!
//! Every frame's camera rays go through one sub-pixel offset of a
//! low-discrepancy sequence (`sampling::sequence::frame_jitter`); this stage
//! averages the frames. For a still camera the blend is 1/n with n the
//! history length, so n frames are the exact mean of n jittered frames: the
//! box filter over the pixel that `reference` computes. When the camera moves,
//! the history is reprojected with the unjittered motion vectors (bilinear,
//! each tap checked with the denoiser's own disocclusion test), dropped where
//! the light changed (the denoiser's `U` test), clamped to the range of the
//! current frame's 3x3 neighbourhood (no ghost trails) and capped short
//! (bilinear resampling every frame would blur a long history).
//!
//! The composite itself is untouched: per frame it is still
//! `U · dn(S_N) / dn(U_N)` with one set of weights; this stage only averages
//! finished frames.

use super::spatial::LANES;
use super::spatial::lanes::{M, V, each};
use super::temporal::{
    Taps, bilinear_weights, encode_normal_lanes, floor_lanes, frame_i32, kept, put,
    same_surface_lanes, sanitize,
};
use super::{DenoiseSettings, GuideBuffers, luminance};
use glam::Vec3;
use penumbra_isa::{self as isa, Kernel};
use rayon::prelude::*;

/// Knobs of the resolve. `Default` gives the tuned values.
#[derive(Clone, Debug)]
pub struct ResolveSettings {
    /// History cap while the camera is still: up to this many jittered
    /// frames are averaged with equal weights.
    pub max_history_still: u16,
    /// History cap while the camera moves: the blend factor never drops below
    /// 1/this, so resampling blur and what the clamp lets through fade fast.
    pub max_history_moving: u16,
    /// Clamp the reprojected colour to the current 3x3 neighbourhood's range
    /// when the camera moves.
    pub clamp: bool,
}

impl Default for ResolveSettings {
    fn default() -> Self {
        ResolveSettings {
            max_history_still: 64,
            max_history_moving: 8,
            clamp: true,
        }
    }
}

/// The fields of a pixel's resolve record (`Records`): what the next frame
/// validates the history with, and the resolved signals.
mod record {
    /// Frames averaged (capped); fractional after bilinear reprojection.
    pub const LEN: usize = 0;
    /// 1 where the history holds more than one surface, else 0.
    pub const MIXED: usize = 1;
    /// The noise-free factor of the colour (see `resolve`), then the colour.
    pub const FACTOR: usize = 2;
    pub const COLOR: usize = 5;
    /// The fields above are what a tap gives; those below, what testing
    /// it takes.
    pub const SIGNALS: usize = 8;
    pub const DEPTH: usize = 8;
    pub const PX: usize = 9;
    pub const PY: usize = 10;
    pub const PZ: usize = 11;
    /// The octahedral normal's two components, as the integers they are.
    pub const E0: usize = 12;
    pub const E1: usize = 13;
    /// Luminance of the analytic `U` this frame, and of its diffuse part.
    pub const LU: usize = 14;
    pub const LU_DIFFUSE: usize = 15;
    pub const COUNT: usize = 16;
}

/// Resolve state: the previous resolved frame and the one being written.
pub struct Resolve {
    width: u32,
    height: u32,
    prev: Records,
    cur: Records,
    /// Per pixel of the last frame resolved: `mixed`.
    mixed: Vec<bool>,
    /// A moving camera's inputs, sanitized, as planes (`Inputs`): the
    /// clamp reads the rows around a row that is resolved in place.
    inputs: Inputs,
    /// `prev` holds a resolved frame (not only empty records).
    has_history: bool,
}

/// How the camera moved since the previous frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraMotion {
    /// Same camera (and lights): every pixel's history is its own.
    Still,
    /// Reproject along the motion vectors.
    Moved,
}

impl Resolve {
    pub fn new(width: u32, height: u32) -> Resolve {
        let (w, h) = (width as usize, height as usize);
        Resolve {
            width,
            height,
            prev: Records::new(w, h),
            cur: Records::new(w, h),
            mixed: vec![false; w * h],
            inputs: Inputs::new(w, h),
            has_history: false,
        }
    }

    /// Forgets the history: the next frame stands alone.
    pub fn reset(&mut self) {
        self.prev.clear();
        self.cur.clear();
        self.mixed.fill(false);
        self.has_history = false;
    }

    /// Frames averaged per pixel after the last call (0 before any).
    pub fn history_len(&self) -> Vec<f32> {
        let (w, h) = (self.width as usize, self.height as usize);
        (0..w * h)
            .map(|i| self.prev.data[self.prev.at(i % w, i / w) + record::LEN * LANES])
            .collect()
    }

    /// Per pixel after the last call: whether its history holds more than
    /// one surface (the jitter or the motion crossed a geometric edge), so
    /// the resolved factor does not belong to this frame's surface alone.
    pub fn mixed(&self) -> &[bool] {
        &self.mixed
    }

    /// Replaces `factor` and `color` by their temporal resolves, with the
    /// same weights. `factor` is the noise-free per-frame part of the colour
    /// (the renderer multiplies it by what its denoiser already averaged),
    /// `color` the whole frame, for the pixels whose history is
    /// [`mixed`](Self::mixed). `surface` holds the disocclusion and
    /// light-change tolerances of the denoiser's history, so both histories
    /// are dropped at the same places. `taps`: the denoiser's reprojection
    /// of this frame (`Denoiser::taps`), given only where its history and
    /// this one hold the same previous frame: a moving camera then takes
    /// each pixel's taps from it rather than testing them again, with the
    /// same result. A size change drops the history.
    pub fn resolve(
        &mut self,
        guide: &GuideBuffers,
        (factor, color): (&mut [Vec3], &mut [Vec3]),
        motion: CameraMotion,
        settings: &ResolveSettings,
        surface: &DenoiseSettings,
        taps: Option<&[Taps]>,
    ) {
        let (w, h) = (guide.width as usize, guide.height as usize);
        let n = w * h;
        assert!(
            color.len() == n
                && factor.len() == n
                && guide.depth.len() == n
                && guide.position.len() == n
                && guide.normal.len() == n
                && guide.prev_pixel.len() == n
                && guide.prev_valid.len() == n
                && guide.u.len() == n,
            "resolve: every buffer must hold width * height pixels"
        );
        if guide.width != self.width || guide.height != self.height {
            *self = Resolve::new(guide.width, guide.height);
        }
        let taps = taps.filter(|t| t.len() == n);
        if n == 0 {
            return;
        }
        let cap = match motion {
            CameraMotion::Still => settings.max_history_still,
            CameraMotion::Moved => settings.max_history_moving,
        }
        .max(1) as f32;
        let row_len = self.cur.row_len();
        let prev = &self.prev;
        // Without a resolved frame every tap would fail its test.
        let motion = if self.has_history { Some(motion) } else { None };
        let rows = (
            self.cur.data.par_chunks_mut(row_len),
            self.mixed.par_chunks_mut(w),
        );
        match motion {
            // Every row is resolved in place, while it is in cache: copying
            // the resolved frame out afterwards would move both signals
            // through memory once more. A pixel that reads only its own
            // input reads it there; a moving camera reads its inputs from a
            // copy (`Inputs`), since the clamp reads the rows around.
            None | Some(CameraMotion::Still) => {
                (rows, factor.par_chunks_mut(w), color.par_chunks_mut(w))
                    .into_par_iter()
                    .enumerate()
                    .for_each(|(y, ((record, mixed), factor, color))| {
                        isa::run(StillRow {
                            guide,
                            prev: motion.map(|_| prev),
                            surface,
                            out: RowOut {
                                y,
                                cap,
                                record,
                                mixed,
                            },
                            signals: (factor, color),
                        })
                    });
            }
            Some(CameraMotion::Moved) => {
                self.inputs.fill((factor, color));
                let inputs = &self.inputs;
                (rows, factor.par_chunks_mut(w), color.par_chunks_mut(w))
                    .into_par_iter()
                    .enumerate()
                    .for_each(|(y, ((record, mixed), out_f, out_c))| {
                        isa::run(MovedRow {
                            guide,
                            prev,
                            surface,
                            taps,
                            clamp: settings.clamp,
                            inputs,
                            out: RowOut {
                                y,
                                cap,
                                record,
                                mixed,
                            },
                            signals: (out_f, out_c),
                        })
                    });
            }
        }
        std::mem::swap(&mut self.prev, &mut self.cur);
        self.has_history = true;
    }
}

/// Values of a lane group's records: each field's eight lanes in turn.
const GROUP: usize = record::COUNT * LANES;

/// One frame of resolve records, by lane groups: the records of the eight
/// pixels of a row that a lane group covers are one block (`GROUP`), field
/// `k` at `k * LANES`, so the pass reads and writes one stream of records
/// instead of a stream per field (streams the prefetchers lose track of).
/// A row holds whole groups, the last one padded.
struct Records {
    data: Vec<f32>,
    /// Lane groups per row.
    groups: usize,
}

impl Records {
    fn new(width: usize, height: usize) -> Records {
        let groups = width.div_ceil(LANES);
        Records {
            data: vec![0.0; groups * GROUP * height],
            groups,
        }
    }

    /// Values of one row's records.
    fn row_len(&self) -> usize {
        self.groups * GROUP
    }

    /// Where pixel `(x, y)`'s first field lies (field `k` at `k * LANES`
    /// further).
    #[inline(always)]
    fn at(&self, x: usize, y: usize) -> usize {
        y * self.row_len() + x / LANES * GROUP + x % LANES
    }

    fn clear(&mut self) {
        self.data.fill(0.0);
    }
}

/// A lane group of one row as the resolve reads it, a lane per pixel: the
/// surface (depth 0 where there is none), the light at it, and this
/// frame's sanitized signals.
#[derive(Default)]
struct Here {
    depth: V,
    pos: [V; 3],
    normal: [V; 3],
    lu: V,
    lu_diffuse: V,
    factor: [V; 3],
    color: [V; 3],
}

impl Here {
    /// The surface and light of the `n` pixels of row `y` from column
    /// `x0`; the signals are left at zero.
    #[inline(always)]
    fn surface(guide: &GuideBuffers, (x0, y, n): (usize, usize, usize)) -> Here {
        let mut h = Here::default();
        let row = y * guide.width as usize;
        for l in 0..n {
            let i = row + x0 + l;
            let d = guide.depth[i];
            let surface = d > 0.0 && d.is_finite();
            let lu = luminance(guide.u[i]);
            let lu = if lu.is_finite() { lu.max(0.0) } else { 0.0 };
            let share = match guide.lobe.get(i) {
                Some(lobe) => lobe.share,
                None => 0.0,
            };
            let (pos, normal) = (guide.position[i], guide.normal[i]);
            h.depth.0[l] = if surface { d } else { 0.0 };
            h.lu.0[l] = lu;
            h.lu_diffuse.0[l] = lu * (1.0 - share);
            for k in 0..3 {
                h.pos[k].0[l] = pos[k];
                h.normal[k].0[l] = normal[k];
            }
        }
        h
    }

    /// `surface`, with the signals sanitized from the row's `factor` and
    /// `color`.
    #[inline(always)]
    fn load(
        guide: &GuideBuffers,
        (x0, y, n): (usize, usize, usize),
        (factor, color): (&[Vec3], &[Vec3]),
    ) -> Here {
        let mut h = Here::surface(guide, (x0, y, n));
        for l in 0..n {
            let (f, c) = (sanitize(factor[x0 + l]), sanitize(color[x0 + l]));
            for k in 0..3 {
                h.factor[k].0[l] = f[k];
                h.color[k].0[l] = c[k];
            }
        }
        h
    }
}

/// The history of a lane group's pixels: per lane whether there is one,
/// and its signals, length and whether it is mixed.
#[derive(Default)]
struct Held {
    has: [bool; LANES],
    mixed: [bool; LANES],
    factor: [V; 3],
    color: [V; 3],
    len: V,
}

/// One row of the resolve's output: the records the next frame validates
/// its history with, and the mixed flags.
struct RowOut<'a> {
    y: usize,
    /// History length cap.
    cap: f32,
    /// The row's records (`Records`).
    record: &'a mut [f32],
    mixed: &'a mut [bool],
}

impl RowOut<'_> {
    /// Blends a lane group's signals into its history (where it holds one)
    /// and writes the result: the records, the mixed flags and the
    /// resolved signals into `factor` and `color` (the row's).
    #[inline(always)]
    fn put(
        &mut self,
        (x0, n): (usize, usize),
        here: &Here,
        held: &Held,
        (factor, color): (&mut [Vec3], &mut [Vec3]),
    ) {
        let at = x0 / LANES * GROUP;
        let one = V::splat(1.0);
        let has = M::from_fn(|l| held.has[l]);
        let len_b = (held.len + 1.0).min(V::splat(self.cap));
        let a = one / has.select(len_b, one);
        let blend = |h: V, v: V| has.select(h + (v - h) * a, v);
        let f = [
            blend(held.factor[0], here.factor[0]),
            blend(held.factor[1], here.factor[1]),
            blend(held.factor[2], here.factor[2]),
        ];
        let c = [
            blend(held.color[0], here.color[0]),
            blend(held.color[1], here.color[1]),
            blend(held.color[2], here.color[2]),
        ];
        let len = has.select(len_b, one);
        let mixed: [bool; LANES] = each(|l| held.has[l] && held.mixed[l]);
        let (e0, e1) = encode_normal_lanes(&here.normal);
        let mixed_v = V(each(|l| f32::from(u8::from(mixed[l]))));
        // One store per field, written out field by field: an array of
        // lanes to loop over is copied through memory first.
        macro_rules! store {
            ($($k:expr => $v:expr),* $(,)?) => {
                $(put(self.record, at + $k * LANES, &$v.0, n);)*
            };
        }
        store!(
            record::DEPTH => here.depth,
            record::PX => here.pos[0],
            record::PY => here.pos[1],
            record::PZ => here.pos[2],
            record::E0 => e0,
            record::E1 => e1,
            record::LU => here.lu,
            record::LU_DIFFUSE => here.lu_diffuse,
            record::LEN => len,
            record::MIXED => mixed_v,
            record::FACTOR => f[0],
            record::FACTOR + 1 => f[1],
            record::FACTOR + 2 => f[2],
            record::COLOR => c[0],
            record::COLOR + 1 => c[1],
            record::COLOR + 2 => c[2],
        );
        for l in 0..n {
            self.mixed[x0 + l] = mixed[l];
            factor[x0 + l] = Vec3::new(f[0].0[l], f[1].0[l], f[2].0[l]);
            color[x0 + l] = Vec3::new(c[0].0[l], c[1].0[l], c[2].0[l]);
        }
    }
}

/// A row under a still camera (or without history: `prev` is `None`),
/// resolved in place.
struct StillRow<'a, 'g> {
    guide: &'a GuideBuffers<'g>,
    prev: Option<&'a Records>,
    surface: &'a DenoiseSettings,
    out: RowOut<'a>,
    signals: (&'a mut [Vec3], &'a mut [Vec3]),
}

impl Kernel for StillRow<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let StillRow {
            guide,
            prev,
            surface,
            mut out,
            signals: (factor, color),
        } = self;
        let (w, y) = (guide.width as usize, out.y);
        for x0 in (0..w).step_by(LANES) {
            let n = LANES.min(w - x0);
            let here = Here::load(guide, (x0, y, n), (factor, color));
            let held = match prev {
                Some(prev) => still_held(prev, (x0, y, n), &here, surface),
                None => Held::default(),
            };
            out.put((x0, n), &here, &held, (&mut *factor, &mut *color));
        }
    }
}

/// A still camera's history: the pixel's own. Nothing is rejected: the
/// static scene cannot have disoccluded anything, a different surface than
/// last frame is the jitter sampling another part of the pixel (what the
/// average is for; the history is then marked mixed), and `U` differs
/// between frames for the same reason; the renderer drops the history when
/// the lights change.
#[inline(always)]
fn still_held(
    prev: &Records,
    (x0, y, n): (usize, usize, usize),
    here: &Here,
    s: &DenoiseSettings,
) -> Held {
    let base = prev.at(x0, y);
    // Every field but the light's, which only a moving camera tests.
    let mut f = [V::default(); record::COUNT];
    for (k, f) in f[..record::LU].iter_mut().enumerate() {
        *f = V::load(&prev.data, base + k * LANES);
    }
    let zero = V::splat(0.0);
    let (md, mlen) = (f[record::DEPTH], f[record::LEN]);
    let mpos = [f[record::PX], f[record::PY], f[record::PZ]];
    let same = same_surface_lanes(
        (here.depth, &here.pos, &here.normal),
        (md, mpos, (f[record::E0], f[record::E1]), mlen),
        s,
    );
    let mut held = Held {
        factor: [
            f[record::FACTOR],
            f[record::FACTOR + 1],
            f[record::FACTOR + 2],
        ],
        color: [f[record::COLOR], f[record::COLOR + 1], f[record::COLOR + 2]],
        len: mlen,
        ..Held::default()
    };
    for l in 0..n {
        // A pixel with no surface keeps its history while the record had
        // none either.
        let same = if here.depth.0[l] > zero.0[l] {
            same.lane(l)
        } else {
            md.0[l] <= 0.0
        };
        held.has[l] = mlen.0[l] > 0.0 || mlen.0[l].is_nan();
        held.mixed[l] = f[record::MIXED].0[l] != 0.0 || !same;
    }
    held
}

/// A row under a moving camera: each pixel's history reprojected (its taps
/// tested here, or the denoiser's `taps`), clamped to the range of this
/// frame's 3x3 neighbourhood (no ghost trails), then blended.
struct MovedRow<'a, 'g> {
    guide: &'a GuideBuffers<'g>,
    prev: &'a Records,
    surface: &'a DenoiseSettings,
    taps: Option<&'a [Taps]>,
    clamp: bool,
    inputs: &'a Inputs,
    out: RowOut<'a>,
    signals: (&'a mut [Vec3], &'a mut [Vec3]),
}

impl Kernel for MovedRow<'_, '_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let MovedRow {
            guide,
            prev,
            surface,
            taps,
            clamp,
            inputs,
            mut out,
            signals: (out_f, out_c),
        } = self;
        let (w, y) = (guide.width as usize, out.y);
        for x0 in (0..w).step_by(LANES) {
            let n = LANES.min(w - x0);
            let mut here = Here::surface(guide, (x0, y, n));
            for k in 0..3 {
                here.factor[k] = inputs.at(Inputs::FACTOR + k, (x0, y), 0);
                here.color[k] = inputs.at(Inputs::COLOR + k, (x0, y), 0);
            }
            let mut held = moved_held(prev, guide, (x0, y, n), &here, taps, surface);
            if clamp {
                for k in 0..3 {
                    held.factor[k] = inputs.clamp(Inputs::FACTOR + k, (x0, y), held.factor[k]);
                    held.color[k] = inputs.clamp(Inputs::COLOR + k, (x0, y), held.color[k]);
                }
            }
            out.put((x0, n), &here, &held, (&mut *out_f, &mut *out_c));
        }
    }
}

/// One image row of `Inputs`: its planes' padded rows.
struct FillRow<'a> {
    rows: &'a mut [f32],
    factor: &'a [Vec3],
    color: &'a [Vec3],
}

impl Kernel for FillRow<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let w = self.factor.len();
        let stride = Inputs::stride(w);
        for (x, (f, c)) in self.factor.iter().zip(self.color).enumerate() {
            let (f, c) = (sanitize(*f), sanitize(*c));
            for k in 0..3 {
                self.rows[(Inputs::FACTOR + k) * stride + 1 + x] = f[k];
                self.rows[(Inputs::COLOR + k) * stride + 1 + x] = c[k];
            }
        }
        for row in self.rows.chunks_mut(stride) {
            row[0] = row[1];
            let last = row[w];
            row[w + 1..].fill(last);
        }
    }
}

/// A moving camera's inputs, sanitized, a plane per channel of the factor
/// and of the colour, each image row padded: one column on the left, and
/// `LANES + 1` on the right, repeating the row's first and last pixels. A
/// lane group then reads its 3x3 neighbourhoods as loads shifted a column
/// either way, and a repeated pixel changes no range.
struct Inputs {
    data: Vec<f32>,
    width: usize,
    height: usize,
}

impl Inputs {
    const FACTOR: usize = 0;
    const COLOR: usize = 3;
    const PLANES: usize = 6;

    fn new(width: usize, height: usize) -> Inputs {
        Inputs {
            data: vec![0.0; Inputs::PLANES * Inputs::stride(width) * height],
            width,
            height,
        }
    }

    /// Values of one padded plane row.
    fn stride(width: usize) -> usize {
        width + LANES + 2
    }

    /// Writes the planes from the frame's signals.
    fn fill(&mut self, (factor, color): (&[Vec3], &[Vec3])) {
        let (w, stride) = (self.width, Inputs::stride(self.width));
        (
            self.data.par_chunks_mut(Inputs::PLANES * stride),
            factor.par_chunks(w),
            color.par_chunks(w),
        )
            .into_par_iter()
            .for_each(|(rows, factor, color)| {
                isa::run(FillRow {
                    rows,
                    factor,
                    color,
                })
            });
    }

    /// Plane `p` at the lane group from `(x0, y)`, shifted `dx` columns
    /// (-1, 0 or 1).
    #[inline(always)]
    fn at(&self, p: usize, (x0, y): (usize, usize), dx: isize) -> V {
        let stride = Inputs::stride(self.width);
        let at = (y * Inputs::PLANES + p) * stride + 1 + x0;
        V::load(&self.data, at.wrapping_add_signed(dx))
    }

    /// `v` clamped, per lane, to the range of plane `p` over the 3x3
    /// neighbourhood (within the frame) of the lane group's pixel.
    #[inline(always)]
    fn clamp(&self, p: usize, (x0, y): (usize, usize), v: V) -> V {
        let rows = [y.saturating_sub(1), y, (y + 1).min(self.height - 1)];
        let mut lo = self.at(p, (x0, y), 0);
        let mut hi = lo;
        for r in rows {
            for dx in [-1, 0, 1] {
                let c = self.at(p, (x0, r), dx);
                lo = V(each(|l| lo.0[l].min(c.0[l])));
                hi = V(each(|l| hi.0[l].max(c.0[l])));
            }
        }
        V(each(|l| v.0[l].max(lo.0[l]).min(hi.0[l])))
    }
}

/// A moving camera's history of a lane group: per lane a bilinear fetch of
/// the previous resolve at the unjittered motion vector's end, over the
/// taps the denoiser's reprojection passed (`taps`), or, without them, over
/// the taps that pass the denoiser's disocclusion test here, and none where
/// the light changed: the denoiser's own reprojection (`temporal`), the
/// taps summed in their order.
#[inline(always)]
fn moved_held(
    prev: &Records,
    guide: &GuideBuffers,
    (x0, y, n): (usize, usize, usize),
    here: &Here,
    taps: Option<&[Taps]>,
    s: &DenoiseSettings,
) -> Held {
    let zero = V::splat(0.0);
    let row = y * guide.width as usize;
    let (mut ax, mut ay) = (zero, zero);
    // Per lane the taps it may take (bit `k` for tap `k`).
    let mut allowed = [0u8; LANES];
    let mut ok0 = [false; LANES];
    for l in 0..n {
        let i = row + x0 + l;
        let at = guide.prev_pixel[i];
        ax.0[l] = at.x - 0.5;
        ay.0[l] = at.y - 0.5;
        allowed[l] = match taps {
            Some(taps) => taps[i],
            None => 0b1111,
        };
        // Finite and not far off-screen (no overflow in the casts).
        ok0[l] = here.depth.0[l] > 0.0
            && guide.prev_valid[i]
            && allowed[l] != 0
            && ax.0[l].abs() <= 1e9
            && ay.0[l].abs() <= 1e9;
    }
    if !ok0.iter().any(|&b| b) {
        return Held::default();
    }
    let some = M::from_fn(|l| ok0[l]);
    let (ax, ay) = (some.select(ax, zero), some.select(ay, zero));
    let (tx0, ty0) = (floor_lanes(ax), floor_lanes(ay));
    let weights = bilinear_weights((ax, ay), (&tx0, &ty0));
    let (w, h) = frame_i32(guide.width, guide.height);
    let row_len = prev.row_len();
    let mut wsum = zero;
    let (mut f, mut c) = ([zero; 3], [zero; 3]);
    let (mut len, mut lu, mut lu_diffuse) = (zero, zero, zero);
    let mut mixed = [false; LANES];
    for (k, (dx, dy, wt)) in weights.into_iter().enumerate() {
        let mut j = [0usize; LANES];
        let mut inside = [false; LANES];
        for l in 0..LANES {
            let (tx, ty) = (tx0[l] + dx, ty0[l] + dy);
            // `&`, not `&&`: no branch per lane.
            inside[l] = ok0[l]
                & (allowed[l] & (1 << k) != 0)
                & (wt.0[l] > 0.0)
                & (tx >= 0)
                & (ty >= 0)
                & (tx < w)
                & (ty < h);
            let (cx, cy) = if inside[l] { (tx, ty) } else { (0, 0) };
            let cx = cx as usize;
            j[l] = cy as usize * row_len + cx / LANES * GROUP + cx % LANES;
        }
        if !inside.iter().any(|&b| b) {
            continue;
        }
        // One load per field where the lanes' taps are one lane group's
        // pixels, else a value per lane.
        // The denoiser's taps need no test: their signals only.
        let consecutive = (0..LANES).all(|l| inside[l] & (j[l] == j[0] + l));
        let fields = if taps.is_some() {
            record::SIGNALS
        } else {
            record::COUNT
        };
        let mut r = [zero; record::COUNT];
        if consecutive {
            for (k, r) in r[..fields].iter_mut().enumerate() {
                *r = V::load(&prev.data, j[0] + k * LANES);
            }
        } else {
            for (k, r) in r[..fields].iter_mut().enumerate() {
                for (v, &j) in r.0.iter_mut().zip(&j) {
                    *v = prev.data[j + k * LANES];
                }
            }
        }
        let mut valid = M::from_fn(|l| inside[l]);
        if taps.is_none() {
            valid = valid.and(same_surface_lanes(
                (here.depth, &here.pos, &here.normal),
                (
                    r[record::DEPTH],
                    [r[record::PX], r[record::PY], r[record::PZ]],
                    (r[record::E0], r[record::E1]),
                    r[record::LEN],
                ),
                s,
            ));
        }
        let wt = valid.select(wt, zero);
        wsum = wsum + wt;
        let add = |acc: V, v: V| acc + valid.select(v * wt, zero);
        for q in 0..3 {
            f[q] = add(f[q], r[record::FACTOR + q]);
            c[q] = add(c[q], r[record::COLOR + q]);
        }
        len = add(len, r[record::LEN]);
        lu = add(lu, r[record::LU]);
        lu_diffuse = add(lu_diffuse, r[record::LU_DIFFUSE]);
        for (m, l) in mixed.iter_mut().zip(0..LANES) {
            *m |= valid.lane(l) & (r[record::MIXED].0[l] != 0.0);
        }
    }
    let light =
        (taps.is_none() && s.light_test).then_some(((here.lu, here.lu_diffuse), (lu, lu_diffuse)));
    let (has, inv) = kept(&ok0, wsum, light, s.u_change);
    Held {
        has,
        mixed,
        factor: [f[0] * inv, f[1] * inv, f[2] * inv],
        color: [c[0] * inv, c[1] * inv, c[2] * inv],
        len: len * inv,
    }
}

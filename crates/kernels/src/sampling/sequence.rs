//! Sample points for the per-pixel estimators.
//!
//! 2D points are the first two Sobol dimensions, a (0,2)-sequence in base 2:
//! every power-of-two prefix of 2^m points puts exactly one point in each
//! elementary interval of area 2^-m (so 16 points fill a 4×4 grid). Each
//! (pixel, dimension, seed) gets its own Owen scramble (keeps the net
//! property, removes the structure shared between pixels) and its own index
//! shuffle (a nested scramble of the index, which permutes aligned power-of-two
//! blocks, so prefixes stay nets while different dimensions stop being
//! correlated). Owen scrambling uses the hash-based approach of Burley 2020,
//! "Practical Hash-based Owen Scrambling". Frames decorrelate through `seed`
//! (mix the frame number into it, e.g. `hash_u32(frame ^ global_seed)`).

use glam::Vec2;
use penumbra_isa::Kernel;

/// A strong 32-bit integer hash (the "lowbias32" mixer, bias ~0.17): full
/// avalanche, so neighbouring pixel indices give unrelated seeds.
#[inline]
pub fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// A scramble in which each output bit (from the most significant) depends
/// only on the input bits above it: that is exactly what keeps nets nets. It
/// operates on bit-reversed values, where "above" becomes "below", which is
/// what multiplication by even constants and adding a seed propagate towards.
#[inline]
fn owen_reversed(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Generator-matrix columns of Sobol dimension 1 (the second one): Pascal's
/// triangle mod 2, each next column `v ^ (v >> 1)`.
const fn sobol1_columns() -> [u32; 32] {
    let mut c = [0u32; 32];
    let mut v = 1u32 << 31;
    let mut k = 0;
    while k < 32 {
        c[k] = v;
        v ^= v >> 1;
        k += 1;
    }
    c
}

/// The matrix–vector product by bytes: entry [k][b] is the XOR of the columns
/// 8k..8k+8 selected by byte value b, stored bit-reversed because the Owen
/// scramble works on reversed values (reversal distributes over XOR). Four
/// lookups instead of a 32-step loop (shuffled indices use all 32 bits).
const SOBOL1_REV_BYTES: [[u32; 256]; 4] = {
    let cols = sobol1_columns();
    let mut t = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            let mut r = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if b & (1 << bit) != 0 {
                    r ^= cols[8 * k + bit];
                }
                bit += 1;
            }
            t[k][b] = r.reverse_bits();
            b += 1;
        }
        k += 1;
    }
    t
};

/// Sobol dimension 1 of index `i` as a bit-reversed 32-bit fraction.
#[inline]
fn sobol_dim1_reversed(i: u32) -> u32 {
    let b = i.to_le_bytes();
    SOBOL1_REV_BYTES[0][b[0] as usize]
        ^ SOBOL1_REV_BYTES[1][b[1] as usize]
        ^ SOBOL1_REV_BYTES[2][b[2] as usize]
        ^ SOBOL1_REV_BYTES[3][b[3] as usize]
}

/// Top 24 bits to a float in [0, 1): exact, and never rounds up to 1.
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// splitmix64's finalizer (Stafford's mix13): full 64-bit avalanche in two
/// multiplies, so one call seeds a whole stream instead of a chain of 32-bit hashes.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Independent scramble seeds for one (pixel, dimension, seed) stream: index
/// shuffle, x and y. (pixel, dimension) fill the 64-bit key injectively and the
/// frame seed is spread over all of it, so for a given frame no two streams
/// share a key, and frames differ everywhere.
#[inline]
fn stream_seeds(pixel_index: u32, dimension: u32, seed: u32) -> (u32, u32, u32) {
    let key = ((pixel_index as u64) << 32 | dimension as u64)
        ^ (seed as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    let h = mix64(key);
    // The y seed is only needed after the index shuffle, so one more mixing
    // round for it costs no latency.
    let hy = (h ^ (h >> 29)).wrapping_mul(0xd6e8_feb8_6659_fd93);
    (h as u32, (h >> 32) as u32, (hy >> 32) as u32)
}

/// The `sample_index`-th 2D point of the stream (pixel, dimension, seed), in
/// [0,1)². Prefixes of 2^m points are (0,m,2)-nets.
#[inline]
pub fn sample_2d(pixel_index: u32, sample_index: u32, dimension: u32, seed: u32) -> Vec2 {
    let (s, sx, sy) = stream_seeds(pixel_index, dimension, seed);
    // Index shuffle: a nested scramble of the index (Owen in reversed bits).
    let i = owen_reversed(sample_index.reverse_bits(), s).reverse_bits();
    // x is the van der Corput point of i, r(i); its Owen scramble
    // r(O(r(r(i)))) is r(O(i)): no reversal going in.
    let x = owen_reversed(i, sx).reverse_bits();
    let y = owen_reversed(sobol_dim1_reversed(i), sy).reverse_bits();
    Vec2::new(to_unit(x), to_unit(y))
}

/// The `sample_index`-th 1D value of the stream, in [0,1): a scrambled,
/// shuffled van der Corput sequence, so 2^m prefixes fill 2^m strata.
#[inline]
pub fn sample_1d(pixel_index: u32, sample_index: u32, dimension: u32, seed: u32) -> f32 {
    // A distinct key space from the 2D streams so a 1D and a 2D dimension with
    // the same number are not the same scrambled points.
    let (s, sx, _) = stream_seeds(pixel_index, dimension ^ 0x8000_0000, seed);
    let i = owen_reversed(sample_index.reverse_bits(), s).reverse_bits();
    to_unit(owen_reversed(i, sx).reverse_bits())
}

/// Pixels per lane group of the batched streams: a multiple of every
/// level's vector width, so each level runs whole vectors.
pub const STREAM_LANES: usize = 16;

/// The streams' values for one sample index over a lane group of pixels:
/// `sample_1d` of `dimension` for each pixel. The same integer arithmetic
/// as `sample_1d`, lane by lane, so the same bits at any vector width.
#[inline(always)]
pub fn sample_1d_lanes(
    pixels: &[u32; STREAM_LANES],
    sample_index: u32,
    dimension: u32,
    seed: u32,
    out: &mut [f32; STREAM_LANES],
) {
    let rev_index = sample_index.reverse_bits();
    for l in 0..STREAM_LANES {
        let (s, sx, _) = stream_seeds(pixels[l], dimension ^ 0x8000_0000, seed);
        let i = owen_reversed(rev_index, s).reverse_bits();
        out[l] = to_unit(owen_reversed(i, sx).reverse_bits());
    }
}

/// `sample_2d` of `dimension` for each pixel of a lane group (see
/// `sample_1d_lanes`). The Sobol table lookups run as a loop of their own
/// so that the hashing around them stays in vectors.
#[inline(always)]
pub fn sample_2d_lanes(
    pixels: &[u32; STREAM_LANES],
    sample_index: u32,
    dimension: u32,
    seed: u32,
    out_x: &mut [f32; STREAM_LANES],
    out_y: &mut [f32; STREAM_LANES],
) {
    let rev_index = sample_index.reverse_bits();
    let mut idx = [0u32; STREAM_LANES];
    let mut sy = [0u32; STREAM_LANES];
    for l in 0..STREAM_LANES {
        let (s, sx, y_seed) = stream_seeds(pixels[l], dimension, seed);
        let i = owen_reversed(rev_index, s).reverse_bits();
        idx[l] = i;
        sy[l] = y_seed;
        out_x[l] = to_unit(owen_reversed(i, sx).reverse_bits());
    }
    let mut sob = [0u32; STREAM_LANES];
    for l in 0..STREAM_LANES {
        sob[l] = sobol_dim1_reversed(idx[l]);
    }
    for l in 0..STREAM_LANES {
        out_y[l] = to_unit(owen_reversed(sob[l], sy[l]).reverse_bits());
    }
}

/// The stream values one sample index draws at a run of pixels, in lane
/// groups, as a `Kernel` so each ISA level hashes in its own vectors:
/// three 1D dimensions and one 2D dimension, each into its own array
/// (`out_1d[d][j]`, `out_2d[c][j]` for pixel `pixels[j]`). Exactly the
/// values `sample_1d` and `sample_2d` give, pixel by pixel.
pub struct StreamBatch<'a> {
    pub pixels: &'a [u32],
    pub sample_index: u32,
    pub seed: u32,
    pub dims_1d: [u32; 3],
    pub out_1d: [&'a mut [f32]; 3],
    pub dim_2d: u32,
    pub out_2d: [&'a mut [f32]; 2],
}

impl Kernel for StreamBatch<'_> {
    type Out = ();
    #[inline(always)]
    fn run(self) {
        let StreamBatch {
            pixels,
            sample_index,
            seed,
            dims_1d,
            out_1d,
            dim_2d,
            out_2d,
        } = self;
        let [o0, o1, o2] = out_1d;
        let [ox, oy] = out_2d;
        let n = pixels.len();
        assert!(o0.len() >= n && o1.len() >= n && o2.len() >= n);
        assert!(ox.len() >= n && oy.len() >= n);
        let mut start = 0;
        while start < n {
            let m = (n - start).min(STREAM_LANES);
            let mut px = [0u32; STREAM_LANES];
            px[..m].copy_from_slice(&pixels[start..start + m]);
            let mut v = [0.0f32; STREAM_LANES];
            for (d, o) in [
                (dims_1d[0], &mut *o0),
                (dims_1d[1], &mut *o1),
                (dims_1d[2], &mut *o2),
            ] {
                sample_1d_lanes(&px, sample_index, d, seed, &mut v);
                o[start..start + m].copy_from_slice(&v[..m]);
            }
            let mut w = [0.0f32; STREAM_LANES];
            sample_2d_lanes(&px, sample_index, dim_2d, seed, &mut v, &mut w);
            ox[start..start + m].copy_from_slice(&v[..m]);
            oy[start..start + m].copy_from_slice(&w[..m]);
            start += m;
        }
    }
}

/// Sub-pixel position of frame `frame`'s camera rays, the same for every
/// pixel (the per-frame jitter of a temporal resolve): the first two Sobol
/// dimensions, unscrambled, so every aligned block of 2^m frames is a
/// (0,m,2)-net: 16 frames put one point in each cell of a 4x4 grid (and of
/// the 16x1, 8x2, 2x8 and 1x16 grids) of the pixel. Each point is moved by
/// 1/32 to the middle of its cell of the 16-frame grid: net points sit on
/// cell corners, so 16 of them average to 15/32 instead of 1/2, and one of
/// them is the pixel corner itself, where rays graze the edges of
/// axis-aligned geometry (measured: a 4-frame resolve of room 8x worse over
/// the whole frame). Frame 0 is the pixel centre instead of (17/32, 17/32),
/// so a one-frame render is the unjittered one.
#[inline]
pub fn frame_jitter(frame: u32) -> Vec2 {
    if frame == 0 {
        return Vec2::splat(0.5);
    }
    // The digital shift by 1/2 (xor of the top bit) keeps the nets and puts
    // frame 0's cell at the centre, next to the point frame 0 uses.
    const HALF: u32 = 1 << 31;
    let mid = |bits: u32| (to_unit(bits ^ HALF) + 1.0 / 32.0).fract();
    Vec2::new(
        mid(frame.reverse_bits()),
        mid(sobol_dim1_reversed(frame).reverse_bits()),
    )
}

/// PCG32 (O'Neill 2014, XSH-RR output): a small fast RNG for anything that
/// needs plain independent random numbers (tests, jitter, tie-breaking).
#[derive(Debug, Clone)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    const MULT: u64 = 6_364_136_223_846_793_005;

    /// A generator for `seed` on stream `stream` (distinct streams do not overlap).
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut r = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        to_unit(self.next_u32())
    }

    /// Uniform in [0, 1)².
    pub fn next_vec2(&mut self) -> Vec2 {
        let x = self.next_f32();
        Vec2::new(x, self.next_f32())
    }
}

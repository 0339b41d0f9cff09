//! The display transform, linear radiance to 8-bit sRGB, shared by PNG
//! output, `compare` and the window: exposure (in stops), a smooth
//! per-channel shoulder `1 - exp(-x)` that never clips, then sRGB encoding.
//!
//! `display_rgb8` defines it. `DisplayMap` gives the same bytes for a whole
//! frame at a fraction of the cost: the transform is monotone, so for one
//! exposure each output level starts at one input value, and a level is
//! found from a table indexed by the input's exponent and top mantissa bits
//! plus a comparison with the next level's start, instead of an `exp` and a
//! `powf` per channel.

use glam::Vec3;

/// The display transform of one pixel, `exposure_scale` = 2^stops.
#[inline]
pub fn display_rgb8(c: Vec3, exposure_scale: f32) -> [u8; 3] {
    [
        level(c.x, exposure_scale),
        level(c.y, exposure_scale),
        level(c.z, exposure_scale),
    ]
}

/// One channel of `display_rgb8`: non-finite and negative values show 0.
#[inline]
fn level(x: f32, exposure_scale: f32) -> u8 {
    let x = if x.is_finite() { x.max(0.0) } else { 0.0 } * exposure_scale;
    let t = 1.0 - (-x).exp();
    (srgb_encode(t) * 255.0 + 0.5) as u8
}

#[inline]
fn srgb_encode(x: f32) -> f32 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Bits of an `f32` below the table's index: the index keeps the exponent
/// and 7 mantissa bits, so one entry spans a relative width of at most
/// 2^-7 (normal floats; the subnormals all show 0), over which the
/// transform rises by under half a level (its steepest is 58.8 levels per
/// unit of `ln x`, at any exposure): one comparison finds the level.
const SHIFT: u32 = 16;
/// Entries: every non-negative finite `f32`.
const ENTRIES: usize = (f32::INFINITY.to_bits() >> SHIFT) as usize;

/// `display_rgb8` at one exposure, by table.
#[derive(Clone, Debug)]
pub struct DisplayMap {
    /// `start[k]`: the least input whose level is at least `k` (`start[0]`
    /// = 0; `INFINITY` for a level no finite input reaches, and for 256).
    /// The map reads `split`; the tests check the levels' starts.
    #[cfg(test)]
    start: [f32; 257],
    /// The level of the least input of each table entry.
    first: Vec<u8>,
    /// The start of the next level after `first`, per entry: the two are
    /// read side by side rather than one after the other.
    split: Vec<f32>,
}

impl DisplayMap {
    pub fn new(exposure_scale: f32) -> DisplayMap {
        let mut start = [f32::INFINITY; 257];
        start[0] = 0.0;
        let brightest = level(f32::MAX, exposure_scale);
        // The least level-`k` input by bisection over the bit patterns of
        // the non-negative finite floats, which order as their values.
        let top = f32::MAX.to_bits();
        for (k, s) in start.iter_mut().enumerate().take(256).skip(1) {
            if brightest < k as u8 {
                continue;
            }
            let (mut lo, mut hi) = (0u32, top);
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if level(f32::from_bits(mid), exposure_scale) >= k as u8 {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            *s = f32::from_bits(lo);
        }
        let mut first = Vec::with_capacity(ENTRIES);
        let mut k = 0usize;
        for e in 0..ENTRIES {
            let x = f32::from_bits((e as u32) << SHIFT);
            while k < 255 && x >= start[k + 1] {
                k += 1;
            }
            first.push(k as u8);
        }
        let split = first.iter().map(|&k| start[k as usize + 1]).collect();
        DisplayMap {
            #[cfg(test)]
            start,
            first,
            split,
        }
    }

    /// One comparison and no branch on the value: with a loop over the
    /// levels instead, `cargo bench --bench display` (random radiance) took
    /// 2.6 times as long. The entry's level and its split are independent
    /// loads; a value that is not a finite non-negative float (its bits at
    /// or above infinity's: negative, infinite, NaN) is taken as 0 by a
    /// select.
    #[inline]
    fn level(&self, x: f32) -> u8 {
        let bits = x.to_bits();
        let shown = bits < f32::INFINITY.to_bits();
        let (x, e) = if shown {
            (x, (bits >> SHIFT) as usize)
        } else {
            (0.0, 0)
        };
        self.first[e] + u8::from(x >= self.split[e])
    }

    /// `display_rgb8` of `c` at this map's exposure.
    #[inline]
    pub fn rgb8(&self, c: Vec3) -> [u8; 3] {
        [self.level(c.x), self.level(c.y), self.level(c.z)]
    }

    /// One row of `[r, g, b, _]` linear texels (the upscale's) to 0RGB
    /// window pixels; a non-finite channel shows 0.
    #[inline]
    pub fn row(&self, texels: &[[f32; 4]], out: &mut [u32]) {
        for (p, t) in out.iter_mut().zip(texels) {
            let [r, g, b] = [self.level(t[0]), self.level(t[1]), self.level(t[2])];
            *p = (r as u32) << 16 | (g as u32) << 8 | b as u32;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exposures the tests check, in stops.
    const STOPS: [f32; 5] = [-4.0, -1.0, 0.0, 1.5, 6.0];

    /// The map of each exposure of `STOPS`, with its scale.
    fn maps() -> impl Iterator<Item = (f32, DisplayMap)> {
        STOPS.into_iter().map(|stops| {
            let scale = stops.exp2();
            (scale, DisplayMap::new(scale))
        })
    }

    fn same_as_reference(map: &DisplayMap, scale: f32, x: f32) {
        let want = display_rgb8(Vec3::splat(x), scale)[0];
        assert_eq!(
            map.rgb8(Vec3::splat(x))[0],
            want,
            "input {x:e} at scale {scale}"
        );
    }

    #[test]
    fn the_map_gives_the_reference_bytes_at_every_level_boundary() {
        for (scale, map) in maps() {
            for &s in map.start.iter().filter(|s| s.is_finite()) {
                let below = f32::from_bits(s.to_bits().saturating_sub(1));
                for x in [below, s, f32::from_bits(s.to_bits() + 1)] {
                    same_as_reference(&map, scale, x);
                }
            }
        }
    }

    #[test]
    fn no_table_entry_spans_more_than_one_level() {
        for (scale, map) in maps() {
            for (e, &k) in map.first.iter().enumerate() {
                // The entry's last input: the next entry's first, less one ulp.
                let last = f32::from_bits((((e + 1) as u32) << SHIFT) - 1);
                let k = k as usize;
                assert!(
                    k == 255 || last < map.start[k + 2],
                    "entry {e} spans two levels at scale {scale}"
                );
            }
        }
    }

    #[test]
    fn the_map_gives_the_reference_bytes_over_a_sweep_of_inputs() {
        for (scale, map) in maps() {
            // Every 4093rd bit pattern of the finite non-negative floats,
            // and the edge cases.
            for bits in (0..f32::MAX.to_bits()).step_by(4093) {
                same_as_reference(&map, scale, f32::from_bits(bits));
            }
            for x in [0.0, -0.0, -1.0, f32::MAX, f32::MIN_POSITIVE, 1e-45] {
                same_as_reference(&map, scale, x);
            }
            for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                assert_eq!(
                    map.rgb8(Vec3::splat(x)),
                    display_rgb8(Vec3::splat(x), scale)
                );
            }
        }
    }
}

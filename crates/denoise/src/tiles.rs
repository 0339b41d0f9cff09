//! Tile classification (the FidelityFX shadow denoiser idea): a tile whose
//! accumulated ratio is exactly 1 everywhere (fully lit) or exactly 0 (fully
//! shadowed) needs no filtering, and most of a frame is such tiles.
//!
//! A tile is skipped only when its 8 neighbours are uniform too, so a
//! penumbra that starts just across a tile border still gets filtered on both
//! sides. Skipping cannot change the ratio of a skipped pixel: it keeps its
//! exact 0 or 1, which is what a filter over an all-0 or all-1 neighbourhood
//! would give.

use super::spatial::lanes::{M, V};
use rayon::prelude::*;

/// Tile edge in pixels.
pub const TILE: usize = 8;

pub(crate) const LIT: u8 = 1;
pub(crate) const DARK: u8 = 2;
/// Class bits of an empty tile (or row of a tile): compatible with both.
pub(crate) const UNIFORM: u8 = LIT | DARK;

pub(crate) struct Tiles {
    pub tw: usize,
    pub th: usize,
    /// AND of the per-pixel class bits; nonzero = uniform (or empty).
    class: Vec<u8>,
    skip: Vec<bool>,
    /// Skipped tiles that a filtered tile's taps can reach (see
    /// [`Tiles::mark_halo`]).
    halo: Vec<bool>,
}

impl Tiles {
    pub fn new(width: u32, height: u32) -> Tiles {
        let tw = (width as usize).div_ceil(TILE);
        let th = (height as usize).div_ceil(TILE);
        Tiles {
            tw,
            th,
            class: vec![0; tw * th],
            skip: vec![false; tw * th],
            halo: vec![false; tw * th],
        }
    }

    pub fn count(&self) -> usize {
        self.tw * self.th
    }

    /// Number of tile columns.
    #[inline]
    pub fn columns(&self) -> usize {
        self.tw
    }

    #[inline]
    pub fn skipped(&self, tx: usize, ty: usize) -> bool {
        self.skip[ty * self.tw + tx]
    }

    /// Whether skipped tile (tx, ty) lies within the reach of a filtered
    /// tile's taps, as the last [`Tiles::mark_halo`] found.
    #[inline]
    pub fn halo(&self, tx: usize, ty: usize) -> bool {
        self.halo[ty * self.tw + tx]
    }

    /// Marks the skipped tiles with a filtered tile at most `reach` tiles
    /// away (in x and in y): the only skipped tiles whose values an
    /// à-trous tap reads. The filter copies no others into its ping-pong
    /// planes, which on a mostly settled frame is most of that copy.
    pub fn mark_halo(&mut self, reach: usize) {
        let (tw, th) = (self.tw, self.th);
        let skip = &self.skip;
        self.halo
            .par_chunks_mut(tw)
            .enumerate()
            .for_each(|(ty, row)| {
                let rows = ty.saturating_sub(reach)..(ty + reach + 1).min(th);
                for (tx, h) in row.iter_mut().enumerate() {
                    let cols = tx.saturating_sub(reach)..(tx + reach + 1).min(tw);
                    *h = skip[ty * tw + tx]
                        && rows
                            .clone()
                            .any(|ny| cols.clone().any(|nx| !skip[ny * tw + nx]));
                }
            });
    }

    /// The class bits of tile `t` (`LIT`, `DARK`, both for an empty tile,
    /// 0 for a mixed one) from the last `classify`.
    #[inline]
    pub fn class(&self, t: usize) -> u8 {
        self.class[t]
    }

    /// Combines the per-row classes of each tile (`row_class`: one byte per
    /// pixel row and tile column, from the temporal pass), marks the
    /// skippable tiles and returns how many are skipped.
    pub fn classify(&mut self, row_class: &[u8], height: usize, enabled: bool) -> usize {
        if !enabled {
            self.skip.fill(false);
            return 0;
        }
        let tw = self.tw;
        self.class
            .par_chunks_mut(tw)
            .enumerate()
            .for_each(|(ty, row)| {
                for (tx, c) in row.iter_mut().enumerate() {
                    *c = (ty * TILE..((ty + 1) * TILE).min(height))
                        .fold(UNIFORM, |bits, y| bits & row_class[y * tw + tx]);
                }
            });
        let (tw, th) = (self.tw, self.th);
        let class = &self.class;
        self.skip
            .par_chunks_mut(tw)
            .enumerate()
            .for_each(|(ty, row)| {
                for (tx, s) in row.iter_mut().enumerate() {
                    let mut uniform = true;
                    for ny in ty.saturating_sub(1)..(ty + 2).min(th) {
                        for nx in tx.saturating_sub(1)..(tx + 2).min(tw) {
                            uniform &= class[ny * tw + nx] != 0;
                        }
                    }
                    *s = uniform;
                }
            });
        self.skip.iter().filter(|&&s| s).count()
    }
}

/// The class bits all of a lane group's surface pixels share (`surface`
/// per lane; `UNIFORM` when it has none): `LIT` where `S_N == U_N`, `DARK`
/// where `S_N` is 0. Exact tests on purpose: the ratio of a skipped pixel
/// must be exactly what filtering would give, and only exact 0 and 1
/// guarantee that. A pixel with no light at all (both zero) fits either
/// class.
#[inline(always)]
pub(crate) fn group_class(surface: &[bool], un: &[V; 3], sn: &[V; 3]) -> u8 {
    let zero = V::splat(0.0);
    let lit = (0..3).fold(M::from_fn(|_| true), |m, c| m.and(sn[c].eq(un[c])));
    let dark = (0..3).fold(M::from_fn(|_| true), |m, c| m.and(sn[c].eq(zero)));
    let mut class = UNIFORM;
    for (l, &s) in surface.iter().enumerate() {
        if s {
            class &= (u8::from(lit.lane(l)) * LIT) | (u8::from(dark.lane(l)) * DARK);
        }
    }
    class
}

//! The LTC table: storage, (de)serialisation, the embedded copy and bilinear
//! lookup. The table is produced by `ltc_fit` (see there for how to
//! regenerate `data/ltc_64.bin`).
//!
//! Convention. In the shading frame (z = normal, x = the view's tangential
//! direction, so the view is `(sin θv, 0, cos θv)`), the specular integrand
//! with Schlick Fresnel splits into two lobes,
//! `f_spec(F=1) cos = A(w)` and `f_spec(F=1) cos (1 - wo.h)^5 = B(w)`, so that
//! `f_spec cos = F0 A + (1 - F0) B`. Each lobe gets its own linearly
//! transformed cosine: `A ~ mag D_A / hmass` and `B ~ fres D_B / fhmass` on the
//! upper hemisphere, each mixed with a plain clamped cosine about the normal:
//! `A ~ mag ((1 - mix) D_A / hmass + mix cos/π)`, and likewise `B` with
//! `fmix`. The cosine's integral over the light is the Lambert form factor,
//! which U computes anyway, so the mixture costs nothing at run time, and it
//! lets the fit follow rough lobes, which are flatter than any single
//! transformed cosine (at alpha = 1 and normal view `f cos` is nearly
//! uniform). (One shared shape for both, as Heitz et al. do, was the
//! largest error of U for dielectrics: `B` sits further from the view than
//! `A`, and at F0 = 0.04 it carries most of the highlight at grazing views.)
//! A cell stores, per lobe, `M^-1 = [[m00, 0, m02], [0, 1, 0], [m20, 0, m22]]`
//! (normalised so the middle element is 1: the LTC is scale invariant), the
//! lobe's integral over the hemisphere (`mag`, `fres`) and the mass of its `D`
//! above the horizon (`hmass`, `fhmass`: the BRDF is zero below it, so we clip
//! there and renormalise); and `err`, the fit's error on polygon integrals
//! (diagnostic only, see `ltc_fit`).

use super::lanes::{LANES, Wide};
use glam::{DMat3, Mat4, Vec4};
use std::sync::OnceLock;

/// Values per cell, in this order.
pub const FIELDS: usize = 15;
const MAGIC: &[u8; 4] = b"PLTC";
const VERSION: u32 = 2;

/// One table cell (or an interpolation of four).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LtcCell {
    pub m00: f32,
    pub m02: f32,
    pub m20: f32,
    pub m22: f32,
    pub mag: f32,
    pub hmass: f32,
    pub mix: f32,
    pub f00: f32,
    pub f02: f32,
    pub f20: f32,
    pub f22: f32,
    pub fres: f32,
    pub fhmass: f32,
    pub fmix: f32,
    pub err: f32,
}

impl LtcCell {
    pub fn to_array(&self) -> [f32; FIELDS] {
        [
            self.m00,
            self.m02,
            self.m20,
            self.m22,
            self.mag,
            self.hmass,
            self.mix,
            self.f00,
            self.f02,
            self.f20,
            self.f22,
            self.fres,
            self.fhmass,
            self.fmix,
            self.err,
        ]
    }

    pub fn from_array(a: [f32; FIELDS]) -> LtcCell {
        LtcCell {
            m00: a[0],
            m02: a[1],
            m20: a[2],
            m22: a[3],
            mag: a[4],
            hmass: a[5],
            mix: a[6],
            f00: a[7],
            f02: a[8],
            f20: a[9],
            f22: a[10],
            fres: a[11],
            fhmass: a[12],
            fmix: a[13],
            err: a[14],
        }
    }

    /// `M^-1` of the F0 lobe `A` as a matrix (column-major, as glam stores it).
    pub fn inv_matrix(&self) -> DMat3 {
        inv_matrix([self.m00, self.m02, self.m20, self.m22])
    }

    /// `M^-1` of the Schlick lobe `B`.
    pub fn fresnel_inv_matrix(&self) -> DMat3 {
        inv_matrix([self.f00, self.f02, self.f20, self.f22])
    }
}

fn inv_matrix([m00, m02, m20, m22]: [f32; 4]) -> DMat3 {
    DMat3::from_cols_array(&[
        m00 as f64, 0.0, m20 as f64, 0.0, 1.0, 0.0, m02 as f64, 0.0, m22 as f64,
    ])
}

/// A `size x size` table over roughness (column index `i`, roughness
/// `i / (size - 1)`) and `sqrt(1 - cos θv)` (row index `j`, value
/// `j / (size - 1)`).
#[derive(Clone, Debug, PartialEq)]
pub struct LtcTable {
    pub size: usize,
    /// Row-major: `cells[j * size + i]`.
    pub cells: Vec<LtcCell>,
}

impl LtcTable {
    pub fn cell(&self, i_rough: usize, j_view: usize) -> &LtcCell {
        &self.cells[j_view * self.size + i_rough]
    }

    /// Roughness of column `i`.
    pub fn roughness_at(size: usize, i: usize) -> f32 {
        i as f32 / (size - 1) as f32
    }

    /// cos θv of row `j`.
    pub fn cos_view_at(size: usize, j: usize) -> f32 {
        let u = j as f32 / (size - 1) as f32;
        1.0 - u * u
    }

    /// Little-endian: "PLTC", version, size, fields, then `f32` cells.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(16 + self.cells.len() * FIELDS * 4);
        out.extend_from_slice(MAGIC);
        for w in [VERSION, self.size as u32, FIELDS as u32] {
            out.extend_from_slice(&w.to_le_bytes());
        }
        for c in &self.cells {
            for v in c.to_array() {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        out
    }

    pub fn from_bytes(bytes: &[u8]) -> Result<LtcTable, String> {
        let word = |k: usize| -> Result<u32, String> {
            let b = bytes
                .get(4 + 4 * k..8 + 4 * k)
                .ok_or("LTC table: truncated header")?;
            Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        if bytes.get(..4) != Some(MAGIC.as_slice()) {
            return Err("LTC table: bad magic (expected PLTC)".into());
        }
        let (version, size, fields) = (word(0)?, word(1)? as usize, word(2)? as usize);
        if version != VERSION || fields != FIELDS || size < 2 {
            return Err(format!(
                "LTC table: unsupported version {version}, size {size}, fields {fields}"
            ));
        }
        let body = &bytes[16..];
        if body.len() != size * size * FIELDS * 4 {
            return Err(format!(
                "LTC table: {} data bytes, expected {}",
                body.len(),
                size * size * FIELDS * 4
            ));
        }
        let cells = body
            .chunks_exact(FIELDS * 4)
            .map(|c| {
                let mut a = [0.0f32; FIELDS];
                for (k, v) in a.iter_mut().enumerate() {
                    v.clone_from(&f32::from_le_bytes([
                        c[4 * k],
                        c[4 * k + 1],
                        c[4 * k + 2],
                        c[4 * k + 3],
                    ]));
                }
                LtcCell::from_array(a)
            })
            .collect();
        Ok(LtcTable { size, cells })
    }

    /// Bilinear lookup at a roughness in [0, 1] and a view cosine (clamped to
    /// [0, 1]: views below the horizon, which shading normals produce, are
    /// treated as grazing).
    #[inline]
    pub fn lookup(&self, roughness: f32, cos_view: f32) -> LtcCell {
        let (i0, j0, fx, fy) = cell_coords(self.size, roughness, cos_view);
        let a = self.cell(i0, j0).to_array();
        let b = self.cell(i0 + 1, j0).to_array();
        let c = self.cell(i0, j0 + 1).to_array();
        let d = self.cell(i0 + 1, j0 + 1).to_array();
        let [w00, w10, w01, w11] = bilinear_weights(fx, fy);
        let mut r = [0.0f32; FIELDS];
        for k in 0..FIELDS {
            r[k] = d[k].mul_add(w11, c[k].mul_add(w01, b[k].mul_add(w10, a[k] * w00)));
        }
        LtcCell::from_array(r)
    }
}

/// The fitted 64x64 table, committed under `data/` and compiled in.
pub static EMBEDDED_LTC_64: &[u8] = include_bytes!("../../../../data/ltc_64.bin");

/// The table cell below (roughness, view) and the bilinear weights inside it,
/// for a table of `size` cells per axis (rows by sqrt(1 - cos_view)).
#[inline]
fn cell_coords(size: usize, roughness: f32, cos_view: f32) -> (usize, usize, f32, f32) {
    let n = (size - 1) as f32;
    let x = roughness.clamp(0.0, 1.0) * n;
    let y = (1.0 - cos_view.clamp(0.0, 1.0)).sqrt() * n;
    let (i0, j0) = ((x as usize).min(size - 2), (y as usize).min(size - 2));
    (i0, j0, x - i0 as f32, y - j0 as f32)
}

/// The weights of the cells (i0, j0), (i0 + 1, j0), (i0, j0 + 1) and
/// (i0 + 1, j0 + 1) at `(fx, fy)` inside the cell. A blend is then one
/// product and three multiply-adds per value (against three lerps, nine
/// operations); every lookup blends with them in this order, so the
/// scalar and lane lookups agree bit for bit.
#[inline(always)]
fn bilinear_weights(fx: f32, fy: f32) -> [f32; 4] {
    let (gx, gy) = (1.0 - fx, 1.0 - fy);
    [gx * gy, fx * gy, gx * fy, fx * fy]
}

/// The embedded table, parsed once.
pub fn table() -> &'static LtcTable {
    static TABLE: OnceLock<LtcTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        LtcTable::from_bytes(EMBEDDED_LTC_64)
            .expect("data/ltc_64.bin is a valid table (checked by a test)")
    })
}

/// The table as U reads it: each cell's fields padded to 16 `f32` in one
/// aligned block, so the bilinear blend of four cells runs as straight
/// 4-wide vector arithmetic instead of field-by-field conversions. Same data,
/// same arithmetic as `LtcTable::lookup` (a test checks equality bit for bit).
#[derive(Clone, Debug)]
pub struct PackedLtc {
    size: usize,
    cells: Vec<PackedCell>,
}

#[derive(Clone, Copy, Debug)]
#[repr(align(64))]
struct PackedCell([f32; 16]);

impl PackedLtc {
    pub fn new(table: &LtcTable) -> PackedLtc {
        let cells = table
            .cells
            .iter()
            .map(|c| PackedCell(packed_fields(c)))
            .collect();
        PackedLtc {
            size: table.size,
            cells,
        }
    }

    /// `LtcTable::lookup`, on the packed cells.
    #[inline]
    pub fn lookup(&self, roughness: f32, cos_view: f32) -> LtcCell {
        let mut r = [0.0f32; 16];
        for (k, v) in self.lookup_packed(roughness, cos_view).iter().enumerate() {
            v.write_to_slice(&mut r[4 * k..4 * k + 4]);
        }
        let mut out = [0.0f32; FIELDS];
        out.copy_from_slice(&r[..FIELDS]);
        LtcCell::from_array(out)
    }

    /// `lookup`'s fields as they are blended: `LtcCell::to_array` order,
    /// four per `Vec4`, the 16th 0. What a batch transposes into lanes
    /// (`CellLanes`) without unpacking a cell.
    #[inline]
    pub fn lookup_packed(&self, roughness: f32, cos_view: f32) -> [Vec4; 4] {
        let (i0, j0, fx, fy) = cell_coords(self.size, roughness, cos_view);
        self.blend(j0 * self.size + i0, bilinear_weights(fx, fy))
    }
}

impl PackedLtc {
    /// `lookup_packed` of a batch's pixels into `out[l]` (lane `l` = pixel
    /// `l`), each cell's 16 values as `packed_fields` orders them. The cell
    /// coordinates are computed across the lanes and each lane's blend runs
    /// over its 16 fields at once (two 8-wide vectors at AVX2, where four
    /// `Vec4` took four): the same cells bit for bit for finite inputs (a
    /// test checks it; a NaN reads cell (0, 0) here).
    #[inline(always)]
    pub fn lookup_cells(&self, roughness: Wide, cos_view: Wide, out: &mut [[f32; 16]; LANES]) {
        let n = Wide::splat((self.size - 1) as f32);
        let x = roughness.clamp(0.0f32, 1.0f32) * n;
        let y = (Wide::ONE - cos_view.clamp(0.0f32, 1.0f32)).sqrt() * n;
        // x, y in [0, size - 1]: truncation as `cell_coords`' `as usize`.
        let last = self.size as i32 - 2;
        // Plain loops: `[T; N]::map` and `array::from_fn` are compiled out
        // of line, at baseline whatever level the caller runs (`isa`).
        let (mut i0, mut j0) = ([0i32; LANES], [0i32; LANES]);
        let (mut fi, mut fj) = (Wide::ZERO, Wide::ZERO);
        for l in 0..LANES {
            i0[l] = (x.0[l] as i32).min(last);
            j0[l] = (y.0[l] as i32).min(last);
            fi.0[l] = i0[l] as f32;
            fj.0[l] = j0[l] as f32;
        }
        let (fx, fy) = (x - fi, y - fj);
        // `bilinear_weights` across the lanes.
        let (gx, gy) = (Wide::ONE - fx, Wide::ONE - fy);
        let w = [gx * gy, fx * gy, gx * fy, fx * fy];
        for (l, cell) in out.iter_mut().enumerate() {
            let k = j0[l] as usize * self.size + i0[l] as usize;
            *cell = self.blend16(k, [w[0].0[l], w[1].0[l], w[2].0[l], w[3].0[l]]);
        }
    }

    /// The bilinear blend of cells `k`, `k + 1` and the two above them,
    /// with their weights `w` (`bilinear_weights`), all 16 values at once.
    #[inline(always)]
    fn blend16(&self, k: usize, [w00, w10, w01, w11]: [f32; 4]) -> [f32; 16] {
        let (a, b) = (&self.cells[k].0, &self.cells[k + 1].0);
        let (c, d) = (
            &self.cells[k + self.size].0,
            &self.cells[k + self.size + 1].0,
        );
        let mut out = [0.0f32; 16];
        for (f, out) in out.iter_mut().enumerate() {
            *out = d[f].mul_add(w11, c[f].mul_add(w01, b[f].mul_add(w10, a[f] * w00)));
        }
        out
    }

    /// `blend16` as four `Vec4` (`lookup_packed`).
    #[inline(always)]
    fn blend(&self, k: usize, w: [f32; 4]) -> [Vec4; 4] {
        let v = self.blend16(k, w);
        [0, 4, 8, 12].map(|i| Vec4::from_slice(&v[i..i + 4]))
    }
}

/// A cell's fields as `PackedLtc::lookup_cells` gives each lane: in
/// `LtcCell::to_array` order, the 16th 0.
#[inline(always)]
pub fn packed_fields(c: &LtcCell) -> [f32; 16] {
    let mut a = [0.0f32; 16];
    a[..FIELDS].copy_from_slice(&c.to_array());
    a
}

/// The cells of four pixels (one per lane, as `lanes::Wide`), field by
/// field: one `Vec4` per field, in `LtcCell::to_array` order. What the
/// batched U's setup computes with across pixels.
#[derive(Clone, Copy, Debug)]
pub struct CellLanes([Vec4; 16]);

impl CellLanes {
    /// `cell` in every lane.
    pub fn splat(cell: &LtcCell) -> CellLanes {
        let mut f = [Vec4::ZERO; 16];
        for (f, v) in f.iter_mut().zip(cell.to_array()) {
            *f = Vec4::splat(v);
        }
        CellLanes(f)
    }

    /// The fields of `lo` (lanes 0-3) and `hi` (lanes 4-7) as eight
    /// lanes each.
    #[inline(always)]
    pub fn join(lo: &CellLanes, hi: &CellLanes) -> [Wide; 16] {
        let mut out = [Wide::ZERO; 16];
        for (f, out) in out.iter_mut().enumerate() {
            *out = Wide::from_halves(lo.0[f], hi.0[f]);
        }
        out
    }

    /// Lane `l` from `cells[l]` (as `lookup_packed` gives them): four 4x4
    /// transposes.
    #[inline(always)]
    pub fn from_packed(cells: &[[Vec4; 4]; 4]) -> CellLanes {
        let mut f = [Vec4::ZERO; 16];
        for k in 0..4 {
            let t = Mat4::from_cols(cells[0][k], cells[1][k], cells[2][k], cells[3][k]).transpose();
            f[4 * k] = t.x_axis;
            f[4 * k + 1] = t.y_axis;
            f[4 * k + 2] = t.z_axis;
            f[4 * k + 3] = t.w_axis;
        }
        CellLanes(f)
    }

    /// `M^-1` of lobe A (m00, m02, m20, m22) across the lanes.
    #[inline]
    pub fn ma(&self) -> [Vec4; 4] {
        [self.0[0], self.0[1], self.0[2], self.0[3]]
    }
    #[inline]
    pub fn mag(&self) -> Vec4 {
        self.0[4]
    }
    #[inline]
    pub fn hmass(&self) -> Vec4 {
        self.0[5]
    }
    #[inline]
    pub fn mix(&self) -> Vec4 {
        self.0[6]
    }
    /// `M^-1` of lobe B (f00, f02, f20, f22) across the lanes.
    #[inline]
    pub fn mb(&self) -> [Vec4; 4] {
        [self.0[7], self.0[8], self.0[9], self.0[10]]
    }
    #[inline]
    pub fn fres(&self) -> Vec4 {
        self.0[11]
    }
    #[inline]
    pub fn fhmass(&self) -> Vec4 {
        self.0[12]
    }
    #[inline]
    pub fn fmix(&self) -> Vec4 {
        self.0[13]
    }
}

/// The embedded table, packed for U, built once.
pub fn packed_table() -> &'static PackedLtc {
    static PACKED: OnceLock<PackedLtc> = OnceLock::new();
    PACKED.get_or_init(|| PackedLtc::new(table()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedded_table_parses_and_round_trips() {
        let t = table();
        assert_eq!(t.size, 64);
        assert_eq!(&LtcTable::from_bytes(&t.to_bytes()).unwrap(), t);
        for c in &t.cells {
            assert!(c.to_array().iter().all(|v| v.is_finite()));
            assert!(c.mag > 0.0 && c.hmass > 0.0 && c.fres >= 0.0 && c.fhmass > 0.0);
        }
    }

    #[test]
    fn cell_lanes_hold_each_lanes_cell_field_by_field() {
        let p = packed_table();
        let at = [(0.1, 0.9), (0.5, 0.2), (0.93, 0.6), (0.3, 0.01)];
        let cells = at.map(|(r, c)| p.lookup(r, c));
        let lanes = CellLanes::from_packed(&at.map(|(r, c)| p.lookup_packed(r, c)));
        for (l, c) in cells.iter().enumerate() {
            let ma = lanes.ma().map(|v| v[l]);
            let mb = lanes.mb().map(|v| v[l]);
            assert_eq!(ma, [c.m00, c.m02, c.m20, c.m22]);
            assert_eq!(mb, [c.f00, c.f02, c.f20, c.f22]);
            let rest = [lanes.mag(), lanes.hmass(), lanes.mix()].map(|v| v[l]);
            assert_eq!(rest, [c.mag, c.hmass, c.mix]);
            let rest = [lanes.fres(), lanes.fhmass(), lanes.fmix()].map(|v| v[l]);
            assert_eq!(rest, [c.fres, c.fhmass, c.fmix]);
        }
        let one = CellLanes::splat(&cells[2]);
        assert_eq!(one.mb().map(|v| v[3]), lanes.mb().map(|v| v[2]));
    }

    #[test]
    fn lane_lookup_equals_one_pixel_lookup_bit_for_bit() {
        let p = packed_table();
        // As below, on a coarser grid, eight different pixels at a time.
        let at = |i: usize| -0.02 + 1.04 * (i % 301) as f32 / 300.0;
        for i in 0..301 * 8 {
            let r = Wide::from_fn(|l| at(i + 37 * l));
            let c = Wide::from_fn(|l| at(i / 8 + 101 * l));
            let mut cells = [[0.0f32; 16]; LANES];
            p.lookup_cells(r, c, &mut cells);
            for (l, cell) in cells.iter().enumerate() {
                let want = p.lookup_packed(r.0[l], c.0[l]);
                for (f, value) in cell.iter().enumerate() {
                    assert_eq!(
                        value.to_bits(),
                        want[f / 4][f % 4].to_bits(),
                        "{r:?} {c:?} lane {l} field {f}"
                    );
                }
            }
        }
    }

    #[test]
    fn packed_lookup_equals_table_lookup_bit_for_bit() {
        let (t, p) = (table(), packed_table());
        // Cell centres, cell edges, the table's borders and out-of-range
        // inputs (clamped): 0.0013 steps do not divide the 1/63 grid.
        for i in 0..=800 {
            let r = -0.02 + 1.04 * i as f32 / 800.0;
            for j in 0..=800 {
                let cv = -0.02 + 1.04 * j as f32 / 800.0;
                assert_eq!(
                    p.lookup(r, cv),
                    t.lookup(r, cv),
                    "roughness {r}, cos_view {cv}"
                );
            }
        }
    }
}

//! The analytic `U` of a band of pixels: per tile, the lights that matter
//! (culling to a stated tolerance of the tile's `U`), then each light's
//! lobes in lanes across pixels (`u_batch`), far lights' Lambert lobe in
//! wide `f32` vectors (`far_light`), and the scalar path where the lanes'
//! rounding bound asks for it.

use crate::gbuffer::{GSample, PixelKind};
use crate::world::World;
use glam::Vec3;
use penumbra_kernels::shading::SurfacePoint;
use penumbra_kernels::shading::brdf::alpha_from_roughness;
use penumbra_kernels::shading::far_light::{
    WidePoints, form_factor_rounding, form_factors, ggx_bounds,
};
use penumbra_kernels::shading::light_bound::{FarView, LobeBound, PointGroup};
use penumbra_kernels::shading::u_batch::{
    LANES, LaneCounts, LaneLobes, PixelBatch, diffuse_batch, lobes_batch,
};
use penumbra_scene::Light;
use penumbra_scene::color::luminance;

use super::surface_point;

/// Columns and rows of the tiles over which the `U` stage culls lights: a
/// tile is a band's height (`frame::BAND_ROWS`), so it never spans two
/// bands.
pub const CULL_COLUMNS: usize = 8;
pub const CULL_ROWS: usize = 4;

/// The share of the culling budget the left-out GGX lobes may take; the
/// lights culled whole take the rest.
const GGX_SHARE: f32 = 0.8;

/// Scenes with fewer lights evaluate every light everywhere: on room's two
/// lights the culling's per-tile work cost more than it saved (`penumbra
/// bench scenes/room.toml --only unshadowed --light-tolerance T`, 0.02 and 0
/// alternated twice: U 224 and 230 against 205 and 214 ns per pixel).
const CULL_MIN_LIGHTS: usize = 3;

/// How the `U` stage's (pixel, light) pairs of surface pixels went.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UCounts {
    /// The lanes of the batched path (`shading::u_batch`).
    pub lanes: LaneCounts,
    /// Pairs with both lobes evaluated.
    pub full: u64,
    /// Pairs whose GGX lobe was left out, its bound being negligible.
    pub diffuse_only: u64,
    /// Of those, the pairs whose Lambert lobe the wide `f32` kernel gave
    /// (`shading::far_light`).
    pub lambert_wide: u64,
    /// Pairs left out, their bound being negligible (or zero).
    pub culled: u64,
}

/// Analytic unshadowed light of every light at every pixel of a band (the
/// frame's `U` stage), `LANES` pixels at a time through the batched `U`
/// (`shading::u_batch`; the lanes it cannot vouch for take the scalar
/// path inside it): `per_light[k * lights + i]` gets light `i` at
/// pixel `k`, `u[k]` their sum and `spec_share[k]` the specular lobe's share
/// of it (luminance; 0 where `U` is 0). Zero off surfaces. `gbuf` holds rows
/// of `row_len` pixels.
///
/// Light culling, per tile of `CULL_COLUMNS` x `CULL_ROWS` pixels: the
/// lights are taken in decreasing order of their bound over the tile
/// (`shading::light_bound`), and the rest are left out (zero) once their
/// bounds, with what the lobes left out before may cost, sum to at most
/// `tolerance` times the smallest `U` so far of a surface pixel of the
/// tile. A light's GGX lobe is left out while the lobes left out stay under
/// `GGX_SHARE` of that budget: over the whole tile by the tile's bound, or
/// per run of `LANES` pixels by each point's own bound when the light is
/// far (`shading::far_light`, which then also gives its Lambert lobe). So
/// every surface pixel's `U` (luminance) is within `tolerance` of what
/// every light would give it. `tolerance` 0, or fewer than
/// `CULL_MIN_LIGHTS` lights, evaluates every light at every pixel.
// Out of line: a stage of `make profile` (scripts/profile.py).
#[inline(never)]
pub fn analytic_u_band(
    world: &World,
    gbuf: &[GSample],
    row_len: usize,
    tolerance: f32,
    per_light: &mut [Vec3],
    u: &mut [Vec3],
    spec_share: &mut [f32],
) -> UCounts {
    let n = world.lights.len();
    let mut counts = UCounts::default();
    per_light[..gbuf.len() * n].fill(Vec3::ZERO);
    u[..gbuf.len()].fill(Vec3::ZERO);
    // The specular luminance until the end, then its share.
    spec_share[..gbuf.len()].fill(0.0);
    if n == 0 || gbuf.is_empty() {
        return counts;
    }
    let row_len = row_len.clamp(1, gbuf.len());
    let rows = gbuf.len().div_ceil(row_len);
    let mut tile = Tile::default();
    let mut out = TileOut {
        per_light,
        u,
        spec_share,
        lights: n,
    };
    let culling = culls(tolerance, n);
    for r0 in (0..rows).step_by(CULL_ROWS) {
        for x0 in (0..row_len).step_by(CULL_COLUMNS) {
            tile.gather(gbuf, row_len, (r0, (r0 + CULL_ROWS).min(rows)), x0, culling);
            if tile.count > 0 {
                tile.shade(world, tolerance, &mut out, &mut counts);
                tile.write(&mut out);
            }
        }
    }
    for (share, total) in out.spec_share.iter_mut().zip(&out.u[..gbuf.len()]) {
        let lt = luminance(*total);
        *share = if lt > 0.0 { *share / lt } else { 0.0 };
    }
    counts
}

/// Where a tile's `U` goes (see `analytic_u_band`).
struct TileOut<'a> {
    per_light: &'a mut [Vec3],
    u: &'a mut [Vec3],
    spec_share: &'a mut [f32],
    lights: usize,
}

/// Up to `LANES` pixels of a row, as the batched path reads them, and
/// their sums over the lights so far, lane by lane.
struct Run {
    /// Its first pixel in the band.
    k0: usize,
    /// Its surface points: `points[first..first + count]` of the tile.
    first: usize,
    count: usize,
    /// Bit `l`: lane `l` holds a surface point.
    surface: u32,
    batch: PixelBatch,
    /// `U` so far, per channel, and its specular part's luminance (0 in
    /// lanes without a surface point).
    u: [[f32; LANES]; 3],
    spec: [f32; LANES],
    /// The luminance of `U` so far (the culling's and the shape
    /// correction's measure; summed light by light).
    kept: [f32; LANES],
}

impl Run {
    fn new() -> Run {
        Run {
            k0: 0,
            first: 0,
            count: 0,
            surface: 0,
            batch: PixelBatch::blank(),
            u: [[0.0; LANES]; 3],
            spec: [0.0; LANES],
            kept: [0.0; LANES],
        }
    }

    /// The tile's point index and the lane of each surface point.
    fn lanes(&self) -> impl Iterator<Item = (usize, usize)> + use<> {
        let surface = self.surface;
        (self.first..).zip((0..LANES).filter(move |&l| surface & (1 << l) != 0))
    }

    /// Adds light `light`'s Lambert lobe `d` (its GGX lobe left out) at
    /// lane `l`.
    #[inline]
    fn add_diffuse(&mut self, out: &mut TileOut, l: usize, light: usize, d: Vec3) {
        out.per_light[(self.k0 + l) * out.lights + light] = d;
        for (c, u) in self.u.iter_mut().enumerate() {
            u[l] += d[c];
        }
        self.kept[l] += luminance(d);
    }

    /// Adds one light's lobes of every lane (zero in lanes without a
    /// surface point, which stay 0).
    #[inline]
    fn add_lanes(&mut self, out: &mut TileOut, light: usize, lobes: &LaneLobes) {
        let mut total = [[0.0f32; LANES]; 3];
        for (c, (total, u)) in total.iter_mut().zip(&mut self.u).enumerate() {
            for (l, (t, u)) in total.iter_mut().zip(u.iter_mut()).enumerate() {
                *t = lobes.diffuse[c][l] + lobes.specular[c][l];
                *u += *t;
            }
        }
        for (l, (spec, kept)) in self.spec.iter_mut().zip(&mut self.kept).enumerate() {
            let s = Vec3::new(
                lobes.specular[0][l],
                lobes.specular[1][l],
                lobes.specular[2][l],
            );
            let t = Vec3::new(total[0][l], total[1][l], total[2][l]);
            *spec += luminance(s);
            *kept += luminance(t);
        }
        let lights = out.lights;
        for (_, l) in self.lanes() {
            out.per_light[(self.k0 + l) * lights + light] =
                Vec3::new(total[0][l], total[1][l], total[2][l]);
        }
    }
}

/// One tile of the `U` stage: its surface points as the batched path, the
/// bounds and the wide Lambert kernel read them, and the working state of
/// its light loop; reused from tile to tile.
#[derive(Default)]
struct Tile {
    /// The runs of up to `LANES` pixels of a row that hold surface points:
    /// the first `live` (slots past them are kept for their storage, the
    /// batches being built in place).
    runs: Vec<Run>,
    live: usize,
    /// How many surface points the runs hold.
    count: usize,
    /// The runs' surface points, run after run: kept only where the tile
    /// culls (`culls`), whose bounds read them all at once.
    points: Vec<SurfacePoint>,
    wide: WidePoints,
    form_factors: Vec<f32>,
    order: Vec<(usize, LobeBound)>,
    /// `rest[j]`: the bounds of the lights from `order[j]` on.
    rest: Vec<f32>,
    /// What the lobes left out at each point may cost (luminance).
    spent: Vec<f32>,
    /// Per point, the bound on one far light's GGX lobe.
    ggx: Vec<f32>,
    /// Per run: whether it leaves the light's GGX lobe out.
    leave_out: Vec<bool>,
    /// Whether `wide` holds this tile's points.
    wide_ready: bool,
}

impl Tile {
    /// The surface pixels of rows `rows` and columns `x0..x0 + CULL_COLUMNS`.
    fn gather(
        &mut self,
        gbuf: &[GSample],
        row_len: usize,
        rows: (usize, usize),
        x0: usize,
        culling: bool,
    ) {
        self.live = 0;
        self.count = 0;
        self.points.clear();
        for r in rows.0..rows.1 {
            let row = r * row_len;
            for c0 in (x0..(x0 + CULL_COLUMNS).min(row_len)).step_by(LANES) {
                let k0 = row + c0;
                if k0 >= gbuf.len() {
                    break;
                }
                let len = LANES.min(row_len - c0).min(gbuf.len() - k0);
                if self.live == self.runs.len() {
                    self.runs.push(Run::new());
                }
                // The points go straight into the run's batch; the tile's
                // list of them is kept only for the culling to read.
                let run = &mut self.runs[self.live];
                let first = self.count;
                let mut surface = 0;
                let lanes = run.batch.points_mut();
                for (l, g) in gbuf[k0..k0 + len].iter().enumerate() {
                    if g.kind == PixelKind::Surface {
                        lanes[l] = surface_point(g);
                        surface |= 1 << l;
                        if culling {
                            self.points.push(lanes[l]);
                        }
                    }
                }
                if surface == 0 {
                    continue;
                }
                self.live += 1;
                run.batch.set_active(surface);
                run.k0 = k0;
                run.first = first;
                run.count = surface.count_ones() as usize;
                self.count += run.count;
                run.surface = surface;
                run.u = [[0.0; LANES]; 3];
                run.spec = [0.0; LANES];
                run.kept = [0.0; LANES];
            }
        }
    }

    /// The tile's `U`, and its specular part's luminance, into `out`.
    fn write(&self, out: &mut TileOut) {
        for run in &self.runs[..self.live] {
            for (_, l) in run.lanes() {
                let k = run.k0 + l;
                out.u[k] = Vec3::new(run.u[0][l], run.u[1][l], run.u[2][l]);
                out.spec_share[k] = run.spec[l];
            }
        }
    }

    /// The tile's points in `wide`, once per tile.
    fn prepare_wide(&mut self) {
        if self.wide_ready {
            return;
        }
        self.wide.clear();
        for sp in &self.points {
            let alpha = alpha_from_roughness(sp.roughness);
            self.wide
                .push(sp.p, sp.n, sp.wo, alpha, sp.specular.max_element());
        }
        self.wide.finish();
        let count = self.points.len();
        self.form_factors.resize(count, 0.0);
        self.ggx.resize(count, 0.0);
        self.wide_ready = true;
    }

    /// Every light's `U` at the tile's points, culled to `tolerance`.
    fn shade(&mut self, world: &World, tolerance: f32, out: &mut TileOut, counts: &mut UCounts) {
        let lights = world.lights.batch();
        let extents = world.lights.extents();
        let n = lights.len();
        let count = self.count;
        let group = culls(tolerance, n)
            .then(|| PointGroup::new(&self.points))
            .flatten();
        let Some(group) = group else {
            // Every light at every point, no bounds to keep.
            let mut lobes = LaneLobes::default();
            for (i, light) in lights.iter().enumerate() {
                for run in self.runs[..self.live].iter_mut() {
                    run.batch.set_others(run.kept);
                    let c = lobes_batch(&run.batch, light, &mut lobes);
                    counts.lanes.fast += c.fast;
                    counts.lanes.scalar += c.scalar;
                    run.add_lanes(out, i, &lobes);
                }
            }
            counts.full += (n * count) as u64;
            return;
        };
        self.order.clear();
        self.order
            .extend(extents.iter().map(|e| group.bound(e)).enumerate());
        self.order
            .sort_unstable_by(|a, b| b.1.total().total_cmp(&a.1.total()));
        // Summed from the smallest bound up, so no large bound is ever
        // subtracted from a small remainder.
        self.rest.clear();
        self.rest.resize(n + 1, 0.0);
        for j in (0..n).rev() {
            self.rest[j] = self.rest[j + 1] + self.order[j].1.total();
        }
        self.spent.clear();
        self.spent.resize(count, 0.0);
        let has_ggx = self.points.iter().any(|sp| sp.specular.max_element() > 0.0);
        self.wide_ready = false;
        // The smallest `U` so far, and the most any point's left-out
        // lobes may cost.
        let (mut smallest, mut most_spent) = (0.0f32, 0.0f32);
        let mut evaluated = 0;
        for j in 0..n {
            let (i, bound) = self.order[j];
            let budget = tolerance * smallest;
            if self.rest[j] + most_spent <= budget {
                break;
            }
            if bound.total() == 0.0 {
                continue;
            }
            evaluated += 1;
            // The tile's bound may leave the GGX lobe out everywhere.
            let tile_drop = most_spent + bound.specular <= GGX_SHARE * budget;
            let light = &world.lights.declared()[i];
            let far = group.far_view(&extents[i]);
            // Where the tile's bound cannot leave the GGX lobe out, each
            // point's own bound (it holds for any light) may, run by run.
            let per_point = has_ggx && !tile_drop;
            if far.is_some() || per_point {
                self.prepare_wide();
            }
            if per_point {
                ggx_bounds(&self.wide, &extents[i], &mut self.ggx);
            }
            let rounding = far.map_or(0.0, |view| bound_of_rounding(group.albedo(), light, view));
            let radiance = luminance(light.radiance);
            let cost = |q: usize| {
                rounding
                    + if tile_drop {
                        bound.specular
                    } else if per_point {
                        radiance * self.ggx[q]
                    } else {
                        0.0
                    }
            };
            // Which runs leave the GGX lobe out, decided before any lobe is
            // computed: a far light's wide Lambert values only where some run
            // takes them; the other runs take the f64 batch (clipped).
            self.leave_out.clear();
            for run in &self.runs[..self.live] {
                let leave = tile_drop
                    || (far.is_some() && !has_ggx)
                    || (per_point
                        && run.lanes().all(|(q, l)| {
                            self.spent[q] + cost(q) <= GGX_SHARE * tolerance * run.kept[l]
                        }));
                self.leave_out.push(leave);
            }
            let wide = far.is_some() && self.leave_out.contains(&true);
            if wide {
                form_factors(&self.wide, &light.vertices, &mut self.form_factors);
            }
            let mut lobes = LaneLobes::default();
            for (run, &leave) in self.runs[..self.live].iter_mut().zip(&self.leave_out) {
                let points = run.count as u64;
                if leave && wide {
                    for (q, l) in run.lanes() {
                        let d = self.points[q].diffuse * light.radiance * self.form_factors[q];
                        run.add_diffuse(out, l, i, d);
                        self.spent[q] += cost(q);
                    }
                    counts.diffuse_only += points;
                    counts.lambert_wide += points;
                    continue;
                }
                run.batch.set_others(run.kept);
                let c = if leave {
                    diffuse_batch(&run.batch, &lights[i], &mut lobes)
                } else {
                    lobes_batch(&run.batch, &lights[i], &mut lobes)
                };
                counts.lanes.fast += c.fast;
                counts.lanes.scalar += c.scalar;
                run.add_lanes(out, i, &lobes);
                if leave {
                    for (q, _) in run.lanes() {
                        self.spent[q] += cost(q);
                    }
                    counts.diffuse_only += points;
                } else {
                    counts.full += points;
                }
            }
            smallest = self.runs[..self.live]
                .iter()
                .flat_map(|run| run.lanes().map(|(_, l)| run.kept[l]))
                .fold(f32::INFINITY, |a, b| a.min(b));
            most_spent = self.spent.iter().fold(0.0f32, |a, &b| a.max(b));
        }
        counts.culled += (n - evaluated) as u64 * count as u64;
    }
}

/// Whether a tile culls its lights (`analytic_u_band`).
fn culls(tolerance: f32, lights: usize) -> bool {
    tolerance > 0.0 && lights >= CULL_MIN_LIGHTS
}

/// What the wide kernel's rounding may cost a tile whose largest albedo
/// channel is `albedo` (luminance).
fn bound_of_rounding(albedo: f32, light: &Light, view: FarView) -> f32 {
    albedo
        * luminance(light.radiance)
        * form_factor_rounding(light.vertices.len(), view.near, view.scale)
}

//! The committed LTC table as U reads it: every cell keeps enough of each
//! lobe's distribution above the horizon that dividing a polygon integral
//! by that mass cannot blow up its rounding (`fit_ltc::HMASS_FLOOR`).

use penumbra::fit_ltc::HMASS_FLOOR;
use penumbra::shading::ltc;

/// The fit's penalty lets a cell end a hair under the floor; this much is
/// allowed (a factor of at most 1 / (0.95 * floor) on rounding).
const FLOOR_SLACK: f64 = 0.95;

#[test]
fn every_cell_keeps_both_lobes_above_the_horizon_mass_floor() {
    let table = ltc::table();
    let floor = (FLOOR_SLACK * HMASS_FLOOR) as f32;
    for (k, c) in table.cells.iter().enumerate() {
        let (i, j) = (k % table.size, k / table.size);
        assert!(
            c.hmass >= floor && c.fhmass >= floor,
            "cell (roughness column {i}, view row {j}): hmass {}, fhmass {} under {floor}",
            c.hmass,
            c.fhmass
        );
    }
}

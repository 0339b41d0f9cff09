//! The criterion configuration every bench runs with.

use criterion::Criterion;

/// Criterion without its HTML plots: it draws their text with the plotters
/// build this crate configures (`ab_glyph`, fonts registered by
/// `report::plot` only), and panicked for want of a font. The figures are
/// in the text output.
pub fn criterion() -> Criterion {
    Criterion::default().without_plots()
}

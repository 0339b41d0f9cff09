//! The progress bars of the long commands (reference renders, `fit-ltc`,
//! `bench`): one style, drawn on stderr, and nothing at all when stderr is
//! not a terminal (indicatif's stderr target hides itself then), so logs
//! and captured output carry no bar.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A bar of `total` steps labelled `prefix`, counting `unit`s ("spp",
/// "cells", "configurations"), with elapsed and remaining time.
pub fn bar(total: u64, prefix: impl Into<String>, unit: &str) -> ProgressBar {
    let template = format!(
        "{{prefix}} [{{bar:30}}] {{pos}}/{{len}} {unit} {{msg}} {{elapsed}}, ~{{eta}} left"
    );
    let style = ProgressStyle::with_template(&template)
        .expect("the template is valid")
        .progress_chars("#>.");
    ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr())
        .with_style(style)
        .with_prefix(prefix.into())
}

/// Whether bars are drawn at all (stderr is a terminal).
pub fn visible() -> bool {
    !ProgressDrawTarget::stderr().is_hidden()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bar_counts_its_steps_whether_or_not_it_is_drawn() {
        let b = bar(8, "test", "steps");
        b.inc(3);
        b.set_position(5);
        assert_eq!((b.position(), b.length()), (5, Some(8)));
        b.finish_and_clear();
        assert!(b.is_finished());
    }
}

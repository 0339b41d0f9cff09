//! Progress bars are drawn only on a terminal: captured stderr (a file, a
//! pipe, CI's log) gets none of them.
use std::process::Command;

#[test]
fn fit_ltc_draws_no_bar_when_stderr_is_not_a_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let run = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["fit-ltc", "--size", "3", "--out"])
        .arg(dir.path().join("ltc.bin"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{err}");
    assert!(err.contains("fitted 3x3 LTC table"), "{err}");
    assert!(
        !err.contains('\r') && !err.contains("cells"),
        "a bar was drawn: {err:?}"
    );
}

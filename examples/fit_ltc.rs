//! Fits the LTC table without the CLI:
//! `cargo run --release --example fit_ltc -- 64 data/ltc_64.bin ltc-error.png`
fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let size = args.get(1).map(|s| s.parse()).transpose()?.unwrap_or(64);
    let out = args
        .get(2)
        .cloned()
        .unwrap_or_else(|| format!("data/ltc_{size}.bin"));
    let heatmap = args.get(3).map(std::path::PathBuf::from);
    penumbra::shading::ltc_fit::run_fit(size, std::path::Path::new(&out), heatmap.as_deref())
}

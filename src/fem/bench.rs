//! `fbgforge bench fem` (filled in below).
use std::path::Path;
/// Run the benchmark.
pub fn run_bench(_out_dir: &Path) -> anyhow::Result<()> {
    Ok(())
}

//! `flexstage report`: (re)builds `<run>/report.html` from whatever a run folder holds.

use std::path::PathBuf;

use clap::Args;
use flexstage_report::{html, write_atomic};

/// Arguments of `flexstage report`.
#[derive(Debug, Args)]
pub struct ReportArgs {
    /// The run folder.
    #[arg(default_value = "runs/quick")]
    pub run: PathBuf,
}

/// Runs `flexstage report`.
pub fn run(args: ReportArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.run.is_dir(),
        "{} is not a run folder",
        args.run.display()
    );
    let path = args.run.join("report.html");
    write_atomic(&path, html::build_report(&args.run).as_bytes())?;
    println!("report: {}", path.display());
    Ok(())
}

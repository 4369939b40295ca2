//! `gregvox info`.
use clap::Args;

/// Arguments of `gregvox info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gregvox info`.
pub fn run(_args: &InfoArgs) -> anyhow::Result<()> {
    Ok(())
}

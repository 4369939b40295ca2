//! `gregvox mesh` and `gregvox subdivide`.
use clap::Args;
use std::path::PathBuf;

/// Arguments of `gregvox mesh`.
#[derive(Debug, Args)]
pub struct MeshArgs {
    /// The OBJ file to analyse.
    pub input: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `gregvox subdivide`.
#[derive(Debug, Args)]
pub struct SubdivideArgs {
    /// The OBJ file to subdivide.
    pub input: PathBuf,
    /// Number of Catmull–Clark levels.
    #[arg(long, default_value_t = 1)]
    pub levels: u32,
    /// Where to write the subdivided OBJ.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs `gregvox mesh`.
pub fn run_mesh(_args: &MeshArgs) -> anyhow::Result<()> {
    anyhow::bail!("gregvox mesh is not built yet")
}

/// Runs `gregvox subdivide`.
pub fn run_subdivide(_args: &SubdivideArgs) -> anyhow::Result<()> {
    anyhow::bail!("gregvox subdivide is not built yet")
}

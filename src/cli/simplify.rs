//! `gregvox simplify`: quadric mesh reduction to a ratio, a face count or an error, one level or a chain
//! of levels of detail (a thin client of `api::simplify`).
use crate::api::{load_mesh, simplify, simplify_lod, Placement, SimplifiedMesh, SimplifyOptions};
use crate::mesh::write::{write_glb_levels, write_mesh, MeshOut};
use clap::Args;
use std::path::{Path, PathBuf};

/// `gregvox simplify`.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("target").required(true).multiple(true).args(["ratio", "faces", "error"])))]
pub struct SimplifyArgs {
    /// The mesh (OBJ, STL, PLY, OFF, glTF/GLB); polygons are fan-triangulated.
    pub input: PathBuf,
    /// Keep this fraction of the triangles (per level with --lod).
    #[arg(long, value_name = "R")]
    pub ratio: Option<f64>,
    /// Keep at most this many triangles (the last level's with --lod).
    #[arg(long, value_name = "N")]
    pub faces: Option<usize>,
    /// Stop before a collapse whose error exceeds this fraction of the bounding-box diagonal (the last
    /// level's with --lod). With --ratio or --faces, the first target reached stops.
    #[arg(long, value_name = "E")]
    pub error: Option<f64>,
    /// Where merged vertices go: keep (on an endpoint) or optimal (the quadric's minimum).
    #[arg(long, value_enum, default_value = "optimal")]
    pub placement: Placement,
    /// Boundary vertices never move nor disappear.
    #[arg(long)]
    pub lock_border: bool,
    /// Allow collapses that change the topology (Euler characteristic, pieces, manifoldness).
    #[arg(long)]
    pub allow_topology: bool,
    /// Remove disconnected pieces whose bounding-box diagonal is at most this fraction of the mesh's
    /// (`--prune` alone: 0.01).
    #[arg(long, value_name = "F", num_args = 0..=1, default_missing_value = "0.01")]
    pub prune: Option<f64>,
    /// Write K levels of detail: level 0 is the input, each next one reduced from the previous. With an
    /// .glb output, one file (MSFT_lod); otherwise OUT_lod0.EXT … OUT_lodK-1.EXT.
    #[arg(long, value_name = "K")]
    pub lod: Option<usize>,
    /// Weld vertices closer than this (per-axis distance) first: coincident vertices of an unwelded
    /// mesh count as attribute seams otherwise (reduced two sides at a time; locked where three or more
    /// copies meet).
    #[arg(long, value_name = "TOL")]
    pub weld: Option<f64>,
    /// The output mesh: .obj, .ply, .stl or .glb.
    #[arg(long, value_name = "OUT")]
    pub out: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
}

/// `OUT_lodK.EXT` beside OUT.
fn level_path(out: &Path, k: usize) -> PathBuf {
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = out
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    out.with_file_name(format!("{stem}_lod{k}{ext}"))
}

/// Runs `gregvox simplify`.
pub fn run(args: &SimplifyArgs) -> anyhow::Result<()> {
    // The output's format is checked before any work.
    let format = MeshOut::of(&args.out)?;
    let mut mesh = load_mesh(&args.input)?;
    if let Some(tol) = args.weld {
        if !(tol.is_finite() && tol >= 0.0) {
            anyhow::bail!("--weld {tol}: the tolerance must be a finite number ≥ 0");
        }
        mesh = crate::mesh::weld(&mesh, tol).0;
    }
    let opts = SimplifyOptions {
        ratio: args.ratio,
        faces: args.faces,
        error: args.error,
        placement: args.placement,
        lock_border: args.lock_border,
        allow_topology: args.allow_topology,
        prune: args.prune.unwrap_or(0.0),
    };
    let input = args.input.display().to_string();
    let levels: Vec<SimplifiedMesh> = match args.lod {
        Some(k) => simplify_lod(&mesh, &opts, k)?,
        None => vec![simplify(&mesh, &opts)?],
    };
    let mut written = Vec::new();
    if args.lod.is_some() && format == MeshOut::Glb {
        let parts: Vec<(&crate::mesh::Mesh, serde_json::Value)> = levels
            .iter()
            .map(|l| (&l.mesh, serde_json::to_value(&l.report).unwrap_or_default()))
            .collect();
        write_glb_levels(&args.out, &parts)?;
        written = vec![args.out.clone(); levels.len()];
    } else {
        for (k, l) in levels.iter().enumerate() {
            let path = if args.lod.is_some() {
                level_path(&args.out, k)
            } else {
                args.out.clone()
            };
            write_mesh(&path, &l.mesh)?;
            written.push(path);
        }
    }
    if args.json {
        let levels: Vec<serde_json::Value> = levels
            .iter()
            .zip(&written)
            .map(|(l, p)| {
                let mut v = serde_json::to_value(&l.report).unwrap_or_default();
                v["out"] = serde_json::json!(p.display().to_string());
                v
            })
            .collect();
        let doc = serde_json::json!({"input": input, "levels": levels});
        super::print_out(&format!("{doc}\n"))?;
    } else {
        let mut text = String::new();
        for (k, (l, p)) in levels.iter().zip(&written).enumerate() {
            let r = &l.report;
            let lod = if args.lod.is_some() {
                format!("level {k}: ")
            } else {
                String::new()
            };
            text.push_str(&format!(
                "{input}: {lod}{} → {} triangles ({:.1} %), {} vertices, error {:.3e} ({:.4} % of the diagonal), {} collapses in {} passes, {:.3} s, written to {}\n",
                r.input_faces,
                r.faces,
                100.0 * r.faces as f64 / r.input_faces.max(1) as f64,
                r.vertices,
                r.error,
                100.0 * r.relative_error,
                r.collapses,
                r.passes,
                r.seconds,
                p.display()
            ));
            if r.locked_vertices > 0 || r.pruned_faces > 0 {
                text.push_str(&format!(
                    "  {} vertices locked (seams, non-manifold fans{}), {} triangles pruned\n",
                    r.locked_vertices,
                    if args.lock_border { ", the border" } else { "" },
                    r.pruned_faces
                ));
            }
        }
        super::print_out(&text)?;
    }
    Ok(())
}

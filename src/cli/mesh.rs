//! `gregvox mesh` (topology report, human-readable or `--json`) and `gregvox subdivide` (Catmull–Clark or
//! Loop, written as OBJ through a temporary file that is renamed into place).
use crate::api::{load_mesh, subdivide, topology, Scheme, TopologyReport};
use crate::mesh;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `gregvox mesh`.
#[derive(Debug, Args)]
pub struct MeshArgs {
    /// The mesh file (OBJ, STL, PLY, OFF, glTF/GLB) to analyse.
    pub input: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Weld vertices closer than this (per-axis distance) before the analysis.
    #[arg(long, value_name = "TOL")]
    pub weld: Option<f64>,
    /// Fan-triangulate polygons before the analysis (loading keeps polygons).
    #[arg(long)]
    pub triangulate: bool,
}

/// Arguments of `gregvox subdivide`.
#[derive(Debug, Args)]
pub struct SubdivideArgs {
    /// The mesh file (OBJ, STL, PLY, OFF, glTF/GLB) to subdivide.
    pub input: PathBuf,
    /// Number of subdivision levels.
    #[arg(long, default_value_t = 1)]
    pub levels: u32,
    /// Where to write the subdivided OBJ (`-`: standard output).
    #[arg(long)]
    pub out: PathBuf,
    /// Subdivision scheme.
    #[arg(long, value_enum, default_value_t = Scheme::CatmullClark)]
    pub scheme: Scheme,
}

/// Runs `gregvox mesh`.
pub fn run_mesh(args: &MeshArgs) -> anyhow::Result<()> {
    let mut m = load_mesh(&args.input)?;
    if let Some(tol) = args.weld {
        if !(tol.is_finite() && tol >= 0.0) {
            anyhow::bail!("--weld {tol}: the tolerance must be a finite number ≥ 0");
        }
        m = mesh::weld(&m, tol).0;
        if m.n_faces() == 0 {
            anyhow::bail!(
                "{}: no face survives welding with tolerance {tol}",
                args.input.display()
            );
        }
    }
    if args.triangulate {
        m = m.triangulated();
    }
    let report = topology(&m);
    // Through print_out: a reader that closes the pipe early (`| head`) ends the output, not the process
    // with a panic.
    if args.json {
        super::print_out(&format!("{}\n", serde_json::to_string_pretty(&report)?))
    } else {
        super::print_out(&human_report(&args.input.display().to_string(), &report))
    }
}

/// The human-readable report.
fn human_report(name: &str, r: &TopologyReport) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let yes = |b: bool| if b { "yes" } else { "no" };
    let _ = writeln!(s, "mesh: {name}");
    let _ = writeln!(
        s,
        "  vertices         {} ({} referenced, {} unreferenced)",
        r.vertices, r.referenced_vertices, r.unreferenced_vertices
    );
    let mut orders: Vec<(u32, usize)> = r
        .face_order_histogram
        .iter()
        .map(|(k, v)| (k.parse().unwrap_or(0), *v))
        .collect();
    orders.sort_unstable();
    let orders: Vec<String> = orders
        .iter()
        .map(|(k, v)| format!("{v} × {k}-gon"))
        .collect();
    let _ = writeln!(s, "  faces            {} ({})", r.faces, orders.join(", "));
    let _ = writeln!(s, "  edges            {}", r.edges);
    let _ = writeln!(
        s,
        "  boundary edges   {} in {} loop(s) {:?}",
        r.boundary_edges, r.boundary_loops, r.boundary_loop_sizes
    );
    let _ = writeln!(
        s,
        "  non-manifold     {} edge(s), {} pinched vertex(es)",
        r.non_manifold_edges, r.non_manifold_vertices
    );
    let _ = writeln!(
        s,
        "  inconsistent     {} edge(s) (second writes in E: {})",
        r.inconsistent_edges, r.second_writes
    );
    let _ = writeln!(s, "  closed           {}", yes(r.closed));
    let _ = writeln!(s, "  oriented         {}", yes(r.consistently_oriented));
    let _ = writeln!(
        s,
        "  components       {} by vertices, {} by edges",
        r.components, r.face_components
    );
    let _ = writeln!(s, "  euler χ          {}", r.euler_characteristic);
    match r.genus {
        Some(g) => {
            let _ = writeln!(s, "  genus            {g}");
        }
        None => {
            let _ = writeln!(
                s,
                "  genus            undefined (not a manifold oriented surface)"
            );
        }
    }
    let mut val: Vec<(u32, usize)> = r
        .valence_histogram
        .iter()
        .map(|(k, v)| (k.parse().unwrap_or(0), *v))
        .collect();
    val.sort_unstable();
    let val: Vec<String> = val.iter().map(|(k, v)| format!("{k}:{v}")).collect();
    let _ = writeln!(s, "  valence          {}", val.join(" "));
    s
}

/// Runs `gregvox subdivide`.
pub fn run_subdivide(args: &SubdivideArgs) -> anyhow::Result<()> {
    crate::io::check_output(&args.out)?;
    let m = load_mesh(&args.input)?;
    let out = subdivide(&m, args.levels, args.scheme).map_err(|e| e.for_input(&args.input))?;
    mesh::write_obj(&args.out, &out)?;
    eprintln!(
        "wrote {} ({} vertices, {} faces)",
        if crate::io::is_stdout(&args.out) {
            "standard output".to_string()
        } else {
            args.out.display().to_string()
        },
        out.positions.len(),
        out.n_faces()
    );
    Ok(())
}

//! `gregvox evaluate`: a cage's limit surface at (face, u, v) rows, into an `.npz` (a thin client of
//! `api::LimitEvaluator`).
use crate::api::{load_cage, LimitEvaluator, Tangents};
use crate::error::Error;
use crate::npy::{read_points, write_npz, Array};
use clap::Args;
use std::path::PathBuf;
use std::time::Instant;

/// `gregvox evaluate`.
#[derive(Debug, Args)]
pub struct EvaluateArgs {
    /// The cage (OBJ with its OpenSubdiv tags, or any mesh format).
    pub input: PathBuf,
    /// (N, 3) float64 (or float32) .npy of (face, u, v) rows: face an OpenSubdiv ptex face index (an
    /// all-quad cage's face index), u and v in [0, 1].
    #[arg(long, value_name = "FUV.npy")]
    pub at: PathBuf,
    /// The output .npz: `position`, `du`, `dv`, `duu`, `duv`, `dvv`, each (N, 3) float64, and `uv`
    /// (N, 2) float64 when the cage has UVs (`vt`).
    #[arg(long, value_name = "P.npz")]
    pub out: PathBuf,
    /// Isolation level L of a cage: refine it L times before building patches, as OpenSubdiv's
    /// RefineAdaptive(L) isolates irregular features (default: the least exact level, ⌈largest
    /// semi-sharp sharpness⌉, 1 with non-quad faces, else 0).
    #[arg(long, value_name = "L")]
    pub isolation: Option<u32>,
}

/// Runs `gregvox evaluate`.
pub fn run(args: &EvaluateArgs) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let mut cage = load_cage(&args.input)?;
    cage.tags.isolation = args.isolation;
    // What the cage itself gets wrong names the cage file.
    let named = |e: Error| match e {
        Error::Invalid(msg) | Error::Mesh(msg) => Error::parse(&args.input, msg),
        e => e,
    };
    crate::engine::cage::check_cage_valence(&cage.mesh).map_err(named)?;
    let rows = read_points(&args.at)?;
    let mut at = Vec::with_capacity(rows.len());
    for (r, &[f, u, v]) in rows.iter().enumerate() {
        if !(f >= 0.0 && f.fract() == 0.0 && f <= u32::MAX as f64) {
            anyhow::bail!(
                "{}: row {r}: face {f} is not a non-negative whole number",
                args.at.display()
            );
        }
        at.push((f as u32, u, v));
    }
    let e = LimitEvaluator::new(&cage, Tangents::OpenSubdiv).map_err(named)?;
    let s = e
        .evaluate(&at)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.at.display()))?;
    let col = |f: fn(&crate::api::LimitSample) -> glam::DVec3| -> Array {
        Array::points_f64(&s.iter().map(|x| f(x).to_array()).collect::<Vec<_>>())
    };
    let mut arrays = vec![
        ("position", col(|x| x.position)),
        ("du", col(|x| x.du)),
        ("dv", col(|x| x.dv)),
        ("duu", col(|x| x.duu)),
        ("duv", col(|x| x.duv)),
        ("dvv", col(|x| x.dvv)),
    ];
    if e.has_uv() {
        let uv = e
            .evaluate_uv(&at)
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.at.display()))?;
        arrays.push(("uv", Array::f64_rows(&uv)));
    }
    write_npz(&args.out, &arrays)?;
    eprintln!(
        "evaluated {} points on {} ptex faces in {:.3} s → {}",
        s.len(),
        e.ptex_faces(),
        t0.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}

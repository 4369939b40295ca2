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
    /// Evaluate on the device (f32; `Surface::evaluate_at`): the same arrays (`position`, `du`, `dv`,
    /// `duu`, `duv`, `dvv`, and `uv`). Default: the CPU in f64.
    #[arg(long)]
    pub device: bool,
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
    if args.device {
        return run_device(args, &cage, &at, t0);
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

/// `--device`: the surface built on the device at level 1 (its grids are not read) and evaluated there.
fn run_device(
    args: &EvaluateArgs,
    cage: &crate::api::Cage,
    at: &[(u32, f64, f64)],
    t0: Instant,
) -> anyhow::Result<()> {
    let named = |e: Error| match e {
        Error::Invalid(msg) | Error::Mesh(msg) => Error::parse(&args.input, msg),
        e => e,
    };
    let gpu = crate::api::Gpu::new()?;
    let surface = gpu
        .tagged_gregory_surface(cage, 1, Tangents::OpenSubdiv)
        .map_err(named)?;
    let s = surface
        .evaluate_at(at)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.at.display()))?;
    let wide = |v: &[[f32; 3]]| -> Array {
        Array::points_f64(&v.iter().map(|p| p.map(f64::from)).collect::<Vec<_>>())
    };
    let mut arrays = vec![
        ("position", wide(&s.position)),
        ("du", wide(&s.du)),
        ("dv", wide(&s.dv)),
        ("duu", wide(&s.duu)),
        ("duv", wide(&s.duv)),
        ("dvv", wide(&s.dvv)),
    ];
    if let Some(uv) = &s.uv {
        arrays.push((
            "uv",
            Array::f64_rows(&uv.iter().map(|p| p.map(f64::from)).collect::<Vec<_>>()),
        ));
    }
    write_npz(&args.out, &arrays)?;
    drop(surface);
    eprintln!(
        "evaluated {} points on the device in {:.3} s → {}",
        s.position.len(),
        t0.elapsed().as_secs_f64(),
        args.out.display()
    );
    Ok(())
}

//! `gregvox query`: winding numbers, occupancy and distances at given or sampled points, into an `.npz`
//! (a thin client of `api::query`).
use crate::api::query::{Distances, MeshQuery, QueryOptions, SampleSpec, SdfSign};
use crate::api::{load_mesh, FillRule};
use crate::npy::{write_npz, Array};
use crate::voxel::gwn::Inside;
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::time::Instant;

/// `--sdf-sign`.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SdfSignArg {
    /// Negative inside (libigl, Open3D, Warp).
    InsideNegative,
    /// Positive inside (trimesh, pysdf).
    InsidePositive,
}

/// `gregvox query`.
#[derive(Debug, Args)]
pub struct QueryArgs {
    /// The mesh (OBJ, STL, PLY, OFF, glTF/GLB).
    pub input: PathBuf,
    /// Query points: an (N, 3) float32 or float64 .npy array (world coordinates).
    #[arg(long, value_name = "P.npy", required_unless_present = "sample")]
    pub points: Option<PathBuf>,
    /// Sample the points instead: uniform:N (the padded box), near:SIGMA:N (area-weighted surface points
    /// moved by normal offsets of standard deviation SIGMA, mesh units), surface:N (surface points and
    /// normals, written as surface_points/surface_normals, not queried); comma-separated, in order.
    #[arg(long, value_name = "SPECS", conflicts_with = "points")]
    pub sample: Option<String>,
    /// What to compute, comma-separated: winding (float64), occupancy (bool), sdf and udf (float32).
    /// Default: winding,occupancy with --points, occupancy with --sample.
    #[arg(long, value_delimiter = ',')]
    pub what: Vec<String>,
    /// The output .npz: one array per name asked, in the order of the points (with --sample also
    /// `points`, the points queried).
    #[arg(long, value_name = "Q.npz")]
    pub out: PathBuf,
    /// Inside rule: gwn = |w| ≥ ½ (the default), gwn-positive = w ≥ ½ (libigl's convention).
    #[arg(long, value_enum, default_value = "gwn")]
    pub rule: FillRule,
    /// The sign of sdf.
    #[arg(long, value_enum, default_value = "inside-negative")]
    pub sdf_sign: SdfSignArg,
    /// Also write the nearest triangle's index (`face`, uint32), the closest point (`closest`) and its
    /// barycentric coordinates (`barycentric`), float32 (N, 3), for sdf/udf.
    #[arg(long)]
    pub closest: bool,
    /// The largest error of a winding number in `winding` (occupancy and sdf signs are decided by bounds,
    /// whatever this is).
    #[arg(long, default_value_t = 1e-6)]
    pub tolerance: f64,
    /// Seed of the samplers.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Padding of the uniform sampler's box, a fraction of its size on each side.
    #[arg(long, default_value_t = 0.1)]
    pub pad: f64,
    /// The Occupancy Networks layout: `occupancy` as packed bits (uint8, `np.unpackbits(a)[:N]`) and
    /// `points` as float16.
    #[arg(long)]
    pub compact: bool,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

fn f32_rows(v: &[[f64; 3]]) -> Vec<[f32; 3]> {
    v.iter().map(|p| p.map(|x| x as f32)).collect()
}

/// Runs `gregvox query`.
pub fn run(args: &QueryArgs) -> anyhow::Result<()> {
    let what: Vec<String> = if args.what.is_empty() {
        if args.sample.is_some() {
            vec!["occupancy".into()]
        } else {
            vec!["winding".into(), "occupancy".into()]
        }
    } else {
        args.what.iter().map(|s| s.trim().to_string()).collect()
    };
    for w in &what {
        if !["winding", "occupancy", "sdf", "udf"].contains(&w.as_str()) {
            anyhow::bail!("--what {w}: expected winding, occupancy, sdf or udf");
        }
    }
    let inside = match args.rule {
        FillRule::Gwn => Inside::Magnitude,
        FillRule::GwnPositive => Inside::Positive,
        r => anyhow::bail!(
            "--rule {}: queries take gwn or gwn-positive",
            r.to_possible_value()
                .map_or("?".into(), |v| v.get_name().to_string())
        ),
    };
    let specs = args
        .sample
        .as_deref()
        .map(SampleSpec::parse_list)
        .transpose()?;
    if args.out.extension().and_then(|e| e.to_str()) != Some("npz") {
        anyhow::bail!("{}: the output must be an .npz", args.out.display());
    }
    crate::io::check_output(&args.out)?;
    let points_in = args
        .points
        .as_ref()
        .map(|p| crate::npy::read_points(p))
        .transpose()?;
    let mesh = load_mesh(&args.input)?;
    let start = Instant::now();
    let opts = QueryOptions {
        inside,
        sdf_sign: match args.sdf_sign {
            SdfSignArg::InsideNegative => SdfSign::InsideNegative,
            SdfSignArg::InsidePositive => SdfSign::InsidePositive,
        },
        tolerance: args.tolerance,
        ..QueryOptions::default()
    };
    // Unsigned distances alone need no winding number: no weld, caps or crossing index.
    let only_udf = what.iter().all(|w| w == "udf");
    let q = if only_udf {
        MeshQuery::distances_only(&mesh, &opts)
    } else {
        MeshQuery::new(&mesh, &opts)
    }
    .map_err(|e| e.for_input(&args.input))?;
    let prepared = start.elapsed().as_secs_f64();
    let mut arrays: Vec<(&str, Array)> = Vec::new();
    let points = match (points_in, &specs) {
        (Some(p), _) => p,
        (None, Some(specs)) => {
            let s = q.sample(specs, args.pad, args.seed)?;
            if !s.surface_points.is_empty() {
                arrays.push((
                    "surface_points",
                    Array::points_f32(&f32_rows(&s.surface_points)),
                ));
                arrays.push((
                    "surface_normals",
                    Array::points_f32(&f32_rows(&s.surface_normals)),
                ));
            }
            let p32 = f32_rows(&s.points);
            let written = if args.compact {
                Array::points_f16(&p32)
            } else {
                Array::points_f32(&p32)
            };
            // The points as written are the points queried (f32 or f16 rounding included), so the
            // answers describe the file's points exactly.
            let queried = if args.compact {
                written
                    .data
                    .chunks(6)
                    .map(|c| {
                        std::array::from_fn(|k| {
                            half::f16::from_le_bytes([c[2 * k], c[2 * k + 1]]).to_f64()
                        })
                    })
                    .collect()
            } else {
                p32.iter().map(|p| p.map(f64::from)).collect()
            };
            arrays.push(("points", written));
            queried
        }
        (None, None) => unreachable!("clap requires --points or --sample"),
    };
    let want = |name: &str| what.iter().any(|w| w == name);
    if want("winding") || want("occupancy") {
        let (w, occ) = if want("winding") {
            q.winding_and_occupancy(&points)?
        } else {
            (Vec::new(), q.occupancy(&points)?)
        };
        if want("winding") {
            arrays.push(("winding", Array::f64s(&w)));
        }
        if want("occupancy") {
            arrays.push((
                "occupancy",
                if args.compact {
                    Array::packed_bits(&occ)
                } else {
                    Array::bools(&occ)
                },
            ));
        }
    }
    let mut closest: Option<Distances> = None;
    for (name, signed) in [("sdf", true), ("udf", false)] {
        if !want(name) {
            continue;
        }
        let d = if signed {
            q.signed_distance(&points)?
        } else {
            q.unsigned_distance(&points)?
        };
        arrays.push((name, Array::f32s(&d.distance)));
        closest.get_or_insert(d);
    }
    if args.closest {
        let Some(d) = closest else {
            anyhow::bail!("--closest needs sdf or udf in --what");
        };
        arrays.push(("face", Array::u32s(&d.face)));
        arrays.push(("closest", Array::points_f32(&f32_rows(&d.closest))));
        arrays.push(("barycentric", Array::points_f32(&f32_rows(&d.barycentric))));
    }
    let seconds = start.elapsed().as_secs_f64();
    write_npz(&args.out, &arrays)?;
    let names: Vec<&str> = arrays.iter().map(|(n, _)| *n).collect();
    if args.json {
        let j = serde_json::json!({
            "input": args.input.display().to_string(),
            "points": points.len(),
            "arrays": names,
            "prepare_seconds": prepared,
            "seconds": seconds,
            "out": args.out.display().to_string(),
        });
        crate::cli::print_out(&format!("{j}\n"))?;
    } else {
        crate::cli::print_out(&format!(
            "{} points of {}: {} in {:.3} s (preparing {:.3} s) → {}\n",
            points.len(),
            args.input.display(),
            names.join(", "),
            seconds,
            prepared,
            args.out.display()
        ))?;
    }
    Ok(())
}

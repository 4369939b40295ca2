//! Specification of `gregvox bench`'s arithmetic and outputs: medians, speed-up ratios and log-log growth
//! fits are exact on constructed data; tables render to well-formed markdown and CSV; a report survives
//! JSON and regenerates the same document; the CPU port of the `wave` deformation (Thesis Table 3.3's
//! CPU path) matches the GPU pass; a tiny `gregvox bench --quick` run writes parseable CSV, JSON and PNG.
mod common;

use gregvox::bench::{fmt_num, loglog_slope, median, num, speedup, Curve, Report, Series, Table};
use serde_json::Value;
use std::process::{Command, Output};

fn gregvox(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(args)
        // The driver is the caller's (VK_DRIVER_FILES inherited): the run must work on any device.
        .env("GREGVOX_VALIDATION", "1")
        .env("LP_NUM_THREADS", "2")
        .output()
        .unwrap()
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("gregvox-bench-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// Splits one CSV line (RFC 4180 quoting) into fields.
fn csv_fields(line: &str) -> Vec<String> {
    let mut out = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match (c, quoted) {
            ('"', true) if chars.peek() == Some(&'"') => {
                chars.next();
                out.last_mut().unwrap().push('"');
            }
            ('"', _) => quoted = !quoted,
            (',', false) => out.push(String::new()),
            (c, _) => out.last_mut().unwrap().push(c),
        }
    }
    out
}

#[test]
fn median_of_odd_and_even_counts() {
    assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
    assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
    assert_eq!(median(&[7.0]), 7.0);
    assert!(median(&[]).is_nan());
}

#[test]
fn loglog_slope_recovers_power_laws_exactly() {
    // y = 3 x²: slope 2 to rounding (1e-12: a handful of ln/exp roundings on five points).
    let pts: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 64.0]
        .iter()
        .map(|&x| (x, 3.0 * x * x))
        .collect();
    assert!((loglog_slope(&pts).unwrap() - 2.0).abs() < 1e-12);
    // y = 5 / x: slope −1.
    let inv: Vec<(f64, f64)> = (1..6).map(|i| (i as f64, 5.0 / i as f64)).collect();
    assert!((loglog_slope(&inv).unwrap() + 1.0).abs() < 1e-12);
    // y = 7 x: slope 1; non-positive and non-finite points are ignored, not fitted.
    let mixed = [
        (1.0, 7.0),
        (2.0, 14.0),
        (0.0, 1.0),
        (3.0, -1.0),
        (4.0, f64::NAN),
        (10.0, 70.0),
    ];
    assert!((loglog_slope(&mixed).unwrap() - 1.0).abs() < 1e-12);
}

#[test]
fn loglog_slope_needs_two_distinct_sizes() {
    assert_eq!(loglog_slope(&[]), None);
    assert_eq!(loglog_slope(&[(2.0, 3.0)]), None);
    assert_eq!(loglog_slope(&[(2.0, 3.0), (2.0, 5.0)]), None);
}

#[test]
fn speedup_is_peer_over_gregvox_and_null_without_a_peer() {
    assert_eq!(speedup(Some(10.0), 5.0), num(2.0));
    assert_eq!(speedup(Some(1.0), 4.0), num(0.25));
    assert_eq!(speedup(None, 4.0), Value::Null);
    assert_eq!(speedup(Some(0.0), 4.0), Value::Null);
    assert_eq!(speedup(Some(3.0), 0.0), Value::Null);
    assert_eq!(speedup(Some(f64::NAN), 1.0), Value::Null);
}

#[test]
fn numbers_print_to_four_significant_digits() {
    assert_eq!(fmt_num(1234.5678), "1235");
    assert_eq!(fmt_num(1.23456), "1.235");
    assert_eq!(fmt_num(0.0123456), "0.01235");
    assert_eq!(fmt_num(1.5e-5), "1.500e-5");
    assert_eq!(num(f64::INFINITY), Value::Null);
}

fn sample_table() -> Table {
    let mut t = Table::new(
        "t1",
        "Title",
        "A note, with a comma.",
        &["name", "ms", "ratio"],
    );
    t.push(vec!["plain".into(), num(1.5), num(2.0)]);
    t.push(vec![
        "has, comma and \"quotes\"".into(),
        num(0.25),
        Value::Null,
    ]);
    t
}

#[test]
fn tables_render_markdown_with_one_cell_per_column() {
    let md = sample_table().markdown();
    let rows: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
    assert_eq!(rows.len(), 4, "header, rule, two rows:\n{md}");
    for r in &rows {
        assert_eq!(r.matches('|').count(), 4, "row {r}");
    }
    assert!(
        rows[3].contains("| – |"),
        "missing values print as a dash: {}",
        rows[3]
    );
}

#[test]
fn tables_render_csv_that_parses_back() {
    let csv = sample_table().csv();
    let lines: Vec<Vec<String>> = csv.lines().map(csv_fields).collect();
    assert_eq!(lines[0], ["name", "ms", "ratio"]);
    assert_eq!(lines[1], ["plain", "1.5", "2.0"]);
    assert_eq!(lines[2], ["has, comma and \"quotes\"", "0.25", ""]);
}

#[test]
fn curves_carry_their_fitted_slope_into_the_table_note() {
    let s = Series::new(
        "cubic",
        (1..5).map(|i| (i as f64, (i * i * i) as f64)).collect(),
    );
    assert!((s.slope.unwrap() - 3.0).abs() < 1e-12);
    let c = Curve {
        id: "c".into(),
        title: "T".into(),
        note: "N.".into(),
        x_label: "n".into(),
        y_label: "ms".into(),
        series: vec![s],
    };
    let t = c.table();
    assert_eq!(t.rows.len(), 4);
    assert!(t.note.contains("cubic: 3.00"), "{}", t.note);
}

#[test]
fn a_report_survives_json_and_regenerates_the_same_document() {
    let r = Report {
        tables: vec![sample_table()],
        curves: vec![Curve {
            id: "c".into(),
            title: "T".into(),
            note: String::new(),
            x_label: "n".into(),
            y_label: "ms".into(),
            series: vec![Series::new("s", vec![(1.0, 2.0), (2.0, 8.0)])],
        }],
        duration_s: 1.25,
        command: "gregvox bench".into(),
        ..Default::default()
    };
    let back: Report = serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap();
    assert_eq!(back, r);
    assert_eq!(back.markdown("bench/"), r.markdown("bench/"));
    assert!(r.markdown("bench/").contains("![T](bench/c.png)"));
}

#[test]
fn the_cpu_wave_deformation_matches_the_gpu_pass() {
    use gregvox::bench::thesis::{grid_cage, wave_cpu};
    use gregvox::engine::gregory::GregorySurface;
    use gregvox::passes::cage_deform::{DeformParams, Deformation};
    use gregvox::surface::{GregoryStencils, Tangents};
    let cage = grid_cage(3, 2);
    let (topo, rest, _) =
        gregvox::engine::cage::cage_topology(&cage, Tangents::OpenSubdiv).unwrap();
    let stencils = GregoryStencils::from_mesh(&cage, Tangents::OpenSubdiv)
        .unwrap()
        .stencils;
    let (t, amplitude) = (0.7, 1.0);
    let want = stencils.points(&wave_cpu(&rest, t, amplitude)).unwrap();
    let got = common::with_gpu(|ctx| {
        let s = GregorySurface::new(ctx, &topo, &rest, 2).unwrap();
        let d = DeformParams {
            mode: Deformation::Wave,
            t: t as f32,
            amplitude: amplitude as f32,
            box_min: s.box_min(),
            box_size: s.box_size(),
        };
        ctx.one_shot(|cmd| s.record(ctx, cmd, Some(&d), None))
            .unwrap();
        s.read_points(ctx).unwrap()
    });
    assert_eq!(got.len(), want.len());
    // f32 sin of arguments up to ~10 rad on a cage of extent 3: a few ulps of 10 → 1e-5 is ample.
    for (g, w) in got.iter().zip(&want) {
        for a in 0..3 {
            assert!((g[a] as f64 - w[a]).abs() < 1e-5, "GPU {g:?} vs CPU {w:?}");
        }
    }
}

#[test]
fn spheres_for_the_triangle_curve_have_about_the_requested_count() {
    for n in [5_000, 80_000, 1_600_000] {
        let got = gregvox::bench::voxel::sphere_with(n).triangles.len() as f64;
        assert!(
            (got / n as f64 - 1.0).abs() < 0.1,
            "{n} requested, {got} made"
        );
    }
}

#[test]
fn gregory_compute_timing_is_positive_and_clean_under_validation() {
    use gregvox::bench::gregory::{time_path, EvalPath};
    use gregvox::surface::Tangents;
    let cage = gregvox::engine::cage::builtin_cage(2, 1, 1);
    let (topo, pos, _) = gregvox::engine::cage::cage_topology(&cage, Tangents::OpenSubdiv).unwrap();
    for path in EvalPath::ALL {
        let ms = common::with_gpu(|ctx| time_path(ctx, &topo, &pos, 3, path, 2).unwrap());
        let ms = ms.unwrap_or_else(|e| panic!("{path:?}: {e}"));
        assert!(ms > 0.0 && ms.is_finite(), "{path:?}: {ms} ms");
    }
}

#[test]
fn quick_run_of_tiny_suites_writes_well_formed_csv_json_and_png() {
    let out = tmp("quick");
    let o = gregvox(&[
        "bench",
        "--quick",
        "--suite",
        "peak",
        "--suite",
        "scaling",
        "--repeats",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "stderr:\n{err}");
    assert!(
        !err.contains("vulkan validation") && !err.contains("panicked"),
        "{err}"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("took"),
        "the run states its duration:\n{stdout}"
    );
    let report: Report =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    assert!(report.quick && report.duration_s > 0.0);
    assert_eq!(report.tables[0].id, "peak");
    let ids: Vec<&str> = report.curves.iter().map(|c| c.id.as_str()).collect();
    assert_eq!(
        ids,
        ["scaling_level", "scaling_resolution", "scaling_triangles"]
    );
    for c in &report.curves {
        for s in &c.series {
            assert!(!s.points.is_empty(), "{} / {}", c.id, s.name);
            assert!(
                s.points.iter().all(|p| p.1 > 0.0 && p.1.is_finite()),
                "{} / {}",
                c.id,
                s.name
            );
            assert!(
                s.slope.is_some(),
                "{} / {} has a fitted growth",
                c.id,
                s.name
            );
        }
    }
    for t in report.tables.iter().chain(
        report
            .curves
            .iter()
            .map(|c| c.table())
            .collect::<Vec<_>>()
            .iter(),
    ) {
        let csv = std::fs::read_to_string(out.join(format!("{}.csv", t.id))).unwrap();
        let lines: Vec<Vec<String>> = csv.lines().map(csv_fields).collect();
        assert_eq!(lines.len(), t.rows.len() + 1, "{}", t.id);
        assert!(
            lines.iter().all(|l| l.len() == t.columns.len()),
            "{}: ragged CSV",
            t.id
        );
    }
    for id in ids {
        let file = std::fs::File::open(out.join(format!("{id}.png"))).unwrap();
        let reader = png::Decoder::new(file).read_info().unwrap();
        let info = reader.info();
        assert_eq!((info.width, info.height), (800, 500), "{id}.png");
    }
    // The document is a pure function of results.json.
    let again = tmp("again");
    let doc = tmp("doc/benchmarks.md");
    let o = gregvox(&[
        "bench",
        "--from-json",
        out.join("results.json").to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
        "--doc",
        doc.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(
        std::fs::read_to_string(again.join("benchmarks.md")).unwrap(),
        std::fs::read_to_string(out.join("benchmarks.md")).unwrap()
    );
    assert!(doc
        .parent()
        .unwrap()
        .join("bench/scaling_level.png")
        .is_file());
    assert!(std::fs::read_to_string(&doc)
        .unwrap()
        .contains("](bench/scaling_level.png)"));
}

#[test]
fn bad_arguments_fail_with_one_clear_line() {
    let o = gregvox(&[
        "bench",
        "--suite",
        "nope",
        "--out",
        tmp("bad").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("--suite 'nope' is not a suite"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    let o = gregvox(&["bench", "--from-json", "/nonexistent/results.json"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("/nonexistent/results.json") && !err.contains("panicked"),
        "{err}"
    );
    let o = gregvox(&["bench", "--repeats", "0", "--suite", "peak"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--repeats must be at least 1"));
}

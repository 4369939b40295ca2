//! Shaping the surface with the mouse: the demo's window under Xvfb, driven by scripted mouse events that go
//! through the same handlers as real ones (`press:X:Y`, `move:X:Y`, `release` in `--keys`). A cage vertex
//! is picked where the test projects it, dragged, and the edited cage written (key W) is checked against
//! the cursor (through the camera the demo frames the cage with), against undo (Z) and reset (R), and
//! for G1 across the patch edges of the surface it makes.
mod common;

use common::read_png;

use glam::{DVec3, Vec3};
use gregvox::api::tessellate::{Patches, TessellateOptions};
use gregvox::demo::scene::Orbit;
use gregvox::engine::cage::builtin_cage;
use gregvox::surface::Tangents;
use std::path::Path;

/// Window pixels of `p` through `view_proj` in a `w`×`h` window.
fn to_screen(view_proj: &glam::Mat4, p: Vec3, w: u32, h: u32) -> (f64, f64) {
    let ndc = view_proj.project_point3(p);
    (
        (ndc.x as f64 + 1.0) * 0.5 * w as f64,
        (ndc.y as f64 + 1.0) * 0.5 * h as f64,
    )
}

/// Where the demo's log says handle `k` was moved to (world coordinates).
fn moved_to(err: &str, k: usize) -> DVec3 {
    let v: Vec<f64> = err
        .lines()
        .find_map(|l| l.split_once(&format!("moved handle {k} to ")))
        .map(|(_, rest)| {
            rest.split_whitespace()
                .take(3)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .unwrap_or_else(|| panic!("no move of handle {k} reported:\n{err}"));
    DVec3::new(v[0], v[1], v[2])
}

/// Pixels that differ (by more than 16 in a channel) between the screenshots before and after a drag.
fn pixels_changed(dir: &Path) -> usize {
    let (_, _, before) = read_png(&dir.join("gregvox-screenshot-001.png"));
    let (_, _, after) = read_png(&dir.join("gregvox-screenshot-002.png"));
    before
        .chunks_exact(4)
        .zip(after.chunks_exact(4))
        .filter(|(a, b)| (0..3).any(|c| a[c].abs_diff(b[c]) > 16))
        .count()
}

/// The worst normal jump (rad) across the shared patch edges of `cage`'s surface at level 8.
fn g1_jump(cage: &gregvox::api::Mesh) -> f64 {
    let gpu = gregvox::Gpu::new().unwrap();
    let patches = Patches::from_cage(cage, Tangents::OpenSubdiv).unwrap();
    let mut profiler = gpu.profiler().unwrap();
    let t = gpu
        .tessellate(&patches, &TessellateOptions::default(), &mut profiler)
        .unwrap();
    let jumps = t.cage_jumps(&patches).expect("a uniform cage tessellation");
    drop(gpu);
    jumps.worst
}

#[test]
fn a_dragged_cage_vertex_lands_under_the_cursor_and_the_surface_stays_g1() {
    let (w, h) = (320u32, 240u32);
    let cage = builtin_cage(4, 2, 2);
    // The camera the demo frames the cage scene with (the rest cage's box).
    let lo = cage
        .positions
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p))
        .as_vec3();
    let hi = cage
        .positions
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p))
        .as_vec3();
    let orbit = Orbit::framing(0.5 * (lo + hi), (hi - lo).max_element());
    let view_proj = orbit.view_proj(w as f32 / h as f32);
    // The vertex nearest the eye: a corner in front, nothing else projected near it.
    let eye = orbit.eye();
    let k = (0..cage.positions.len())
        .min_by(|&a, &b| {
            let d = |i: usize| (cage.positions[i].as_vec3() - eye).length();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let start = to_screen(&view_proj, cage.positions[k].as_vec3(), w, h);
    let target = (start.0 + 28.0, start.1 - 21.0);
    let mid = (start.0 + 10.0, start.1 - 5.0);

    let dir = std::env::temp_dir().join(format!("gregvox-drag-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let f = |(x, y): (f64, f64)| format!("{x:.2}:{y:.2}");
    let keys = [
        "h".to_string(), // the overlay off: the frames compared below show the surface alone
        "Space".into(),  // pause: the cage shows and its vertices can be picked
        "p".into(),
        format!("press:{}", f(start)),
        format!("move:{}", f(mid)),
        format!("move:{}", f(target)),
        "release".into(),
        "p".into(),
        "w".into(), // cage 001: dragged
        "z".into(),
        "w".into(), // cage 002: undone
        format!("press:{}", f(start)),
        format!("move:{}", f(mid)),
        "release".into(),
        "r".into(),
        "w".into(), // cage 003: reset
        // A press away from every vertex orbits the camera instead.
        "press:5:5".into(),
        "move:40:5".into(),
        "release".into(),
    ];
    let size = format!("{w}x{h}");
    // The adaptive path on: the edited cage goes through the same chain as with uniform grids.
    let err = common::run_demo_window(
        &[
            "--frames",
            "110",
            "--size",
            &size,
            "--scene",
            "cage",
            "--time-step",
            "0.02",
            "--adaptive",
            "8",
        ],
        &keys,
        &dir,
    );
    assert_eq!(
        err.matches(&format!("picked handle {k} ")).count(),
        2,
        "vertex {k} picked twice:\n{err}"
    );
    for said in ["undo (0 left)", "reset", "gregvox-cage-003.obj"] {
        assert!(err.contains(said), "no '{said}' in:\n{err}");
    }

    // The dragged cage: vertex k alone moved, onto the cursor (in the view plane it was picked in).
    let dragged = gregvox::api::load_mesh(dir.join("gregvox-cage-001.obj")).unwrap();
    assert_eq!(dragged.indices, cage.indices);
    for (i, (a, b)) in dragged.positions.iter().zip(&cage.positions).enumerate() {
        if i != k {
            assert!((*a - *b).length() < 1e-6, "vertex {i} moved: {a} from {b}");
        }
    }
    let moved = dragged.positions[k].as_vec3();
    let on_screen = to_screen(&view_proj, moved, w, h);
    let miss = (on_screen.0 - target.0).hypot(on_screen.1 - target.1);
    assert!(
        miss < 2.0,
        "vertex {k} at {on_screen:?} on screen, the cursor at {target:?}"
    );
    let depth = |p: Vec3| view_proj.project_point3(p).z;
    assert!(
        (depth(moved) - depth(cage.positions[k].as_vec3())).abs() < 1e-4,
        "the drag stays in the view plane"
    );
    assert!((moved - cage.positions[k].as_vec3()).length() > 0.1);

    // Undo and reset give the cage back.
    for n in [2, 3] {
        let back = gregvox::api::load_mesh(dir.join(format!("gregvox-cage-{n:03}.obj"))).unwrap();
        for (a, b) in back.positions.iter().zip(&cage.positions) {
            assert!((*a - *b).length() < 1e-6, "cage {n}: {a} against {b}");
        }
    }

    // The surface moved where the cursor went: the frames before and after the drag differ around it.
    let (sw, sh, before) = read_png(&dir.join("gregvox-screenshot-001.png"));
    let (_, _, after) = read_png(&dir.join("gregvox-screenshot-002.png"));
    assert_eq!((sw, sh), (w, h));
    let (tx, ty) = (target.0 as i64, target.1 as i64);
    let mut changed = 0;
    for y in (ty - 20).max(0)..(ty + 20).min(h as i64) {
        for x in (tx - 20).max(0)..(tx + 20).min(w as i64) {
            let i = ((y as u32 * w + x as u32) * 4) as usize;
            if (0..3).any(|c| before[i + c].abs_diff(after[i + c]) > 16) {
                changed += 1;
            }
        }
    }
    assert!(changed > 100, "{changed} pixels changed around the cursor");

    // G1 holds on the edited surface as on the original.
    let (g_rest, g_dragged) = (g1_jump(&cage), g1_jump(&dragged));
    assert!(g_rest < 1e-3, "{g_rest}");
    assert!(g_dragged < 1e-3, "G1 after the drag: {g_dragged} rad");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_dragged_curve_point_follows_the_cursor_and_the_wheel_sets_its_nurbs_weight() {
    use gregvox::demo::curves::{framing, CurveControls, BEZIER_POINTS, BSPLINE_POINTS};
    let (w, h) = (320u32, 240u32);
    let view_proj = framing().view_proj(w as f32 / h as f32);
    // The middle NURBS control point, as the paused scene shows it.
    let k = (BEZIER_POINTS + BSPLINE_POINTS + 2) as usize;
    let shown = CurveControls::default().at(0.0).points()[k];
    let p = Vec3::new(shown.x as f32, 0.0, shown.y as f32);
    let start = to_screen(&view_proj, p, w, h);
    let target = (start.0 - 15.0, start.1 + 24.0);
    let dir = std::env::temp_dir().join(format!("gregvox-drag-curve-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let f = |(x, y): (f64, f64)| format!("{x:.2}:{y:.2}");
    let keys = [
        "h".to_string(),
        "Space".into(),
        "p".into(),
        format!("press:{}", f(start)),
        format!("move:{}", f(target)),
        "wheel:2".into(),
        "release".into(),
        "p".into(),
    ];
    let size = format!("{w}x{h}");
    let err = common::run_demo_window(
        &["--frames", "50", "--size", &size, "--scene", "curves"],
        &keys,
        &dir,
    );
    assert!(err.contains(&format!("picked handle {k} ")), "{err}");
    // Two notches heavier: 2 × 1.25².
    assert!(err.contains("NURBS weight 2: 3.1250"), "{err}");
    let moved = moved_to(&err, k).as_vec3();
    assert!(
        moved.y.abs() < 1e-4,
        "the point stays in the curves' plane: {moved}"
    );
    let on_screen = to_screen(&view_proj, moved, w, h);
    let miss = (on_screen.0 - target.0).hypot(on_screen.1 - target.1);
    assert!(
        miss < 2.0,
        "{on_screen:?} on screen, the cursor at {target:?}"
    );
    // The curve moved: the frames before and after differ around the NURBS panel.
    let changed = pixels_changed(&dir);
    assert!(changed > 200, "{changed} pixels changed");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_dragged_flag_corner_follows_the_cursor_and_the_corrected_flag_stays_g1() {
    use gregvox::engine::flag::{corner_offsets, flag_corners, flag_patches_with, FlagParams};
    let (w, h) = (320u32, 240u32);
    // The demo's flag: 3×2 patches, paused at t = 0, framed over its 3×2 box.
    let params = FlagParams::default();
    let orbit = Orbit::framing(Vec3::new(1.5, 1.0, 0.0), 3.0);
    let view_proj = orbit.view_proj(w as f32 / h as f32);
    let corners = flag_corners(&params, &[]);
    let eye = orbit.eye();
    let k = (0..corners.len())
        .min_by(|&a, &b| {
            let d = |i: usize| (corners[i].as_vec3() - eye).length();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let start = to_screen(&view_proj, corners[k].as_vec3(), w, h);
    let target = (start.0 + 20.0, start.1 - 16.0);
    let dir = std::env::temp_dir().join(format!("gregvox-drag-flag-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let f = |(x, y): (f64, f64)| format!("{x:.2}:{y:.2}");
    let keys = [
        "h".to_string(),
        "Space".into(),
        "p".into(),
        format!("press:{}", f(start)),
        format!("move:{}", f(target)),
        "release".into(),
        "p".into(),
    ];
    let size = format!("{w}x{h}");
    let err = common::run_demo_window(
        &["--frames", "45", "--size", &size, "--scene", "flag"],
        &keys,
        &dir,
    );
    assert!(err.contains(&format!("picked handle {k} ")), "{err}");
    let moved = moved_to(&err, k);
    let on_screen = to_screen(&view_proj, moved.as_vec3(), w, h);
    let miss = (on_screen.0 - target.0).hypot(on_screen.1 - target.1);
    assert!(
        miss < 2.0,
        "{on_screen:?} on screen, the cursor at {target:?}"
    );
    // The network with that corner moved keeps the corrected flag G1 (the f64 reference the GPU equals).
    let mut positions = corners.clone();
    positions[k] = moved;
    let offsets = corner_offsets(&params, &positions);
    let patches = flag_patches_with(&params, &offsets).unwrap();
    let jump = common::flag_max_jump(&patches, 3, 2);
    assert!(
        jump <= 1e-9,
        "normal jump {jump} rad across the corrected flag's edges"
    );
    let changed = pixels_changed(&dir);
    assert!(changed > 200, "{changed} pixels changed");
    let _ = std::fs::remove_dir_all(&dir);
}

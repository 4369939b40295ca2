//! Specification of the largest grid, R = 2048 (2³³ voxels, 1 GiB of bits): it is tiled so that no storage
//! binding exceeds `maxStorageBufferRange` (128 MiB on lavapipe), and the count is exact.
//!
//! The model is a unit cube with a cubical cavity [¼, ¾]³ (an inverted inner shell). The grid is fitted to the
//! unit cube, so voxel centres sit at (i + ½)/2048 and no centre lies on a face: the cavity removes exactly the
//! 1024³ voxels with 512 ≤ i < 1536 on every axis, and the solid count is 2048³ − 1024³ with no tolerance.
//! Four layers per column exercise the layer loop at the full viewport. Runs through the binary with the
//! validation layer forced on.
use std::process::Command;

const OUTER: [[f64; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 1.0],
];

/// Outward-facing quads of a cube over the corners above (1-based OBJ indices).
const QUADS: [[usize; 4]; 6] = [
    [1, 4, 3, 2],
    [5, 6, 7, 8],
    [1, 2, 6, 5],
    [2, 3, 7, 6],
    [3, 4, 8, 7],
    [4, 1, 5, 8],
];

fn hollow_cube_obj() -> std::path::PathBuf {
    let mut s = String::new();
    for p in OUTER {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for p in OUTER {
        let q = p.map(|c| 0.25 + 0.5 * c);
        s += &format!("v {} {} {}\n", q[0], q[1], q[2]);
    }
    for q in QUADS {
        s += &format!("f {} {} {} {}\n", q[0], q[1], q[2], q[3]);
    }
    // The cavity's shell faces inward: reversed winding.
    for q in QUADS {
        s += &format!("f {} {} {} {}\n", q[3] + 8, q[2] + 8, q[1] + 8, q[0] + 8);
    }
    let dir = std::env::temp_dir().join(format!("gregvox-voxel-scale-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("hollow_cube.obj");
    std::fs::write(&path, s).unwrap();
    path
}

fn voxelize_2048(method: &str) -> serde_json::Value {
    let obj = hollow_cube_obj();
    let out = Command::new(env!("CARGO_BIN_EXE_gregvox"))
        .args(["voxelize", obj.to_str().unwrap(), "--res", "2048"])
        .args(["--axis", "z", "--method", method, "--json"])
        .env("GREGVOX_VALIDATION", "1")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{method} at 2048 failed:\n{err}");
    assert!(
        !err.contains("vulkan validation") && !err.contains("panicked"),
        "{err}"
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

const EXACT: u64 = 2048 * 2048 * 2048 - 1024 * 1024 * 1024;

#[test]
fn peel_at_2048_counts_the_hollow_cube_exactly() {
    let j = voxelize_2048("peel");
    assert_eq!(j["layers"]["z"].as_u64(), Some(4), "{j}");
    assert_eq!(j["solid_voxels"].as_u64(), Some(EXACT));
    let h = 1.0 / 2048.0;
    assert_eq!(j["voxel_size"], serde_json::json!([h, h, h]));
}

#[test]
fn abuffer_at_2048_counts_the_hollow_cube_exactly() {
    let j = voxelize_2048("abuffer");
    assert_eq!(j["solid_voxels"].as_u64(), Some(EXACT));
}

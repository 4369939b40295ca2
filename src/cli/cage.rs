//! Shared by the commands that take a quad cage: loading it as GPU Gregory topology, and measuring normal
//! jumps across shared patch edges of an evaluated grid.
use crate::engine::gregory::GregoryTopology;
use crate::passes::gregory_eval::SurfaceVertex;
use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Loads an OBJ quad cage and builds its ACC-2 topology (refining non-quad cages once, with a note).
pub fn load_cage_topology(
    path: &Path,
) -> anyhow::Result<(GregoryTopology, Vec<DVec3>, Option<String>)> {
    let _ = path;
    anyhow::bail!("{}: ACC-2 cages are not supported yet", path.display())
}

/// Largest normal jump across shared edges (consistently oriented patches).
pub fn max_jump_shared_edges(
    _topo: &GregoryTopology,
    vertices: &[SurfaceVertex],
    level: u32,
) -> f64 {
    max_jump_coincident(vertices, level)
}

/// Largest angle (rad, up to orientation) between the normals of coincident boundary vertices of different
/// patches (within 1e-5 of the grid's bounding-box diagonal) in an evaluated (L+1)²-per-patch grid.
pub fn max_jump_coincident(vertices: &[SurfaceVertex], level: u32) -> f64 {
    let n = (level + 1) as usize;
    let per = n * n;
    if vertices.is_empty() || per == 0 {
        return 0.0;
    }
    let pos = |v: &SurfaceVertex| Vec3::new(v.position[0], v.position[1], v.position[2]);
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for v in vertices {
        lo = lo.min(pos(v));
        hi = hi.max(pos(v));
    }
    let tol = ((hi - lo).length() * 1e-5).max(f32::MIN_POSITIVE);
    let cell = |p: Vec3| ((p - lo) / tol).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    let boundary = |k: usize| {
        let l = k % per;
        let (i, j) = (l % n, l / n);
        i == 0 || j == 0 || i == n - 1 || j == n - 1
    };
    for (k, v) in vertices.iter().enumerate() {
        if boundary(k) {
            grid.entry(cell(pos(v))).or_default().push(k);
        }
    }
    let mut worst = 0.0f64;
    for (k, v) in vertices.iter().enumerate() {
        if !boundary(k) {
            continue;
        }
        let c = cell(pos(v));
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(list) = grid.get(&(c + glam::IVec3::new(dx, dy, dz))) else {
                        continue;
                    };
                    for &o in list {
                        if o / per == k / per || (pos(&vertices[o]) - pos(v)).length() > tol {
                            continue;
                        }
                        let a =
                            DVec3::new(v.normal[0] as f64, v.normal[1] as f64, v.normal[2] as f64);
                        let b = &vertices[o].normal;
                        let b = DVec3::new(b[0] as f64, b[1] as f64, b[2] as f64);
                        let theta = a.cross(b).length().atan2(a.dot(b));
                        worst = worst.max(theta.min(std::f64::consts::PI - theta));
                    }
                }
            }
        }
    }
    worst
}

//! Quad cages for the Gregory pipeline: loading one as GPU Gregory topology (with the valence limit and one
//! Catmull–Clark step for non-quad cages), a built-in box cage, and measuring normal jumps across shared
//! patch edges of an evaluated grid.
use crate::engine::gregory::{
    canonical_edge_flags, GregorySurface, GregoryTopology, SingularPoint,
};
use crate::mesh::{load_cage_file, Cage, Mesh};
use crate::passes::gregory_eval::SurfaceVertex;
use crate::surface::adaptive::AdaptiveStencils;
use crate::surface::{CageStencils, GregoryStencils, PtexMap, Tangents};
use glam::{DVec3, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// Loads a quad cage (any mesh file format) and builds its patches for a device surface
/// ([`surface_topologies`]: refining non-quad cages once, with a note; feature-adaptive patches in the ptex
/// layout past the uniform limit), for viewing: a cage far from the world origin ([`crate::geom::is_far`])
/// comes back moved to its box's minimum corner (in f64), so its f32 GPU surface keeps the precision of one
/// at the origin.
pub fn load_cage_topology(path: &Path) -> crate::Result<CageTopologies> {
    Ok(load_cage(path)?.1)
}

/// [`load_cage_topology`] that also returns the cage as loaded, its positions moved as the rest positions
/// are (the demo draws and edits it). The UV layout is in the topologies when the cage has UVs.
pub fn load_cage(path: &Path) -> crate::Result<(Mesh, CageTopologies)> {
    let cage = load_cage_file(path)?;
    let mut t = surface_topologies(&cage, Tangents::OpenSubdiv, true).map_err(|e| match e {
        crate::Error::Invalid(msg) => crate::Error::parse(path, msg),
        e => e,
    })?;
    let lo = t
        .rest
        .iter()
        .fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
    let hi = t
        .rest
        .iter()
        .fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
    if crate::geom::is_far(lo.to_array(), hi.to_array()) {
        for p in &mut t.rest {
            *p -= lo;
        }
    }
    let mut mesh = cage.mesh;
    mesh.positions.clone_from(&t.rest);
    Ok((mesh, t))
}

/// Largest vertex valence (and polygon size: an n-gon refined once makes a valence-n vertex) accepted for
/// Gregory patches. Why a limit: every patch around a vertex reads its whole 1-ring, so the stencil matrix
/// W grows with the square of the valence (measured, debug build on lavapipe: a 256-gon takes 12 s, a
/// 1000-gon over a minute, a million-gon never ends). Real cages stay far below (valence ≤ 16 is typical).
pub const MAX_CAGE_VALENCE: usize = 64;

/// Refuses cages past [`MAX_CAGE_VALENCE`] with a message naming the face or vertex.
pub fn check_cage_valence(mesh: &Mesh) -> crate::Result<()> {
    if let Some(f) = (0..mesh.n_faces()).find(|&f| mesh.face(f).len() > MAX_CAGE_VALENCE) {
        return Err(crate::Error::Invalid(format!(
            "face {} has {} vertices; refined into quads it makes a vertex of that valence, and Gregory \
             patches support valence up to {MAX_CAGE_VALENCE}",
            f + 1,
            mesh.face(f).len()
        )));
    }
    let mut faces_at = vec![0usize; mesh.positions.len()];
    for &v in &mesh.indices {
        faces_at[v as usize] += 1;
    }
    // A boundary vertex has one edge more than faces: allow for it.
    if let Some((v, n)) = faces_at
        .iter()
        .enumerate()
        .find(|&(_, &n)| n + 1 > MAX_CAGE_VALENCE)
    {
        return Err(crate::Error::Invalid(format!(
            "vertex {} is shared by {n} faces; Gregory patches support valence up to {MAX_CAGE_VALENCE}",
            v + 1
        )));
    }
    Ok(())
}

/// The GPU topology of an untagged cage: W (columns = the cage's vertices), patch point rows and
/// canonical-edge flags of the all-quad patch layout.
pub fn cage_topology(
    mesh: &Mesh,
    tangents: Tangents,
) -> crate::Result<(GregoryTopology, Vec<DVec3>, Option<String>)> {
    tagged_cage_topology(&Cage::from(mesh.clone()), tangents)
}

/// [`cage_topology`] of a tagged cage (creases, corners, holes, boundary rule): one patch per quad that is
/// not a hole.
pub fn tagged_cage_topology(
    cage: &Cage,
    tangents: Tangents,
) -> crate::Result<(GregoryTopology, Vec<DVec3>, Option<String>)> {
    let t = tagged_cage_topologies(cage, tangents, false)?;
    Ok((t.topology, t.rest, t.note))
}

/// A UV surface's patch layout: the UV cage's stencils ([`crate::surface::fvar`]) and its values as points
/// (u, v, 0); patch `k` is the positions' patch `k`.
#[derive(Clone, Debug)]
pub struct UvTopology {
    pub topology: GregoryTopology,
    pub values: Vec<DVec3>,
}

/// What [`tagged_cage_topologies`] builds.
pub struct CageTopologies {
    pub topology: GregoryTopology,
    /// The cage's positions.
    pub rest: Vec<DVec3>,
    pub note: Option<String>,
    /// The UVs' layout, when asked for and the cage has UVs.
    pub uv: Option<UvTopology>,
    /// Where each ptex face (face, u, v) is among the patches (both layouts).
    pub ptex: PtexMap,
    /// How a device surface lays its vertices out over these patches.
    pub layout: Layout,
}

/// How a device surface ([`GregorySurface`]) tessellates a cage's patches.
pub enum Layout {
    /// One `(level + 1)²` grid per patch: the uniform refinement, every patch at the same depth.
    Patches,
    /// One grid per ptex face over the feature-adaptive patches ([`GregorySurface::new_ptex`]), when the
    /// uniform refinement would pass [`crate::surface::acc2::MAX_REFINED_PATCHES`]: the cage (its faces
    /// make the grids) and, when it has UVs, their evaluator (the host evaluates UVs once: they do not
    /// deform).
    Ptex {
        cage: Box<Cage>,
        uv: Option<Box<crate::surface::LimitEvaluator>>,
    },
}

impl CageTopologies {
    /// The device surface of these patches at `level`, in their layout.
    pub fn gregory_surface(
        &self,
        ctx: &crate::gpu::Context,
        level: u32,
    ) -> crate::Result<GregorySurface> {
        match &self.layout {
            Layout::Patches => GregorySurface::new(ctx, &self.topology, &self.rest, level),
            Layout::Ptex { cage, .. } => {
                let mut cage = (**cage).clone();
                cage.mesh.positions.clone_from(&self.rest);
                GregorySurface::new_ptex(ctx, &self.topology, &cage, self.ptex.clone(), level)
            }
        }
    }
}

/// The device layout of feature-adaptive patches (for [`GregorySurface::new_ptex`]): their W and point rows.
pub fn adaptive_topology(a: &AdaptiveStencils) -> GregoryTopology {
    GregoryTopology {
        w: a.stencils.w.clone(),
        patch_points: a.stencils.patch_points.clone(),
        // The ptex layout evaluates its grid points by query: no patch edge is evaluated canonically.
        patch_flags: vec![0; a.stencils.patch_points.len()],
        singular: Vec::new(),
    }
}

/// [`tagged_cage_topologies`] for a device surface: past the uniform refinement's limit
/// ([`crate::surface::acc2::MAX_REFINED_PATCHES`]: semi-sharp features on a large cage), the
/// feature-adaptive patches of [`AdaptiveStencils::from_cage`] in the [`Layout::Ptex`] layout, with a note
/// saying so, instead of an error.
pub fn surface_topologies(
    cage: &Cage,
    tangents: Tangents,
    uvs: bool,
) -> crate::Result<CageTopologies> {
    use crate::surface::acc2::{uniform_patch_count, MAX_REFINED_PATCHES};
    let uniform = uniform_patch_count(cage)?;
    if uniform <= MAX_REFINED_PATCHES {
        return tagged_cage_topologies(cage, tangents, uvs);
    }
    check_cage_valence(&cage.mesh)?;
    let a = AdaptiveStencils::from_cage(cage, tangents)?;
    let n = a.stencils.patch_points.len();
    let uv = if uvs {
        let e = crate::surface::LimitEvaluator::from_adaptive(cage, &a)?.with_uv(cage, a.levels)?;
        e.has_uv().then(|| Box::new(e))
    } else {
        None
    };
    let note = format!(
        "the cage's uniform refinement to level {} would make {uniform} patches, past {MAX_REFINED_PATCHES}: \
         its {n} feature-adaptive patches are tessellated per ptex face (one grid a face, level segments \
         per cage edge)",
        a.levels
    );
    Ok(CageTopologies {
        ptex: PtexMap::from_tree(cage, &a.tree),
        topology: adaptive_topology(&a),
        rest: cage.mesh.positions.clone(),
        note: Some(note),
        uv: None,
        layout: Layout::Ptex {
            cage: Box::new(cage.clone()),
            uv,
        },
    })
}

fn topology_of(cs: CageStencils) -> GregoryTopology {
    let quads: Vec<[u32; 4]> = cs
        .stencils
        .patch_face
        .iter()
        .map(|&f| {
            let q = cs.quad_mesh.face(f as usize);
            [q[0], q[1], q[2], q[3]]
        })
        .collect();
    GregoryTopology {
        w: cs.stencils.w,
        patch_points: cs.stencils.patch_points,
        patch_flags: canonical_edge_flags(&quads),
        singular: singular_points(&quads),
    }
}

/// [`tagged_cage_topology`], and with `uvs` the UV surface's layout beside it (OpenSubdiv's tangent
/// masks; `None` when the cage has no UVs).
pub fn tagged_cage_topologies(
    cage: &Cage,
    tangents: Tangents,
    uvs: bool,
) -> crate::Result<CageTopologies> {
    let mesh = &cage.mesh;
    check_cage_valence(mesh)?;
    let cs = GregoryStencils::from_cage(cage, tangents)?;
    let uv = if uvs {
        crate::surface::fvar::uv_stencils(cage, &cs, Tangents::OpenSubdiv)?.map(|(uvc, ucs)| {
            UvTopology {
                topology: topology_of(ucs),
                values: uvc.mesh.positions,
            }
        })
    } else {
        None
    };
    let note = cs.note.clone();
    let ptex = PtexMap::new(cage, &cs);
    Ok(CageTopologies {
        topology: topology_of(cs),
        rest: mesh.positions.clone(),
        note,
        uv,
        ptex,
        layout: Layout::Patches,
    })
}

/// The interior vertices of valence 2 of an all-quad patch layout, with their patch corners.
///
/// ```
/// use gregvox::engine::cage::singular_points;
/// // A square split into two quads through its centre 4: vertex 4 is interior (both its edges are shared)
/// // with the two neighbours 0 and 2; the square's corners lie on the boundary.
/// let sheet = [[0, 1, 2, 4], [0, 4, 2, 3]];
/// let s = singular_points(&sheet);
/// assert_eq!(s.len(), 1);
/// assert_eq!((s[0].vertex, s[0].corners.clone()), (4, vec![(0, 3), (1, 1)]));
/// // Closed by one quad below (a pillow), the corners 1 and 3 become interior with valence 2 as well.
/// let pillow = [[0, 1, 2, 4], [0, 4, 2, 3], [3, 2, 1, 0]];
/// let v: Vec<u32> = singular_points(&pillow).iter().map(|s| s.vertex).collect();
/// assert_eq!(v, [1, 3, 4]);
/// ```
pub fn singular_points(quads: &[[u32; 4]]) -> Vec<SingularPoint> {
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    let mut corners: HashMap<u32, Vec<(u32, u8)>> = HashMap::new();
    for (f, q) in quads.iter().enumerate() {
        for c in 0..4 {
            let (a, b) = (q[c], q[(c + 1) % 4]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            corners.entry(q[c]).or_default().push((f as u32, c as u8));
        }
    }
    let mut out: Vec<SingularPoint> = corners
        .into_iter()
        .filter(|(v, at)| {
            let mut ring: Vec<u32> = Vec::new();
            for &(f, c) in at {
                let q = quads[f as usize];
                ring.push(q[(c as usize + 1) % 4]);
                ring.push(q[(c as usize + 3) % 4]);
            }
            ring.sort_unstable();
            ring.dedup();
            let interior = ring
                .iter()
                .all(|&n| edges.get(&(n.min(*v), n.max(*v))) == Some(&2));
            interior && ring.len() == 2
        })
        .map(|(vertex, corners)| SingularPoint { vertex, corners })
        .collect();
    out.sort_by_key(|s| s.vertex);
    out
}

/// A cage where half the vertices are extraordinary: the icosphere of `subdivisions` midpoint levels (unit
/// radius, 20·4ⁿ outward triangles, valence 5 and 6) after one Catmull–Clark level, so every old vertex
/// (valence 5 or 6) and every face point (valence 3) is extraordinary. The bench's many-EV cage.
///
/// ```
/// let m = gregvox::engine::cage::icosphere_quad_cage(3);
/// assert_eq!(m.n_faces(), 3 * 20 * 64); // three quads per triangle
/// let t = gregvox::api::topology(&m);
/// assert!(t.closed && t.genus == Some(0));
/// let extraordinary: usize = t.valence_histogram.iter().filter(|(v, _)| v.as_str() != "4").map(|(_, n)| n).sum();
/// assert_eq!(extraordinary, 642 + 1280); // the old vertices and the face points
/// ```
pub fn icosphere_quad_cage(subdivisions: u32) -> Mesh {
    let g = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<DVec3> = [
        [-1.0, g, 0.0],
        [1.0, g, 0.0],
        [-1.0, -g, 0.0],
        [1.0, -g, 0.0],
        [0.0, -1.0, g],
        [0.0, 1.0, g],
        [0.0, -1.0, -g],
        [0.0, 1.0, -g],
        [g, 0.0, -1.0],
        [g, 0.0, 1.0],
        [-g, 0.0, -1.0],
        [-g, 0.0, 1.0],
    ]
    .iter()
    .map(|p| DVec3::from_array(*p).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoint: HashMap<(u32, u32), u32> = HashMap::new();
        let mut mid = |a: u32, b: u32, positions: &mut Vec<DVec3>| -> u32 {
            *midpoint.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        tris = tris
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    mid(a, b, &mut positions),
                    mid(b, c, &mut positions),
                    mid(c, a, &mut positions),
                );
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let faces: Vec<Vec<u32>> = tris.iter().map(|t| t.to_vec()).collect();
    let sphere = Mesh::from_polygons(positions, &faces).expect("a valid icosphere");
    crate::mesh::catmull_clark(&sphere, 1)
}

/// The demo's built-in cage: the surface of an `nx × ny × nz` box lattice of size 2 × 1 × 1, outward quads
/// (valence-3 corners, valence-4 elsewhere).
///
/// ```
/// let m = gregvox::engine::cage::builtin_cage(4, 2, 2);
/// assert_eq!(m.n_faces(), 2 * (4 * 2 + 2 * 2 + 4 * 2));
/// ```
pub fn builtin_cage(nx: u32, ny: u32, nz: u32) -> Mesh {
    let (nx, ny, nz) = (nx.max(1), ny.max(1), nz.max(1));
    let n = [nx, ny, nz];
    let size = [2.0, 1.0, 1.0];
    let mut index: HashMap<[u32; 3], u32> = HashMap::new();
    let mut positions = Vec::new();
    let mut id = |p: [u32; 3], positions: &mut Vec<DVec3>| -> u32 {
        *index.entry(p).or_insert_with(|| {
            positions.push(DVec3::new(
                size[0] * (p[0] as f64 / nx as f64 - 0.5),
                size[1] * (p[1] as f64 / ny as f64 - 0.5),
                size[2] * (p[2] as f64 / nz as f64 - 0.5),
            ));
            positions.len() as u32 - 1
        })
    };
    let mut faces = Vec::new();
    for axis in 0..3 {
        let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, n[axis]] {
            for i in 0..n[a] {
                for j in 0..n[b] {
                    let corner = |di: u32, dj: u32| {
                        let mut p = [0u32; 3];
                        p[axis] = side;
                        p[a] = i + di;
                        p[b] = j + dj;
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    let mut f: Vec<u32> = q.iter().map(|&p| id(p, &mut positions)).collect();
                    // (a, b, axis) is right-handed: counter-clockwise in (a, b) faces +axis.
                    if side == 0 {
                        f.reverse();
                    }
                    faces.push(f);
                }
            }
        }
    }
    Mesh::from_polygons(positions, &faces).expect("a valid lattice box")
}

/// Largest normal jump across shared edges of a cage's patches, away from its singular points (see
/// [`cage_jumps`]). The patches of a consistently oriented cage share its orientation, so the angle is
/// signed: a patch whose normal flips shows as a jump near π.
pub fn max_jump_shared_edges(
    topo: &GregoryTopology,
    vertices: &[SurfaceVertex],
    level: u32,
) -> f64 {
    cage_jumps(topo, vertices, level).worst
}

/// The normal jumps of a cage's uniform tessellation (one (L+1)² grid per patch).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CageJumps {
    /// The largest angle (rad) between the normals of coincident boundary samples of different patches,
    /// leaving out the samples at singular points (where there is no tangent plane to agree on).
    pub worst: f64,
    /// Per singular point of the topology: the point (the patches' shared corner sample) and the largest
    /// angle (rad) between the normals its patches give it.
    pub singular: Vec<SingularJump>,
}

/// One singular point's normals ([`CageJumps::singular`]).
#[derive(Clone, Debug, PartialEq)]
pub struct SingularJump {
    pub point: SingularPoint,
    /// The corner sample's position (the tessellation's frame).
    pub position: [f32; 3],
    pub jump: f64,
}

/// [`CageJumps`] of `vertices`, the uniform tessellation of `topo` at `level`.
pub fn cage_jumps(topo: &GregoryTopology, vertices: &[SurfaceVertex], level: u32) -> CageJumps {
    let n = (level + 1) as usize;
    let per = n * n;
    let corner = |(patch, c): (u32, u8)| -> Option<&SurfaceVertex> {
        let (i, j) = [(0, 0), (n - 1, 0), (n - 1, n - 1), (0, n - 1)][c as usize];
        vertices.get(patch as usize * per + j * n + i)
    };
    let mut excluded = std::collections::HashSet::new();
    let mut singular = Vec::new();
    for point in &topo.singular {
        let at: Vec<&SurfaceVertex> = point.corners.iter().filter_map(|&c| corner(c)).collect();
        let Some(first) = at.first() else { continue };
        let mut jump = 0.0f64;
        for (k, a) in at.iter().enumerate() {
            excluded.insert(a.position_key());
            for b in &at[k + 1..] {
                jump = jump.max(angle(dvec(a.normal_xyz()), dvec(b.normal_xyz())));
            }
        }
        singular.push(SingularJump {
            point: point.clone(),
            position: first.xyz(),
            jump,
        });
    }
    CageJumps {
        worst: coincident_jumps_away_from(vertices, level, &excluded).worst,
        singular,
    }
}

fn dvec(a: [f32; 3]) -> DVec3 {
    DVec3::from(a.map(f64::from))
}

/// The angle (rad, 0 to π) between two normals.
fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Largest angle (rad, 0 to π) between the normals of coincident boundary vertices of different patches
/// (within 1e-5 of the grid's bounding-box diagonal) in an evaluated (L+1)²-per-patch grid. The angle is
/// the full one between the normals, not between tangent planes: a patch whose normal flips shows as a
/// jump near π. (Beziex's 04_Cup1 does show π: its rim edges have a vanishing cross-boundary derivative,
/// |S_cross| ≈ 5e-8 against |S_along| ≈ 0.7, so the normal drawn there is undefined.)
pub fn max_jump_coincident(vertices: &[SurfaceVertex], level: u32) -> f64 {
    coincident_jumps(vertices, level).worst
}

/// What [`coincident_jumps`] measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CoincidentJumps {
    /// The largest angle (rad).
    pub worst: f64,
    /// Pairs of distinct samples compared: the work done, linear in the surface (a file that repeats
    /// its patches compares as many pairs as one copy).
    pub pairs_compared: usize,
}

/// [`max_jump_coincident`] with the number of sample pairs it compared.
pub fn coincident_jumps(vertices: &[SurfaceVertex], level: u32) -> CoincidentJumps {
    coincident_jumps_away_from(vertices, level, &std::collections::HashSet::new())
}

/// [`coincident_jumps`] leaving out the boundary samples at the positions `excluded` (f32 bits, -0 as 0).
fn coincident_jumps_away_from(
    vertices: &[SurfaceVertex],
    level: u32,
    excluded: &std::collections::HashSet<[u32; 3]>,
) -> CoincidentJumps {
    let n = (level + 1) as usize;
    let per = n * n;
    if vertices.is_empty() || per == 0 {
        return CoincidentJumps::default();
    }
    let pos = |v: &SurfaceVertex| Vec3::new(v.position[0], v.position[1], v.position[2]);
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for v in vertices {
        lo = lo.min(pos(v));
        hi = hi.max(pos(v));
    }
    let tol = ((hi - lo).length() * 1e-5).max(f32::MIN_POSITIVE);
    let cell = |p: Vec3| ((p - lo) / tol).floor().as_ivec3();
    let boundary = |k: usize| {
        let l = k % per;
        let (i, j) = (l % n, l / n);
        i == 0 || j == 0 || i == n - 1 || j == n - 1
    };
    // Boundary samples merged by (position, normal) bits: two of them contribute an angle of 0 to each
    // other, so only one is kept, with whether it came from more than one patch. A file of many
    // coincident patches (the same patch repeated) then costs what one copy costs, not the square of
    // the copies.
    struct Sample {
        position: Vec3,
        normal: DVec3,
        patch: usize,
        several_patches: bool,
    }
    let mut index: HashMap<([u32; 3], [u32; 3]), usize> = HashMap::new();
    let mut samples: Vec<Sample> = Vec::new();
    for (k, v) in vertices.iter().enumerate() {
        if !boundary(k) || excluded.contains(&v.position_key()) {
            continue;
        }
        let key = (
            [v.position[0], v.position[1], v.position[2]].map(f32::to_bits),
            [v.normal[0], v.normal[1], v.normal[2]].map(f32::to_bits),
        );
        match index.get(&key) {
            Some(&s) => samples[s].several_patches |= samples[s].patch != k / per,
            None => {
                index.insert(key, samples.len());
                samples.push(Sample {
                    position: pos(v),
                    normal: DVec3::new(v.normal[0] as f64, v.normal[1] as f64, v.normal[2] as f64),
                    patch: k / per,
                    several_patches: false,
                });
            }
        }
    }
    let mut grid: HashMap<glam::IVec3, Vec<usize>> = HashMap::new();
    for (s, sample) in samples.iter().enumerate() {
        grid.entry(cell(sample.position)).or_default().push(s);
    }
    let mut worst = 0.0f64;
    let mut pairs_compared = 0;
    for (s, a) in samples.iter().enumerate() {
        let c = cell(a.position);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let Some(list) = grid.get(&(c + glam::IVec3::new(dx, dy, dz))) else {
                        continue;
                    };
                    for &o in list {
                        let b = &samples[o];
                        let other_patch =
                            a.patch != b.patch || a.several_patches || b.several_patches;
                        if o == s || !other_patch || (b.position - a.position).length() > tol {
                            continue;
                        }
                        worst = worst.max(angle(a.normal, b.normal));
                        pairs_compared += 1;
                    }
                }
            }
        }
    }
    CoincidentJumps {
        worst,
        pairs_compared,
    }
}

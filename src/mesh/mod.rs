//! Mesh loading (OBJ, STL, PLY, OFF, glTF/GLB: [`load_mesh_file`]) and writing ([`mod@write`]: OBJ, PLY, STL,
//! GLB), mesh connectivity as sparse matrices (`MeshMatrix`): topology, normals, subdivision, and
//! reduction by parallel quadric edge collapses ([`simplify`]).
//!
//! Ownership: [`Mesh`] (positions + polygon faces as read) is the input; [`MeshMatrix`] owns the
//! connectivity (M, Mᵀ, E) and answers every topology question; positions stay outside it as
//! `&[DVec3]` so one connectivity serves a deforming cage. Free functions (libigl style) and methods on
//! `MeshMatrix` compute the same things. Everything is deterministic (stable counting sorts, gathers
//! summed in row order), `u32`-indexed and ready to upload to the GPU as-is.
//!
//! ```
//! use gregvox::mesh::{parse_obj, MeshMatrix, NormalWeighting};
//! let mesh = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n", "tet.obj").unwrap();
//! let m = MeshMatrix::from_mesh(&mesh);
//! let report = m.report();
//! assert!(report.closed);
//! assert_eq!(report.euler_characteristic, 2);
//! let n = m.vertex_normals(&mesh.positions, NormalWeighting::Area);
//! assert!(n.iter().all(|v| (v.length() - 1.0).abs() < 1e-12));
//! ```
pub mod distance;
mod glb;
pub mod host_kernels;
mod load;
mod matrix;
mod normals;
mod obj;
mod off;
mod ply;
pub mod sample;
pub mod simplify;
mod sparse;
mod stl;
mod subdivision;
mod tags;
mod topology;
mod uv;
pub mod write;

pub use load::{load_cage_file, load_mesh_file, parse_mesh_bytes, MeshFormat};
pub use matrix::{ActionMap, FaceLayout, HalfEdgeFace, MeshMatrix, VertexCorners, NONE};
pub use normals::{
    face_centroids, face_normals, face_normals_unnormalized, vertex_normals, vertex_normals_f32,
    NormalWeighting,
};
pub use obj::{load_obj, parse_obj, weld, write_obj, Mesh};
pub use sparse::SparseMatrix;
pub use subdivision::{
    catmull_clark, catmull_clark_matrix, catmull_clark_matrix_creased,
    catmull_clark_matrix_creased_hidden, dependent_vertex_sharpness, loop_matrix, loop_subdivide,
    rows_sum_to_one, CreasedSubdivision, LoopBeta, Subdivision, SubdivisionStack,
};
pub use tags::{
    load_obj_cage, parse_obj_cage, BoundaryInterpolation, Cage, CornerTag, Crease, SubdivTags,
    SHARPNESS_INFINITE,
};
pub use topology::{EdgeUse, TopologyReport};
pub use uv::{FVarLinear, FaceVarying};

//! Gregory patches from cages (ACC-2 stencils), Beziex patches, CPU reference tessellator.
//!
//! Invariants: patch `k` of a quad cage is face `k` (`patch_face[k]` once hole faces are skipped); control points are in OpenSubdiv GREGORY_BASIS order
//! (see [`crate::geom::gregory`]); tessellation grids follow the contract of docs/ARCHITECTURE.md (u along
//! v0→v1, rows of u inner, vertex `j·(L+1)+i` at (i/L, j/L)).
pub mod acc2;
pub mod adaptive;
pub mod beziex;
pub mod evaluate;
pub mod features;
pub mod fvar;
pub mod gregory_host;
pub mod ptex_grid;
pub mod tessellate;

pub use acc2::{gather_patches, CageStencils, GregoryStencils, Tangents};
pub use evaluate::{LimitEvaluator, LimitSample, Located, PtexMap};
pub use features::Features;
pub use tessellate::{indices, tessellate, write_tessellation_obj, Tessellation};

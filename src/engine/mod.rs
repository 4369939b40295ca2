//! Multi-pass GPU workflows composed from the passes: voxelization (and, later, the Gregory surface
//! pipeline). Each workflow owns its passes and the transient resources of one run.
pub mod cage;
pub mod flag;
pub mod gregory;
pub mod vertex_pull;
pub mod voxelize;

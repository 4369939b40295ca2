//! Multi-pass GPU workflows composed from the passes: solid voxelization (`voxelize`: depth peeling,
//! A-buffer, the resident voxelizer), the Gregory surface from a cage (`gregory`, with `cage` building its
//! topology), the capturing vertex-pull path (`vertex_pull`) and the thesis's flag of boundary-curve patches
//! (`flag`). Each workflow owns its passes and its buffers: for one run (the voxelizers) or for its lifetime
//! (the surfaces, the resident voxelizer); all of them release themselves when dropped.
pub mod cage;
pub mod evaluator;
pub mod flag;
pub mod gregory;
pub mod mesh;
pub mod vertex_pull;
pub mod voxelize;

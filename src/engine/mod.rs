//! Multi-pass GPU workflows composed from the passes: solid voxelization (`voxelize`: depth peeling,
//! A-buffer, the resident voxelizer), the Gregory surface from a cage (`gregory`) and the thesis's flag of
//! boundary-curve patches (`flag`). Each workflow owns its passes and its buffers: for one run (the
//! voxelizers) or for its lifetime (the surfaces, the resident voxelizer).
pub mod flag;
pub mod gregory;
pub mod voxelize;

//! Solid voxelization: the grid contract, the CPU reference voxelizer, the GPU depth-peeling driver, hygiene
//! of the input triangles and the exporters.
pub mod cpu;
pub mod export;
pub mod grid;
pub mod mesh;
pub mod raycast;

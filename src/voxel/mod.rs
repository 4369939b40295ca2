//! Solid voxelization on the CPU side: the grid contract, the CPU reference voxelizer, hygiene of the input
//! triangles, the surface (triangle–box) voxels, the exporters (OpenVDB's `.vdb` among them) and the solid's boundary mesh, the CPU reference of the voxel ray caster and the
//! generalized winding number's stress suite. The GPU drivers (depth peeling,
//! A-buffer) are one layer up, in the engine's `voxelize` module.
pub mod boundary;
pub mod cpu;
pub mod export;
pub mod grid;
pub mod gwn;
pub mod levelset;
pub mod mesh;
pub mod raycast;
pub mod stress;
pub mod surface;
pub mod vdb;

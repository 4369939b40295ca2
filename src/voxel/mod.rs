//! The voxel grid contract, the CPU voxelizer and exporters.

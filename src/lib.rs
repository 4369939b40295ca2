//! gregvox: a Vulkan-native engine (on `ash`) for smooth Gregory surfaces and solid voxels.
//!
//! # Quick start
//!
//! The [`api`] module is the whole workflow in a few calls; everything it creates on the GPU releases itself
//! when dropped. Voxelize a mesh, build a Gregory surface from a quad cage, ask a mesh its topology:
//!
//! ```no_run
//! use gregvox::{load_mesh, topology, Deformation, Gpu, VoxelizeOptions};
//!
//! # fn main() -> gregvox::Result<()> {
//! let gpu = Gpu::new()?; // any Vulkan 1.2 device; lavapipe when there is no GPU
//! let mesh = load_mesh("assets/models/stanford-bunny.obj")?;
//! let voxels = gpu.voxelize(&mesh, &VoxelizeOptions::default().res(256))?;
//! voxels.grid.save("bunny.binvox")?;
//!
//! let cage = load_mesh("assets/models/spot_quadrangulated.obj")?;
//! let mut surface = gpu.gregory_surface(&cage, 8)?;
//! surface.deform(Deformation::Twist, 0.5, 0.2)?; // on the GPU: cage → control points → patches
//! let vertices = surface.read_vertices()?; // positions and unit normals, patch after patch
//! assert_eq!(vertices.len(), surface.patch_count() as usize * 81);
//!
//! let report = topology(&mesh);
//! println!("closed: {}, boundary edges: {}", report.closed, report.boundary_edges);
//! # Ok(())
//! # }
//! ```
//!
//! The same without a file or a GPU (this one runs as a test):
//!
//! ```
//! use gregvox::mesh::Mesh;
//! use gregvox::{topology, voxelize_on_cpu, VoxelizeOptions};
//! # fn main() -> gregvox::Result<()> {
//! let corners = (0..8).map(|i| glam::DVec3::new((i & 1) as f64, (i >> 1 & 1) as f64, (i >> 2) as f64));
//! let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
//! let cube = Mesh::from_polygons(corners.collect(), &quads.map(|q| q.to_vec()))?;
//! assert!(topology(&cube).closed);
//! let voxels = voxelize_on_cpu(&cube, &VoxelizeOptions::default().res(16))?;
//! assert_eq!(voxels.grid.count(), 16 * 16 * 16);
//! // A chosen voxel size, one empty voxel around, every voxel a face touches as well as the solid:
//! let opts = VoxelizeOptions::default().voxel_size(0.25).pad(1).fill(gregvox::Fill::Both);
//! let voxels = voxelize_on_cpu(&cube, &opts)?;
//! assert_eq!(voxels.grid.frame.dims, [6, 6, 6]);
//! assert_eq!(voxels.grid.frame.centre(0, 0, 0), [-0.125; 3]);
//! # Ok(())
//! # }
//! ```
//!
//! # Layers
//!
//! Nothing imports from a layer above it:
//! `cli` → `demo`, `bench` → `args` → [`api`] → [`engine`] (multi-pass workflows) → [`passes`] (one GPU pass per file)
//! → [`surface`], [`voxel`] → [`mesh`] → [`geom`]; [`gpu`] is the Vulkan foundation and knows no geometry;
//! [`error`] and [`io`] are shared by all. The app (`cli`, `demo`, `bench`) sits behind cargo features of the
//! same names, on by default: `cargo build --lib --no-default-features` builds the engine without clap,
//! winit, plotters or indicatif. `docs/ARCHITECTURE.md` follows a mesh from a file to voxels or pixels.
#[cfg(feature = "cli")]
pub mod args;
#[cfg(feature = "bench")]
pub mod bench;
#[cfg(feature = "cli")]
pub mod cli;
#[cfg(feature = "demo")]
pub mod demo;

pub mod api;
pub mod engine;
pub mod error;
pub mod geom;
pub mod gpu;
pub mod io;
pub mod mesh;
pub mod npy;
pub mod passes;
pub mod surface;
pub mod voxel;

pub use api::{
    load_mesh, topology, voxelize, voxelize_on_cpu, Axes, Deformation, Fill, Gpu, Method, Surface,
    Voxelization, VoxelizeOptions, VoxelizeReport,
};
pub use error::{Error, Result};

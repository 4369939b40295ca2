//! [`voxelize_gregory_surface`]: a Gregory surface voxelized straight from the device-local vertex buffer its
//! evaluation pass wrote (no CPU round trip of the surface).
use super::*;
use crate::voxel::cpu::FillRule;

/// Voxelizes a Gregory surface straight from its device-local vertex buffer: the grid frame (`spec` over the
/// surface's box) comes from a GPU bounds reduction (six numbers read back), and the peel pass draws the evaluation pass's vertex and index
/// buffers as they are. The surface must have been recorded (evaluated) before.
pub fn voxelize_gregory_surface(
    ctx: &Context,
    surface: &crate::engine::gregory::GregorySurface,
    spec: &crate::voxel::grid::GridSpec,
    axes: &[Axis],
    rule: FillRule,
    max_layers: u32,
    profiler: Option<&mut Profiler>,
) -> Result<(VoxelGrid, Vec<AxisStats>)> {
    let bounds = crate::engine::gregory::SurfaceBounds::new(ctx)?;
    ctx.one_shot(|cmd| bounds.record(ctx, cmd, surface))?;
    let (lo, hi) = bounds.read(ctx)?;
    let surface_box = Bounds::of_points([lo, hi])?;
    let frame = spec.frame(surface_box)?;
    let mut v = PeelVoxelizer::new(ctx, 32)?;
    v.max_layers = max_layers;
    let geom = PeelGeometry {
        vertices: surface.vertices(),
        indices: surface.indices(),
        index_count: surface.index_count(),
        bounds: Some(surface_box),
        mesh: None,
    };
    v.voxelize(ctx, &geom, &frame, axes, rule, profiler)
}

//! `ClosestPointPass`: the nearest piece of a distance tree to each of many points, on the device in f64
//! (glsl/closest_point.comp), for `MeshQuery::unsigned_distance_on` / `signed_distance_on`.
//!
//! Invariants: the pass owns its pipeline; the tree ([`DeviceLayout`], uploaded once by
//! [`nearest_slots`]), the points (four f64 per point) and the slots (one u32 per point) are the caller's
//! buffers. A slot is the piece with the least (squared distance, triangle index), as the CPU's search
//! computes them, or with [`INCOMPLETE`] set the best piece of a search that stopped at
//! [`Search::visits`] nodes (lavapipe ends an invocation's loops after 65,535 iterations in all). Slots are
//! below 2³¹ (checked).
//! The shader computes in f64: the device must have `shaderFloat64` ([`ClosestPointPass::new`] refuses
//! otherwise). The traversal stack holds [`STACK`] nodes: [`ClosestPointPass::record`] refuses a deeper
//! tree (a median-split tree of 2³² pieces is 30 deep). On exit the slots are visible to transfers.
//!
//! Cost: one invocation per point, O(log P) nodes near a spread surface as on the CPU (no Morton-order
//! hint: each point searches alone); the host finishes the incomplete searches (and, verifying, checks
//! every answer) in a descent the device's piece prunes at once. The correcting shader's division costs
//! about 3× the search on lavapipe (which runs both sides of every branch), hence the IEEE variant there.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::compute_writes_to_readers;
use crate::gpu::{shaders, Buffer, Context, MemoryLocation};
use crate::mesh::distance::DeviceLayout;
use ash::vk;

/// Push constants (`Push` in glsl/closest_point.comp).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    count: u32,
    visits: u32,
    /// Tests only: ulps added to every quotient before the shader corrects it (0 in use).
    perturb: i32,
    pad: u32,
}

/// The traversal stack of the kernel (`STACK` in glsl/closest_point.comp).
pub const STACK: u32 = 64;

/// Nodes one search visits at most by default: under lavapipe's 65,535 loop iterations per invocation,
/// far above what a search needs on any mesh of the tests and the bench (they complete).
pub const VISITS: u32 = 60_000;

/// How the shader searches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Search {
    /// Nodes one search visits at most (then its slot has [`INCOMPLETE`] set).
    pub visits: u32,
    /// Tests only: ulps added to every quotient before the shader rounds it to nearest, as a device whose
    /// f64 division is that far off would give it (0 in use; not 0 forces the correcting shader).
    pub perturb: i32,
    /// Use the correcting shader even where the driver's division is IEEE's (tests).
    pub force_correction: bool,
}

impl Default for Search {
    fn default() -> Self {
        Search {
            visits: VISITS,
            perturb: 0,
            force_correction: false,
        }
    }
}

/// The slot's high bit: the search stopped before it was done (`INCOMPLETE` in glsl/closest_point.comp).
pub const INCOMPLETE: u32 = 1 << 31;

// The shader writes a leaf's pieces out one by one (`PIECE(k)`), for at most 8 of them.
const _: () = assert!(crate::mesh::distance::LEAF <= 8);

/// Points per submission of [`nearest_slots`] (8 MiB of points): a submission stays short on a slow
/// device, and the host memory of one batch is bounded.
pub const POINTS_PER_SUBMIT: usize = 1 << 18;

/// Whether the device's f64 division is known to be IEEE 754's (rounded to nearest): lavapipe compiles
/// it to the CPU's own division instruction. Elsewhere the shader corrects every quotient (Vulkan requires
/// only add, subtract and multiply to be correctly rounded).
pub fn ieee_division(ctx: &Context) -> bool {
    ctx.info.driver_name == "llvmpipe"
}

/// The nearest-piece compute pass.
pub struct ClosestPointPass {
    pipeline: ComputePipeline,
    /// Whether the pipeline corrects the driver's quotients (glsl/closest_point.comp) or takes them as
    /// they are (glsl/closest_point_ieee.comp).
    corrects: bool,
}

impl ClosestPointPass {
    /// The pass; `correct_division` picks the shader that rounds every quotient as IEEE 754 does (needed
    /// unless [`ieee_division`]; the tests force it on lavapipe to check the correction).
    pub fn new(ctx: &Context, correct_division: bool) -> Result<Self> {
        if !ctx.info.features.shader_float64 {
            return Err(Error::Invalid(format!(
                "{}: the nearest-triangle search needs shaderFloat64",
                ctx.info.name
            )));
        }
        let mut b = DescriptorSetLayoutBuilder::new();
        for i in 0..5 {
            b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
        }
        let layout = b.build(ctx, "closest point set")?;
        let (name, code) = if correct_division {
            ("closest point", shaders::CLOSEST_POINT_COMP)
        } else {
            (
                "closest point (IEEE division)",
                shaders::CLOSEST_POINT_IEEE_COMP,
            )
        };
        Ok(ClosestPointPass {
            pipeline: ComputePipeline::new(
                ctx,
                name,
                code,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
            corrects: correct_division,
        })
    }

    /// Records the search of `count` points of `points` into `slots` over the tree in `nodes`,
    /// `triangles` and `index` (uploaded from `layout`), as `search` says.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        layout: &DeviceLayout,
        nodes: &Buffer,
        triangles: &Buffer,
        index: &Buffer,
        points: &Buffer,
        slots: &Buffer,
        count: u64,
        search: Search,
    ) -> Result<()> {
        if layout.depth >= STACK {
            return Err(Error::Invalid(format!(
                "a distance tree {} nodes deep (the device's search holds {STACK})",
                layout.depth
            )));
        }
        if layout.index.is_empty() {
            return Err(Error::Invalid(
                "the device's nearest-triangle search: a tree without triangles".into(),
            ));
        }
        if count * 32 > points.size() || count * 4 > slots.size() {
            return Err(Error::Invalid(format!(
                "{count} points do not fit buffers '{}' and '{}'",
                points.name(),
                slots.name()
            )));
        }
        if count == 0 {
            return Ok(());
        }
        if search.perturb != 0 && !self.corrects {
            return Err(Error::Invalid(
                "perturbed quotients need the correcting shader".into(),
            ));
        }
        if count > u32::MAX as u64 {
            return Err(Error::Invalid(format!("{count} points in one dispatch")));
        }
        let push = Push {
            count: count as u32,
            visits: search.visits,
            perturb: search.perturb,
            pad: 0,
        };
        let bindings = [
            (0, Binding::Storage(nodes.raw())),
            (1, Binding::Storage(triangles.raw())),
            (2, Binding::Storage(points.raw())),
            (3, Binding::Storage(slots.raw())),
            (4, Binding::Storage(index.raw())),
        ];
        self.pipeline
            .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&push));
        self.pipeline.dispatch_linear(ctx, cmd, count)?;
        compute_writes_to_readers(ctx, cmd);
        Ok(())
    }
}

/// The slot of the nearest piece of `layout`'s tree to each of `points` (in the tree's local frame), in
/// their order, as `search` says: the tree uploaded once, the points in submissions of
/// [`POINTS_PER_SUBMIT`]. A new pipeline each call; [`nearest_slots_with`] takes one made before.
pub fn nearest_slots(
    ctx: &Context,
    layout: &DeviceLayout,
    points: &[[f64; 3]],
    search: Search,
) -> Result<Vec<u32>> {
    let correct = search.force_correction || search.perturb != 0 || !ieee_division(ctx);
    nearest_slots_with(
        ctx,
        &ClosestPointPass::new(ctx, correct)?,
        layout,
        points,
        search,
    )
}

/// [`nearest_slots`] with `pass`.
pub fn nearest_slots_with(
    ctx: &Context,
    pass: &ClosestPointPass,
    layout: &DeviceLayout,
    points: &[[f64; 3]],
    search: Search,
) -> Result<Vec<u32>> {
    if layout.index.len() >= INCOMPLETE as usize {
        return Err(Error::Invalid(format!(
            "a distance tree of {} pieces (the device's search numbers fewer than 2³¹)",
            layout.index.len()
        )));
    }
    let range = ctx.limits.max_storage_buffer_range as u64;
    let bytes = (layout.triangles.len() * 32) as u64;
    if bytes > range || (layout.nodes.len() * 64) as u64 > range {
        return Err(Error::Invalid(format!(
            "{}: a distance tree of {} pieces ({} MiB) is past maxStorageBufferRange ({} MiB)",
            ctx.info.name,
            layout.index.len(),
            bytes >> 20,
            range >> 20
        )));
    }
    let usage = vk::BufferUsageFlags::STORAGE_BUFFER;
    let nodes = ctx.upload_buffer(
        "distance tree nodes",
        bytemuck::cast_slice(&layout.nodes),
        usage,
    )?;
    let triangles = ctx.upload_buffer(
        "distance tree pieces",
        bytemuck::cast_slice(&layout.triangles),
        usage,
    )?;
    let index = ctx.upload_buffer(
        "distance tree piece triangles",
        bytemuck::cast_slice(&layout.index),
        usage,
    )?;
    let mut slots = Vec::with_capacity(points.len());
    for chunk in points.chunks(POINTS_PER_SUBMIT) {
        let rows: Vec<[f64; 4]> = chunk.iter().map(|q| [q[0], q[1], q[2], 0.0]).collect();
        let n = rows.len() as u64;
        let pbuf =
            ctx.upload_buffer("distance query points", bytemuck::cast_slice(&rows), usage)?;
        let sbuf = ctx.create_buffer(
            "distance query slots",
            n * 4,
            usage | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?;
        ctx.one_shot(|cmd| {
            pass.record(
                ctx, cmd, layout, &nodes, &triangles, &index, &pbuf, &sbuf, n, search,
            )
        })?;
        slots.extend(ctx.read_pod::<u32>(&sbuf)?);
    }
    Ok(slots)
}

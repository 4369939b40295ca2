//! `AdaptiveLevelsPass`: the screen-space tessellation level of every Gregory patch, the crack-free level of
//! every shared edge, and one indexed-indirect draw command per patch (glsl/adaptive_levels.comp).
//!
//! Invariants: the pass owns only its pipeline; every buffer is the caller's. The level rule (also in
//! [`patch_level`], the CPU reference): L_p = clamp(⌈s / pixels_per_segment⌉, 1, L_max) with s the longest of
//! the four projected boundary control polygons in pixels; a control point at or behind the eye plane gives
//! L_max. Edge levels are L_e = min over the patches sharing the edge, so [`crate::passes::gregory_eval`]'s
//! adaptive variant snaps both sides of an edge to the same samples. Draw command p draws the (L_p+1)² grid in
//! patch p's slot of (L_max+1)² vertices from [`adaptive_indices`] (grids of levels 1…L_max concatenated).
//! On exit the levels, edge levels and commands are visible to compute reads, indirect draws and copies.
use crate::error::{Error, Result};
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::{compute_to_compute, memory_barrier};
use crate::gpu::{shaders, Buffer, Context};
use crate::passes::gregory_eval::MAX_LEVEL;
use ash::vk;
use glam::{DVec3, DVec4, Mat4};

/// The view that sets the adaptive levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveParams {
    /// World → clip (the same matrix the draw uses).
    pub view_proj: Mat4,
    /// Viewport size in pixels.
    pub viewport: [f32; 2],
    /// Target length of one tessellation segment on screen, in pixels (> 0).
    pub pixels_per_segment: f32,
}

impl AdaptiveParams {
    /// Checks the parameters (one clear message per problem).
    pub fn validate(&self) -> Result<()> {
        if !(self.pixels_per_segment > 0.0 && self.pixels_per_segment.is_finite()) {
            return Err(Error::Invalid(format!(
                "adaptive tessellation needs a positive number of pixels per segment, not {}",
                self.pixels_per_segment
            )));
        }
        if !self.viewport.iter().all(|v| *v > 0.0 && v.is_finite()) {
            return Err(Error::Invalid(format!(
                "adaptive tessellation needs a positive viewport, not {:?}",
                self.viewport
            )));
        }
        if !self.view_proj.is_finite() {
            return Err(Error::Invalid(
                "the adaptive view-projection matrix is not finite".into(),
            ));
        }
        Ok(())
    }
}

/// `VkDrawIndexedIndirectCommand`, as the pass writes it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct DrawCommand {
    pub index_count: u32,
    pub instance_count: u32,
    pub first_index: u32,
    pub vertex_offset: i32,
    pub first_instance: u32,
}

/// Index of the first index of level `level`'s grid in [`adaptive_indices`]: Σ_{l<level} 6·l².
pub fn first_index(level: u32) -> u32 {
    (level - 1) * level * (2 * level - 1)
}

/// The grids of levels 1…`l_max` concatenated (each as `grid_indices(1, l)`: vertex `j·(l+1)+i`).
///
/// ```
/// use gregvox::passes::adaptive_levels::{adaptive_indices, first_index};
/// let idx = adaptive_indices(3);
/// assert_eq!(idx.len() as u32, first_index(4));
/// assert_eq!(&idx[6..12], &[0, 1, 4, 0, 4, 3]); // level 2 starts after level 1's 6 indices
/// ```
pub fn adaptive_indices(l_max: u32) -> Vec<u32> {
    (1..=l_max)
        .flat_map(|l| crate::passes::gregory_eval::grid_indices(1, l))
        .collect()
}

/// Triangles over patch grids stored one after the other (patch p's (L_p+1)² vertices, rows of u inner,
/// right after patch p−1's): the index list of an adaptive tessellation read back compactly.
///
/// ```
/// let idx = gregvox::passes::adaptive_levels::compact_grid_indices(&[1, 1]);
/// assert_eq!(idx, [0, 1, 3, 0, 3, 2, 4, 5, 7, 4, 7, 6]);
/// ```
pub fn compact_grid_indices(levels: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    let mut base = 0;
    for &l in levels {
        out.extend(
            crate::passes::gregory_eval::grid_indices(1, l)
                .into_iter()
                .map(|i| i + base),
        );
        base += (l + 1) * (l + 1);
    }
    out
}

/// The draw command of patch `patch` at `level` with slots of (`l_max`+1)² vertices.
pub fn draw_command(patch: u32, level: u32, l_max: u32) -> DrawCommand {
    DrawCommand {
        index_count: 6 * level * level,
        instance_count: 1,
        first_index: first_index(level),
        vertex_offset: (patch * (l_max + 1) * (l_max + 1)) as i32,
        first_instance: 0,
    }
}

/// CPU reference of the level rule for one patch from its 20 control points (f64; the GPU computes in f32,
/// so the two can differ by one where s / pixels_per_segment is within rounding of an integer).
/// Returns the level and the unrounded ratio s / pixels_per_segment (∞ behind the eye).
pub fn patch_level(cv: &[DVec3; 20], p: &AdaptiveParams, l_max: u32) -> (u32, f64) {
    const EDGES: [[usize; 4]; 4] = [
        [0, 1, 7, 5],
        [5, 6, 12, 10],
        [15, 17, 11, 10],
        [0, 2, 16, 15],
    ];
    let m = p.view_proj.as_dmat4();
    let half = glam::DVec2::new(p.viewport[0] as f64, p.viewport[1] as f64) * 0.5;
    let mut longest = 0.0f64;
    for e in EDGES {
        let mut len = 0.0;
        let mut prev = None;
        for k in e {
            let c: DVec4 = m * cv[k].extend(1.0);
            // Not in front of the eye plane (NaN included).
            if c.w.partial_cmp(&(1e-6 * c.truncate().length())) != Some(std::cmp::Ordering::Greater)
            {
                return (l_max, f64::INFINITY);
            }
            let s = c.truncate().truncate() / c.w * half;
            if let Some(q) = prev {
                len += s.distance(q);
            }
            prev = Some(s);
        }
        longest = longest.max(len);
    }
    let ratio = longest / p.pixels_per_segment as f64;
    let want = ratio.ceil();
    let level = if want.is_nan() || want >= l_max as f64 {
        l_max
    } else {
        (want as u32).max(1)
    };
    (level, ratio)
}

/// Edge topology of a patch layout for the adaptive path: edges are identified by their four boundary
/// control-point rows (shared W rows ⇔ bit-identical canonical edges, docs/notes/gregory.md §4.2).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct EdgeTopology {
    /// Per patch edge (4·patch + e), its edge id.
    pub edge_ids: Vec<u32>,
    /// CSR offsets into `edge_patches`, one more than edges.
    pub edge_offsets: Vec<u32>,
    /// The patches sharing each edge.
    pub edge_patches: Vec<u32>,
}

impl EdgeTopology {
    /// Groups the patch edges whose boundary rows are the same set.
    pub fn new(patch_points: &[[u32; 20]]) -> Self {
        const EDGES: [[usize; 4]; 4] = [
            [0, 1, 7, 5],
            [5, 6, 12, 10],
            [15, 17, 11, 10],
            [0, 2, 16, 15],
        ];
        let mut ids = std::collections::HashMap::new();
        let mut lists: Vec<Vec<u32>> = Vec::new();
        let mut edge_ids = Vec::with_capacity(patch_points.len() * 4);
        for (p, pts) in patch_points.iter().enumerate() {
            for e in EDGES {
                let mut key = e.map(|k| pts[k]);
                key.sort_unstable();
                let id = *ids.entry(key).or_insert_with(|| {
                    lists.push(Vec::new());
                    lists.len() as u32 - 1
                });
                if !lists[id as usize].contains(&(p as u32)) {
                    lists[id as usize].push(p as u32);
                }
                edge_ids.push(id);
            }
        }
        let mut edge_offsets = vec![0];
        let mut edge_patches = Vec::new();
        for l in lists {
            edge_patches.extend(l);
            edge_offsets.push(edge_patches.len() as u32);
        }
        EdgeTopology {
            edge_ids,
            edge_offsets,
            edge_patches,
        }
    }

    /// Number of distinct edges.
    pub fn edge_count(&self) -> u32 {
        self.edge_offsets.len() as u32 - 1
    }
}

/// The caller's buffers the pass reads and writes.
pub struct AdaptiveBuffers<'a> {
    /// vec4 control points and 20 u32 rows per patch (as for the evaluation pass).
    pub points: &'a Buffer,
    pub patch_points: &'a Buffer,
    /// Out: u32 level per patch.
    pub levels: &'a Buffer,
    /// Out: one [`DrawCommand`] per patch (INDIRECT_BUFFER usage).
    pub commands: &'a Buffer,
    /// [`EdgeTopology::edge_offsets`] and [`EdgeTopology::edge_patches`].
    pub edge_offsets: &'a Buffer,
    pub edge_patches: &'a Buffer,
    /// Out: u32 level per edge.
    pub edge_levels: &'a Buffer,
}

/// The adaptive level pass.
pub struct AdaptiveLevelsPass {
    pipeline: ComputePipeline,
}

/// Push constants of the kernel (`Push` in glsl/adaptive_levels.comp).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    view_proj: [f32; 16],
    viewport: [f32; 2],
    pixels_per_segment: f32,
    l_max: u32,
    count: u32,
    mode: u32,
}

impl AdaptiveLevelsPass {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let mut b = DescriptorSetLayoutBuilder::new();
        for i in 0..7 {
            b = b.storage_buffer(i, vk::ShaderStageFlags::COMPUTE);
        }
        let layout = b.build(ctx, "adaptive levels set")?;
        Ok(AdaptiveLevelsPass {
            pipeline: ComputePipeline::new(
                ctx,
                "adaptive levels",
                shaders::ADAPTIVE_LEVELS_COMP,
                vec![layout],
                std::mem::size_of::<Push>() as u32,
                64,
            )?,
        })
    }

    /// Records the patch levels and commands, then the edge levels, for `patch_count` patches and
    /// `edge_count` edges with levels up to `l_max`.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        b: &AdaptiveBuffers,
        params: &AdaptiveParams,
        (patch_count, edge_count, l_max): (u32, u32, u32),
    ) -> Result<()> {
        params.validate()?;
        if !(1..=MAX_LEVEL).contains(&l_max) {
            return Err(Error::Invalid(format!(
                "adaptive maximum level {l_max} is outside 1…{MAX_LEVEL}"
            )));
        }
        let checks = [
            (b.levels, patch_count as u64 * 4),
            (b.commands, patch_count as u64 * 20),
            (b.edge_levels, edge_count as u64 * 4),
            (b.edge_offsets, (edge_count as u64 + 1) * 4),
        ];
        for (buf, need) in checks {
            if buf.size() < need {
                return Err(Error::Invalid(format!(
                    "buffer '{}' holds {} bytes, {need} needed",
                    buf.name(),
                    buf.size()
                )));
            }
        }
        let bindings = [
            (0, Binding::Storage(b.points.raw())),
            (1, Binding::Storage(b.patch_points.raw())),
            (2, Binding::Storage(b.levels.raw())),
            (3, Binding::Storage(b.commands.raw())),
            (4, Binding::Storage(b.edge_offsets.raw())),
            (5, Binding::Storage(b.edge_patches.raw())),
            (6, Binding::Storage(b.edge_levels.raw())),
        ];
        let mut push = Push {
            view_proj: params.view_proj.to_cols_array(),
            viewport: params.viewport,
            pixels_per_segment: params.pixels_per_segment,
            l_max,
            count: patch_count,
            mode: 0,
        };
        self.pipeline
            .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&push));
        self.pipeline
            .dispatch_linear(ctx, cmd, patch_count as u64)?;
        // Patch levels → edge levels.
        compute_to_compute(ctx, cmd);
        push.count = edge_count;
        push.mode = 1;
        self.pipeline
            .bind(ctx, cmd, &bindings, bytemuck::bytes_of(&push));
        self.pipeline.dispatch_linear(ctx, cmd, edge_count as u64)?;
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::DRAW_INDIRECT
                    | vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::SHADER_STORAGE_READ
                    | vk::AccessFlags2::INDIRECT_COMMAND_READ
                    | vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        Ok(())
    }
}

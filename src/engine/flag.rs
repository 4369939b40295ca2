//! The thesis's flag experiment (Takeda 2008 §3.1.1, Table 3.1): a C×R grid of Gregory patches built every
//! frame on the GPU from an animated network of boundary curves, with the Chiyokura–Kimura compatibility
//! correction switchable on and off, evaluated straight into a vertex buffer.
//!
//! [`flag_patches`] is the f64 CPU reference of glsl/flag_patches.comp (same formulas); [`FlagSurface`] owns the
//! GPU chain: build patches → evaluate (the same `GregoryEvalPass` as cage surfaces). The network's corners
//! can be moved ([`flag_patches_with`], [`FlagSurface::record_offsets`]: the demo drags them); every curve
//! at a corner keeps sharing its tangent plane, so the corrected flag stays G1.
//!
//! Invariants: `FlagSurface` owns its passes and buffers; `record` begins with a barrier from every earlier
//! reader of its buffers (frames in flight) to its compute writes.
use crate::error::{Error, Result};
use crate::geom::compat::{chiyokura_kimura, Edge};
use crate::geom::gregory::PatchF64;
use crate::gpu::pipeline::{Binding, ComputePipeline, DescriptorSetLayoutBuilder};
use crate::gpu::resources::{memory_barrier, record_update};
use crate::gpu::{shaders, Buffer, Context, MemoryLocation, Profiler};
use crate::passes::gregory_eval::{
    grid_indices, vertex_count, ControlPoints, GregoryEvalPass, MAX_LEVEL,
};
use ash::vk;
use glam::DVec3;

/// Push constants of glsl/flag_patches.comp (its `layout(push_constant)` block).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FlagPush {
    columns: u32,
    rows: u32,
    correct: u32,
    pad: u32,
    t: f32,
    amplitude: f32,
}

/// The animated flag's shape parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FlagParams {
    pub columns: u32,
    pub rows: u32,
    pub t: f64,
    pub amplitude: f64,
    /// Apply the Chiyokura–Kimura correction on shared edges.
    pub correct: bool,
}

impl Default for FlagParams {
    fn default() -> Self {
        FlagParams {
            columns: 3,
            rows: 2,
            t: 0.0,
            amplitude: 0.35,
            correct: true,
        }
    }
}

/// The boundary network: the shape parameters and the corners' offsets.
struct Network<'a> {
    p: &'a FlagParams,
    /// Per corner ((columns + 1) × (rows + 1), row-major), or empty for none.
    offsets: &'a [DVec3],
}

impl Network<'_> {
    fn offset(&self, (c, r): (i64, i64)) -> DVec3 {
        let (w, h) = (self.p.columns as i64, self.p.rows as i64);
        if self.offsets.is_empty() || c < 0 || r < 0 || c > w || r > h {
            return DVec3::ZERO;
        }
        self.offsets[(r * (w + 1) + c) as usize]
    }

    fn grid_xy(&self, g: (i64, i64)) -> (f64, f64) {
        let (c, r) = (g.0 as f64, g.1 as f64);
        let o = self.offset(g);
        (
            c + 0.15 * (1.3 * c + 2.1 * r + 0.4).sin() + o.x,
            r + 0.15 * (0.7 * c + 1.9 * r + 1.1).sin() + o.y,
        )
    }

    fn corner(&self, g: (i64, i64)) -> DVec3 {
        self.corner_with(g, self.offset(g))
    }

    /// Corner `g` moved by `o` (whatever the offsets say).
    fn corner_with(&self, g: (i64, i64), o: DVec3) -> DVec3 {
        let p = self.p;
        let (c, r) = (g.0 as f64, g.1 as f64);
        let x = c + 0.15 * (1.3 * c + 2.1 * r + 0.4).sin() + o.x;
        let y = r + 0.15 * (0.7 * c + 1.9 * r + 1.1).sin() + o.y;
        let phi = 2.0 * x - 3.0 * p.t + 0.6 * y;
        DVec3::new(x, y, p.amplitude * (x / p.columns as f64) * phi.sin() + o.z)
    }

    /// The inner point near corner `a` of the network cubic from `a` to `b`.
    fn near_point(&self, a: (i64, i64), b: (i64, i64)) -> DVec3 {
        let p = self.p;
        let (x, y) = self.grid_xy(a);
        let (bx, by) = self.grid_xy(b);
        let (dx, dy) = (bx - x, by - y);
        let w = p.columns as f64;
        let phi = 2.0 * x - 3.0 * p.t + 0.6 * y;
        let fx = p.amplitude * (phi.sin() / w + (x / w) * 2.0 * phi.cos());
        let fy = p.amplitude * (x / w) * 0.6 * phi.cos();
        self.corner(a) + DVec3::new(dx, dy, fx * dx + fy * dy) / 3.0
    }
}

/// The offsets that put the network's corners at `positions` (one per corner, as [`flag_corners`] lists
/// them): the inverse of [`flag_corners`], the height measured from the wave at the moved grid position.
pub fn corner_offsets(p: &FlagParams, positions: &[DVec3]) -> Vec<DVec3> {
    let net = Network { p, offsets: &[] };
    let corners: Vec<(i64, i64)> = (0..=p.rows as i64)
        .flat_map(|r| (0..=p.columns as i64).map(move |c| (c, r)))
        .collect();
    corners
        .iter()
        .zip(positions)
        .map(|(&g, q)| {
            let (x, y) = net.grid_xy(g);
            let at = net.corner_with(g, DVec3::new(q.x - x, q.y - y, 0.0));
            DVec3::new(q.x - x, q.y - y, q.z - at.z)
        })
        .collect()
}

/// The network's corners ((columns + 1) × (rows + 1), row-major) with `offsets` (as
/// [`flag_patches_with`]): where the demo draws the handles it drags.
pub fn flag_corners(p: &FlagParams, offsets: &[DVec3]) -> Vec<DVec3> {
    let net = Network { p, offsets };
    (0..=p.rows as i64)
        .flat_map(|r| (0..=p.columns as i64).map(move |c| (c, r)))
        .map(|g| net.corner(g))
        .collect()
}

const OFFSET: [(i64, i64); 4] = [(0, 0), (1, 0), (1, 1), (0, 1)];
/// Start and end corner of edges V0, U1, V1, U0 (parameter increasing).
const EDGE_CORNERS: [(usize, usize); 4] = [(0, 1), (1, 2), (3, 2), (0, 3)];
/// Direction from each edge into the patch.
const INWARD: [(i64, i64); 4] = [(0, 1), (-1, 0), (0, -1), (1, 0)];

/// The flag's patches (row-major, `rows × columns`): the f64 reference of glsl/flag_patches.comp.
///
/// ```
/// use gregvox::engine::flag::{flag_patches, FlagParams};
/// let p = flag_patches(&FlagParams::default()).unwrap();
/// assert_eq!(p.len(), 6);
/// // Neighbours share their boundary cubic exactly.
/// assert_eq!(p[0].cv[5], p[1].cv[0]);
/// ```
pub fn flag_patches(p: &FlagParams) -> Result<Vec<PatchF64>> {
    flag_patches_with(p, &[])
}

/// [`flag_patches`] with the network's corners moved by `offsets` (one per corner, (columns + 1) ×
/// (rows + 1) row-major: xy added to the grid position, z to the height; empty for none). Every curve at a
/// corner still shares its tangent plane, so the correction keeps the shared edges G1.
pub fn flag_patches_with(p: &FlagParams, offsets: &[DVec3]) -> Result<Vec<PatchF64>> {
    if p.columns == 0 || p.rows == 0 || p.columns > 4096 || p.rows > 4096 {
        return Err(Error::Invalid(format!(
            "a flag of {}×{} patches is out of range",
            p.columns, p.rows
        )));
    }
    let corners = (p.columns as usize + 1) * (p.rows as usize + 1);
    if !offsets.is_empty() && offsets.len() != corners {
        return Err(Error::Invalid(format!(
            "{} corner offsets given, the {}×{} flag has {corners} corners",
            offsets.len(),
            p.columns,
            p.rows
        )));
    }
    let net = Network { p, offsets };
    let edges = [Edge::V0, Edge::U1, Edge::V1, Edge::U0];
    let mut out = Vec::new();
    for r in 0..p.rows as i64 {
        for c in 0..p.columns as i64 {
            let id = r * p.columns as i64 + c;
            let cs = OFFSET.map(|(dx, dy)| (c + dx, r + dy));
            let mut cv = [DVec3::ZERO; 20];
            for i in 0..4 {
                let pt = net.corner(cs[i]);
                let ep = net.near_point(cs[i], cs[(i + 1) % 4]);
                let em = net.near_point(cs[i], cs[(i + 3) % 4]);
                let f = ep + em - pt;
                cv[5 * i..5 * i + 5].copy_from_slice(&[pt, ep, em, f, f]);
            }
            if p.correct {
                for e in 0..4 {
                    let nb = (c - INWARD[e].0, r - INWARD[e].1);
                    if nb.0 < 0 || nb.1 < 0 || nb.0 >= p.columns as i64 || nb.1 >= p.rows as i64 {
                        continue;
                    }
                    let (s, f) = (cs[EDGE_CORNERS[e].0], cs[EDGE_CORNERS[e].1]);
                    let pts = [
                        net.corner(s),
                        net.near_point(s, f),
                        net.near_point(f, s),
                        net.corner(f),
                    ];
                    let me_a = id < nb.1 * p.columns as i64 + nb.0;
                    let ia = if me_a {
                        INWARD[e]
                    } else {
                        (-INWARD[e].0, -INWARD[e].1)
                    };
                    let step = |q: (i64, i64), d: (i64, i64)| (q.0 + d.0, q.1 + d.1);
                    let neg = (-ia.0, -ia.1);
                    let sol = chiyokura_kimura(
                        &pts,
                        net.near_point(s, step(s, ia)) - pts[0],
                        net.near_point(f, step(f, ia)) - pts[3],
                        net.near_point(s, step(s, neg)) - pts[0],
                        net.near_point(f, step(f, neg)) - pts[3],
                    )?;
                    let face = if me_a { sol.a_face } else { sol.b_face };
                    let inner = edges[e].inner();
                    cv[inner[1]] = face[0];
                    cv[inner[2]] = face[1];
                }
            }
            out.push(PatchF64 { cv });
        }
    }
    Ok(out)
}

/// The GPU flag: patch building and evaluation into a vertex buffer.
pub struct FlagSurface {
    build: ComputePipeline,
    eval: GregoryEvalPass,
    /// The corners' offsets (vec4, (columns + 1) × (rows + 1)), zero until [`FlagSurface::record_offsets`].
    offsets: Buffer,
    points: Buffer,
    patch_points: Buffer,
    patch_flags: Buffer,
    vertices: Buffer,
    indices: Buffer,
    pub columns: u32,
    pub rows: u32,
    pub level: u32,
}

impl FlagSurface {
    /// Creates the passes and buffers for a `columns × rows` flag at `level`.
    pub fn new(ctx: &Context, columns: u32, rows: u32, level: u32) -> Result<Self> {
        if columns == 0 || rows == 0 || columns as u64 * rows as u64 > 1 << 20 {
            return Err(Error::Invalid(format!(
                "a flag of {columns}×{rows} patches is out of range"
            )));
        }
        if !(1..=MAX_LEVEL).contains(&level) {
            return Err(Error::Invalid(format!(
                "tessellation level {level} is outside 1…{MAX_LEVEL}"
            )));
        }
        let n = columns * rows;
        let layout = DescriptorSetLayoutBuilder::new()
            .storage_buffer(0, vk::ShaderStageFlags::COMPUTE)
            .storage_buffer(1, vk::ShaderStageFlags::COMPUTE)
            .build(ctx, "flag set")?;
        let build = ComputePipeline::new(
            ctx,
            "flag patches",
            shaders::FLAG_PATCHES_COMP,
            vec![layout],
            std::mem::size_of::<FlagPush>() as u32,
            64,
        )?;
        let eval = GregoryEvalPass::new(ctx)?;
        let rw = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
        let idx: Vec<u32> = (0..n * 20).collect();
        let corners = (columns as usize + 1) * (rows as usize + 1);
        Ok(FlagSurface {
            build,
            eval,
            offsets: ctx.upload_buffer(
                "flag corner offsets",
                bytemuck::cast_slice(&vec![[0.0f32; 4]; corners]),
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            )?,
            points: ctx.create_buffer(
                "flag points",
                n as u64 * 20 * 16,
                rw,
                MemoryLocation::GpuOnly,
            )?,
            patch_points: ctx.upload_buffer(
                "flag patch points",
                bytemuck::cast_slice(&idx),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            // Each patch's edge points come from the same analytic network, so both sides of an edge agree
            // to f32 evaluation of the same formulas; canonical edges are off (flags unused).
            patch_flags: ctx.upload_buffer(
                "flag patch flags",
                bytemuck::cast_slice(&vec![0u32; n as usize]),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            vertices: ctx.create_buffer(
                "flag vertices",
                vertex_count(n, level) * 32,
                rw | vk::BufferUsageFlags::VERTEX_BUFFER,
                MemoryLocation::GpuOnly,
            )?,
            indices: ctx.upload_buffer(
                "flag indices",
                bytemuck::cast_slice(&grid_indices(n, level)),
                vk::BufferUsageFlags::INDEX_BUFFER,
            )?,
            columns,
            rows,
            level,
        })
    }

    /// The control points (vec4, 20 per patch, written by the flag pass each frame).
    pub fn points(&self) -> &Buffer {
        &self.points
    }

    /// The 20 point indices per patch (GREGORY_BASIS order), as `GregorySurface::patch_points`.
    pub fn patch_points(&self) -> &Buffer {
        &self.patch_points
    }

    /// Number of patches (columns × rows).
    pub fn patch_count(&self) -> u32 {
        self.columns * self.rows
    }

    /// The vertex buffer (stride 32).
    pub fn vertices(&self) -> &Buffer {
        &self.vertices
    }

    /// The index buffer.
    pub fn indices(&self) -> &Buffer {
        &self.indices
    }

    /// Number of indices.
    pub fn index_count(&self) -> u32 {
        self.columns * self.rows * self.level * self.level * 6
    }

    /// Records building the patches at time `t` (with or without the correction) and evaluating them.
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        t: f32,
        amplitude: f32,
        correct: bool,
        mut profiler: Option<(&mut Profiler, usize)>,
    ) -> Result<()> {
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::VERTEX_ATTRIBUTE_INPUT
                    | vk::PipelineStageFlags2::VERTEX_SHADER
                    | vk::PipelineStageFlags2::COMPUTE_SHADER
                    | vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::NONE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
        );
        let name = if correct {
            "flag patches (CK on)"
        } else {
            "flag patches (CK off)"
        };
        let s = profiler
            .as_mut()
            .map(|(p, slot)| p.begin(ctx, cmd, *slot, name));
        let push = FlagPush {
            columns: self.columns,
            rows: self.rows,
            correct: correct as u32,
            pad: 0,
            t,
            amplitude,
        };
        self.build.bind(
            ctx,
            cmd,
            &[
                (0, Binding::Storage(self.points.raw())),
                (1, Binding::Storage(self.offsets.raw())),
            ],
            bytemuck::bytes_of(&push),
        );
        self.build
            .dispatch_linear(ctx, cmd, (self.columns * self.rows) as u64)?;
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER,
                vk::AccessFlags2::SHADER_STORAGE_WRITE,
            ),
            (
                vk::PipelineStageFlags2::COMPUTE_SHADER | vk::PipelineStageFlags2::COPY,
                vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::TRANSFER_READ,
            ),
        );
        if let (Some((p, _)), Some(s)) = (profiler.as_mut(), s) {
            p.end(ctx, cmd, s);
        }
        let s = profiler
            .as_mut()
            .map(|(p, slot)| p.begin(ctx, cmd, *slot, "gregory_eval"));
        self.eval.record(
            ctx,
            cmd,
            ControlPoints::plain(&self.points),
            &self.patch_points,
            &self.patch_flags,
            self.columns * self.rows,
            self.level,
            false,
            &self.vertices,
        )?;
        if let (Some((p, _)), Some(s)) = (profiler.as_mut(), s) {
            p.end(ctx, cmd, s);
        }
        Ok(())
    }

    /// Records new corner offsets (one per corner, (columns + 1) × (rows + 1) row-major, as
    /// [`flag_patches_with`]) into `cmd`: later builds use them, frames in flight keep theirs.
    pub fn record_offsets(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        offsets: &[DVec3],
    ) -> Result<()> {
        let corners = (self.columns as usize + 1) * (self.rows as usize + 1);
        if offsets.len() != corners {
            return Err(Error::Invalid(format!(
                "{} corner offsets given, the flag has {corners} corners",
                offsets.len()
            )));
        }
        let data: Vec<[f32; 4]> = offsets
            .iter()
            .map(|o| [o.x as f32, o.y as f32, o.z as f32, 0.0])
            .collect();
        record_update(ctx, cmd, &self.offsets, bytemuck::cast_slice(&data))
    }

    /// Reads the built control points (20 per patch).
    pub fn read_points(&self, ctx: &Context) -> Result<Vec<[f32; 4]>> {
        ctx.read_pod(&self.points)
    }
}

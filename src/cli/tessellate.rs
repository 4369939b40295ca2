//! `gregvox tessellate IN.obj|IN.gzjson --level N --out OUT.obj`: evaluates every patch on the GPU (compute or
//! vertex-pull path) and writes positions and unit normals in the contract order of DESIGN.md (one (L+1)² grid
//! per patch, u along the face's first edge, rows of u inner), plus the grid triangles.
use super::profile::ProfileArgs;
use crate::engine::gregory::{GregorySurface, GregoryTopology};
use crate::gpu::present::begin_color_target;
use crate::gpu::resources::image_barrier;
use crate::gpu::{Buffer, Context, ContextDesc, ImageDesc, MemoryLocation, Profiler};
use crate::passes::beziex_eval::BeziexEvalPass;
use crate::passes::cage_deform::{DeformParams, Deformation};
use crate::passes::gregory_eval::{grid_indices, vertex_count, SurfaceVertex, MAX_LEVEL};
use crate::passes::patch_pull::{PatchKind, PatchPullPass};
use crate::passes::surface_draw::{DrawTarget, SurfacePush};
use crate::surface::beziex::{load_beziex, BeziexPatch};
use crate::voxel::export::write_atomically;
use anyhow::{bail, Context as _};
use ash::vk;
use clap::{Args, ValueEnum};
use glam::DVec3;
use std::path::{Path, PathBuf};

/// The evaluation path.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EvalPath {
    /// Compute shader into a device-local vertex buffer.
    Compute,
    /// Instanced grid whose vertex shader evaluates the patches (the Beziex seed's method).
    Vertex,
}

/// Arguments of `gregvox tessellate`.
#[derive(Debug, Args)]
pub struct TessellateArgs {
    /// A quad cage (.obj, ACC-2 Gregory patches) or a Beziex model (.gzjson).
    pub input: PathBuf,
    /// Tessellation level L (1–64): (L+1)² vertices per patch.
    #[arg(long, default_value_t = 8)]
    pub level: u32,
    /// Output OBJ (v, vn and f lines).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Evaluation path.
    #[arg(long, value_enum, default_value = "compute")]
    pub path: EvalPath,
    /// One frame of cage animation before evaluation: twist, bend or wave, optionally `:AMOUNT` (default 1).
    #[arg(long)]
    pub deform: Option<String>,
    /// Re-run the GPU passes K times (for timing).
    #[arg(long, default_value_t = 1)]
    pub repeat: u32,
    /// Print vertex count, the largest normal jump across shared patch edges and the throughput.
    #[arg(long)]
    pub stats: bool,
    #[command(flatten)]
    pub profile: ProfileArgs,
}

/// Parses `twist|bend|wave[:AMOUNT]`.
pub fn parse_deform(s: &str) -> anyhow::Result<(Deformation, f32)> {
    let (name, amount) = match s.split_once(':') {
        Some((n, a)) => (
            n,
            a.parse::<f32>()
                .ok()
                .filter(|a| a.is_finite())
                .with_context(|| format!("--deform amount '{a}' is not a number"))?,
        ),
        None => (s, 1.0),
    };
    let mode = match name {
        "twist" => Deformation::Twist,
        "bend" => Deformation::Bend,
        "wave" => Deformation::Wave,
        other => bail!("--deform '{other}' is not one of twist, bend, wave"),
    };
    Ok((mode, amount))
}

/// Writes the tessellation as OBJ: `v`, `vn` per vertex and the grid triangles (1-based, `a//a`).
pub fn write_tessellation_obj(
    path: &Path,
    vertices: &[SurfaceVertex],
    patches: u32,
    level: u32,
) -> anyhow::Result<()> {
    write_atomically(path, |w| {
        writeln!(w, "# gregvox tessellate: {patches} patches at level {level}, (level+1)^2 vertices per patch")?;
        for v in vertices {
            writeln!(w, "v {} {} {}", v.position[0], v.position[1], v.position[2])?;
        }
        for v in vertices {
            writeln!(w, "vn {} {} {}", v.normal[0], v.normal[1], v.normal[2])?;
        }
        for t in grid_indices(patches, level).chunks(3) {
            let (a, b, c) = (t[0] + 1, t[1] + 1, t[2] + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Runs `gregvox tessellate`.
pub fn run(args: &TessellateArgs) -> anyhow::Result<()> {
    if !(1..=MAX_LEVEL).contains(&args.level) {
        bail!(
            "--level {} is out of range: the tessellation level must be between 1 and {MAX_LEVEL}",
            args.level
        );
    }
    if args.repeat == 0 {
        bail!("--repeat must be at least 1");
    }
    let deform = args.deform.as_deref().map(parse_deform).transpose()?;
    let ext = args
        .input
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    let source = if ext == "gzjson" || ext == "json" {
        if deform.is_some() {
            bail!(
                "--deform animates a cage; {} is a Beziex model",
                args.input.display()
            );
        }
        Source::Beziex(load_beziex(&args.input)?)
    } else {
        let (topo, cage, note) = super::cage::load_cage_topology(&args.input)?;
        if let Some(n) = note {
            eprintln!("gregvox tessellate: {n}");
        }
        Source::Cage(topo, cage)
    };
    let ctx = Context::with_desc(&ContextDesc::default())?;
    let mut profiler = Profiler::new(&ctx, 1, 4 * args.repeat.min(1000) + 8)?;
    let result = evaluate(&ctx, &source, args, deform, &mut profiler);
    let out = result.and_then(|(vertices, patches)| {
        args.profile.emit(&profiler)?;
        if let Some(path) = &args.out {
            write_tessellation_obj(path, &vertices, patches, args.level)?;
        }
        if args.stats {
            let jump = match &source {
                Source::Beziex(p) => max_jump_beziex(p, &vertices, args.level),
                Source::Cage(topo, _) => super::cage::max_jump_shared_edges(topo, &vertices, args.level),
            };
            let eval_ms: f64 = profiler
                .stats()
                .iter()
                .filter(|s| s.name == "gregory_eval" || s.name == "beziex_eval" || s.name == "vertex_pull")
                .map(|s| s.median_ms)
                .sum();
            let rate = if eval_ms > 0.0 { vertices.len() as f64 / (eval_ms * 1e-3) } else { 0.0 };
            super::print_out(&format!(
                "vertices: {}\npatches: {patches}\nmax normal jump across shared edges: {jump:.3e} rad\n\
                 evaluation: {eval_ms:.3} ms median ({:.1} M vertices/s)\n",
                vertices.len(),
                rate / 1e6
            ))?;
        }
        Ok(())
    });
    profiler.destroy(&ctx);
    out
}

enum Source {
    Beziex(Vec<BeziexPatch>),
    Cage(GregoryTopology, Vec<DVec3>),
}

fn evaluate(
    ctx: &Context,
    source: &Source,
    args: &TessellateArgs,
    deform: Option<(Deformation, f32)>,
    profiler: &mut Profiler,
) -> anyhow::Result<(Vec<SurfaceVertex>, u32)> {
    let level = args.level;
    match (source, args.path) {
        (Source::Cage(topo, cage), EvalPath::Compute) => {
            let surface = GregorySurface::new(ctx, topo, cage, level)?;
            let params = deform.map(|(mode, amplitude)| DeformParams {
                mode,
                t: 1.0,
                amplitude,
                box_min: surface.box_min,
                box_size: surface.box_size,
            });
            let r = (|| -> anyhow::Result<Vec<SurfaceVertex>> {
                for _ in 0..args.repeat {
                    ctx.one_shot(|cmd| {
                        surface.record(ctx, cmd, params.as_ref(), Some((&mut *profiler, 0)))
                    })?;
                    profiler.collect(ctx, 0)?;
                }
                Ok(surface.read_vertices(ctx)?)
            })();
            let n = surface.patch_count;
            surface.destroy(ctx);
            Ok((r?, n))
        }
        (Source::Cage(topo, cage), EvalPath::Vertex) => {
            let surface = GregorySurface::new(ctx, topo, cage, level)?;
            let params = deform.map(|(mode, amplitude)| DeformParams {
                mode,
                t: 1.0,
                amplitude,
                box_min: surface.box_min,
                box_size: surface.box_size,
            });
            let ids: Vec<u32> = topo.patch_points.iter().flatten().copied().collect();
            let pp = ctx.upload_buffer(
                "patch points",
                bytemuck::cast_slice(&ids),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            );
            let r = pp.map_err(anyhow::Error::from).and_then(|pp| {
                // Points from the same deform + W·cage chain; the evaluation itself happens in the vertex shader.
                let r = (|| -> anyhow::Result<Vec<SurfaceVertex>> {
                    ctx.one_shot(|cmd| surface.record(ctx, cmd, params.as_ref(), None))?;
                    vertex_pull(
                        ctx,
                        PatchKind::Gregory,
                        surface.points(),
                        &pp,
                        surface.patch_count,
                        level,
                        args.repeat,
                        profiler,
                    )
                })();
                pp.destroy(ctx);
                r
            });
            let n = surface.patch_count;
            surface.destroy(ctx);
            Ok((r?, n))
        }
        (Source::Beziex(patches), path) => {
            let nets: Vec<[f32; 4]> = patches.iter().flat_map(|p| p.to_gpu()).collect();
            let n = patches.len() as u32;
            let nb = ctx.upload_buffer(
                "beziex nets",
                bytemuck::cast_slice(&nets),
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?;
            let r = (|| -> anyhow::Result<Vec<SurfaceVertex>> {
                if path == EvalPath::Vertex {
                    let dummy = ctx.upload_buffer(
                        "no patch points",
                        &[0u8; 4],
                        vk::BufferUsageFlags::STORAGE_BUFFER,
                    )?;
                    let r = vertex_pull(
                        ctx,
                        PatchKind::Beziex,
                        &nb,
                        &dummy,
                        n,
                        level,
                        args.repeat,
                        profiler,
                    );
                    dummy.destroy(ctx);
                    return r;
                }
                let pass = BeziexEvalPass::new(ctx)?;
                let out = ctx.create_buffer(
                    "beziex vertices",
                    vertex_count(n, level) * 32,
                    vk::BufferUsageFlags::STORAGE_BUFFER
                        | vk::BufferUsageFlags::VERTEX_BUFFER
                        | vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::GpuOnly,
                );
                let r = out.map_err(anyhow::Error::from).and_then(|out| {
                    let r = (|| -> anyhow::Result<Vec<SurfaceVertex>> {
                        for _ in 0..args.repeat {
                            ctx.one_shot(|cmd| {
                                profiler.scope(ctx, cmd, 0, "beziex_eval", || {
                                    pass.record(ctx, cmd, &nb, n, level, &out)
                                })
                            })?;
                            profiler.collect(ctx, 0)?;
                        }
                        Ok(ctx.read_pod(&out)?)
                    })();
                    out.destroy(ctx);
                    r
                });
                pass.destroy(ctx);
                r
            })();
            nb.destroy(ctx);
            Ok((r?, n))
        }
    }
}

/// Draws the patches through the capturing vertex-pull pipeline into a small offscreen target and returns
/// the evaluated vertices (in the compute path's order).
#[allow(clippy::too_many_arguments)]
pub fn vertex_pull(
    ctx: &Context,
    kind: PatchKind,
    points: &Buffer,
    patch_points: &Buffer,
    patches: u32,
    level: u32,
    repeat: u32,
    profiler: &mut Profiler,
) -> anyhow::Result<Vec<SurfaceVertex>> {
    let (w, h) = (256, 256);
    let mut owned: Vec<Buffer> = Vec::new();
    let mut images = Vec::new();
    let pass = PatchPullPass::new(
        ctx,
        vk::Format::B8G8R8A8_UNORM,
        vk::Format::D32_SFLOAT,
        true,
    )?;
    let r = (|| -> anyhow::Result<Vec<SurfaceVertex>> {
        images.push(ctx.create_image(
            "pull color",
            &ImageDesc::d2(
                w,
                h,
                vk::Format::B8G8R8A8_UNORM,
                vk::ImageUsageFlags::COLOR_ATTACHMENT,
            ),
        )?);
        images.push(ctx.create_image(
            "pull depth",
            &ImageDesc::d2(
                w,
                h,
                vk::Format::D32_SFLOAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            ),
        )?);
        owned.push(ctx.upload_buffer(
            "pull grid",
            bytemuck::cast_slice(&grid_indices(1, level)),
            vk::BufferUsageFlags::INDEX_BUFFER,
        )?);
        owned.push(ctx.create_buffer(
            "pull capture",
            vertex_count(patches, level) * 32,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
        )?);
        let push = SurfacePush {
            view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            eye: [0.0, 0.0, 10.0, 1.0],
            light: [0.0, 0.0, 1.0, 0.3],
            color: [1.0; 4],
            mode: [0; 4],
        };
        let target = DrawTarget {
            color: images[0].view,
            depth: images[1].view,
            extent: vk::Extent2D {
                width: w,
                height: h,
            },
        };
        for _ in 0..repeat {
            ctx.one_shot(|cmd| {
                begin_color_target(ctx, cmd, images[0].raw);
                image_barrier(
                    ctx,
                    cmd,
                    images[1].raw,
                    images[1].range(),
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                    (
                        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                            | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS,
                        vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                    ),
                );
                profiler.scope(ctx, cmd, 0, "vertex_pull", || {
                    pass.record(
                        ctx,
                        cmd,
                        &target,
                        Some([0.0; 4]),
                        kind,
                        points,
                        patch_points,
                        patches,
                        level,
                        &owned[0],
                        Some(&owned[1]),
                        &push,
                    )
                })
            })?;
            profiler.collect(ctx, 0)?;
        }
        Ok(ctx.read_pod(&owned[1])?)
    })();
    for b in owned {
        b.destroy(ctx);
    }
    for i in images {
        i.destroy(ctx);
    }
    pass.destroy(ctx);
    r
}

/// Largest normal jump (rad, up to orientation) between coincident edge vertices of different Beziex
/// patches in an evaluated grid.
fn max_jump_beziex(_patches: &[BeziexPatch], vertices: &[SurfaceVertex], level: u32) -> f64 {
    super::cage::max_jump_coincident(vertices, level)
}

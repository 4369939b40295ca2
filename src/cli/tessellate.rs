//! `gregvox tessellate IN.obj|IN.gzjson --level N --out OUT.obj`: evaluates every patch on the GPU (compute or
//! vertex-pull path) and writes positions and unit normals in the contract order of docs/ARCHITECTURE.md
//! (one (L+1)² grid per patch, u along the face's first edge, rows of u inner), plus the grid triangles.
use super::profile::ProfileArgs;
use crate::engine::gregory::{GregorySurface, GregoryTopology};
use crate::engine::vertex_pull::vertex_pull;
use crate::gpu::{Context, ContextDesc, MemoryLocation, Profiler};
use crate::io::write_atomic;
use crate::passes::adaptive_levels::{compact_grid_indices, AdaptiveParams};
use crate::passes::beziex_eval::BeziexEvalPass;
use crate::passes::cage_deform::{DeformParams, Deformation};
use crate::passes::gregory_eval::{
    grid_indices, vertex_count, ControlPoints, SurfaceVertex, MAX_LEVEL,
};
use crate::passes::patch_pull::PatchKind;
use crate::surface::beziex::{load_beziex, BeziexPatch};
use crate::surface::Tangents;
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

/// Edge-point masks at extraordinary vertices (gregory.md §3.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TangentMode {
    /// OpenSubdiv's masks (its GREGORY_BASIS points).
    Opensubdiv,
    /// The exact Catmull–Clark limit-tangent masks (EV normals on the limit tangent plane).
    Exact,
}

impl From<TangentMode> for Tangents {
    fn from(t: TangentMode) -> Tangents {
        match t {
            TangentMode::Opensubdiv => Tangents::OpenSubdiv,
            TangentMode::Exact => Tangents::Exact,
        }
    }
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
    /// Edge-point masks of a cage's ACC-2 patches at extraordinary vertices.
    #[arg(long, value_enum, default_value = "opensubdiv")]
    pub tangents: TangentMode,
    /// Screen-space adaptive levels: target PIXELS per tessellation segment on screen, each patch's level
    /// between 1 and --level (compute path, cages only). The OBJ then holds every patch's own (L_p+1)² grid
    /// in patch order (rows of u inner), its levels listed in a `# levels` comment.
    #[arg(long, value_name = "PIXELS")]
    pub adaptive: Option<f32>,
    /// With --adaptive: the eye position `X,Y,Z`, looking at the cage's bounding-box centre (up +Y, 45°
    /// vertical field of view). Default: on +Z, 1.5 bounding-box diagonals from the centre.
    #[arg(long, value_name = "X,Y,Z")]
    pub eye: Option<String>,
    /// With --adaptive: the viewport `WxH` in pixels.
    #[arg(long, value_name = "WxH", default_value = "1280x720")]
    pub viewport: String,
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
    write_atomic(path, |w| {
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
    let adaptive = parse_adaptive(args)?;
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
        if args.tangents != TangentMode::Opensubdiv {
            bail!(
                "--tangents chooses a cage's edge-point masks; {} is a Beziex model",
                args.input.display()
            );
        }
        if adaptive.is_some() {
            bail!(
                "--adaptive tessellates ACC-2 cages; {} is a Beziex model",
                args.input.display()
            );
        }
        Source::Beziex(load_beziex(&args.input)?)
    } else {
        let mesh = crate::mesh::load_obj(&args.input)?;
        let (topo, cage, note) = crate::engine::cage::cage_topology(&mesh, args.tangents.into())
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.input.display()))?;
        if let Some(n) = note {
            eprintln!("gregvox tessellate: {n}");
        }
        Source::Cage(topo, cage)
    };
    let ctx = Context::with_desc(&ContextDesc::default())?;
    let mut profiler = Profiler::new(&ctx, 1, 4 * args.repeat.min(1000) + 8)?;
    let result = evaluate(
        &ctx,
        &source,
        args,
        deform,
        adaptive.as_ref(),
        &mut profiler,
    );
    let out = result.and_then(|(vertices, patches, levels)| {
        args.profile.emit(&profiler)?;
        if let Some(path) = &args.out {
            match &levels {
                Some(l) => write_adaptive_obj(path, &vertices, l)?,
                None => write_tessellation_obj(path, &vertices, patches, args.level)?,
            }
        }
        if args.stats {
            let jump = match (&source, &levels) {
                (Source::Beziex(p), _) => max_jump_beziex(p, &vertices, args.level),
                // Adaptive grids differ per patch; the uniform-grid edge matcher does not apply.
                (Source::Cage(..), Some(_)) => f64::NAN,
                (Source::Cage(topo, _), None) => {
                    crate::engine::cage::max_jump_shared_edges(topo, &vertices, args.level)
                }
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
    out
}

enum Source {
    Beziex(Vec<BeziexPatch>),
    Cage(GregoryTopology, Vec<DVec3>),
}

/// The adaptive view of `--adaptive/--eye/--viewport` before the cage is known: (pixels, eye, viewport).
type AdaptiveArgs = (f32, Option<[f32; 3]>, [f32; 2]);

fn parse_adaptive(args: &TessellateArgs) -> anyhow::Result<Option<AdaptiveArgs>> {
    let Some(px) = args.adaptive else {
        if args.eye.is_some() {
            bail!("--eye sets the view of --adaptive, which is not given");
        }
        return Ok(None);
    };
    if !(px > 0.0 && px.is_finite()) {
        bail!("--adaptive {px}: the pixels per segment must be a positive number");
    }
    if args.path != EvalPath::Compute {
        bail!("--adaptive runs on the compute path only");
    }
    let eye = match &args.eye {
        None => None,
        Some(e) => {
            let c: Vec<f32> = e
                .split(',')
                .map(|x| x.trim().parse::<f32>())
                .collect::<Result<_, _>>()
                .ok()
                .filter(|c: &Vec<f32>| c.len() == 3 && c.iter().all(|x| x.is_finite()))
                .ok_or_else(|| anyhow::anyhow!("--eye '{e}' is not three numbers X,Y,Z"))?;
            Some([c[0], c[1], c[2]])
        }
    };
    let vp = args
        .viewport
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some([w.trim().parse::<u32>().ok()?, h.trim().parse::<u32>().ok()?]))
        .filter(|v| v[0] > 0 && v[1] > 0)
        .ok_or_else(|| {
            anyhow::anyhow!(
                "--viewport '{}' is not WIDTHxHEIGHT in pixels",
                args.viewport
            )
        })?;
    Ok(Some((px, eye, [vp[0] as f32, vp[1] as f32])))
}

/// The adaptive parameters for a cage with bounding box `box_min + [0, box_size]`.
fn adaptive_params(a: &AdaptiveArgs, box_min: [f32; 3], box_size: [f32; 3]) -> AdaptiveParams {
    let size = glam::Vec3::from(box_size);
    let centre = glam::Vec3::from(box_min) + 0.5 * size;
    let d = size.length().max(f32::MIN_POSITIVE);
    let eye =
        a.1.map_or(centre + glam::Vec3::Z * 1.5 * d, glam::Vec3::from);
    let forward = (centre - eye).normalize_or_zero();
    let up = if forward.cross(glam::Vec3::Y).length() < 1e-3 {
        glam::Vec3::Z
    } else {
        glam::Vec3::Y
    };
    let dist = (centre - eye).length();
    let proj = glam::Mat4::perspective_rh(
        45f32.to_radians(),
        a.2[0] / a.2[1],
        (1e-3 * d).max(1e-6 * dist),
        dist + 10.0 * d,
    );
    AdaptiveParams {
        view_proj: proj * glam::Mat4::look_at_rh(eye, centre, up),
        viewport: a.2,
        pixels_per_segment: a.0,
    }
}

/// Writes an adaptive tessellation (every patch's own grid, patch order) as OBJ.
fn write_adaptive_obj(
    path: &Path,
    vertices: &[SurfaceVertex],
    levels: &[u32],
) -> anyhow::Result<()> {
    write_atomic(path, |w| {
        writeln!(
            w,
            "# gregvox tessellate --adaptive: {} patches, patch p has (L_p+1)^2 vertices",
            levels.len()
        )?;
        let list: Vec<String> = levels.iter().map(|l| l.to_string()).collect();
        writeln!(w, "# levels {}", list.join(" "))?;
        for v in vertices {
            writeln!(w, "v {} {} {}", v.position[0], v.position[1], v.position[2])?;
        }
        for v in vertices {
            writeln!(w, "vn {} {} {}", v.normal[0], v.normal[1], v.normal[2])?;
        }
        for t in compact_grid_indices(levels).chunks(3) {
            let (a, b, c) = (t[0] + 1, t[1] + 1, t[2] + 1);
            writeln!(w, "f {a}//{a} {b}//{b} {c}//{c}")?;
        }
        Ok(())
    })?;
    Ok(())
}

type Evaluated = (Vec<SurfaceVertex>, u32, Option<Vec<u32>>);

fn evaluate(
    ctx: &Context,
    source: &Source,
    args: &TessellateArgs,
    deform: Option<(Deformation, f32)>,
    adaptive: Option<&AdaptiveArgs>,
    profiler: &mut Profiler,
) -> anyhow::Result<Evaluated> {
    let level = args.level;
    match (source, args.path) {
        (Source::Cage(topo, cage), EvalPath::Compute) => {
            let mut surface = GregorySurface::new(ctx, topo, cage, level)?;
            if let Some(a) = adaptive {
                let p = adaptive_params(a, surface.box_min(), surface.box_size());
                if let Err(e) = surface.set_adaptive(ctx, Some(p)) {
                    return Err(e.into());
                }
            }
            let params = deform.map(|(mode, amplitude)| DeformParams {
                mode,
                t: 1.0,
                amplitude,
                box_min: surface.box_min(),
                box_size: surface.box_size(),
            });
            let r = (|| -> anyhow::Result<(Vec<SurfaceVertex>, Option<Vec<u32>>)> {
                for _ in 0..args.repeat {
                    ctx.one_shot(|cmd| {
                        surface.record(ctx, cmd, params.as_ref(), Some((&mut *profiler, 0)))
                    })?;
                    profiler.collect(ctx, 0)?;
                }
                if adaptive.is_some() {
                    let (v, l) = surface.read_adaptive_grids(ctx)?;
                    return Ok((v, Some(l)));
                }
                Ok((surface.read_vertices(ctx)?, None))
            })();
            let n = surface.patch_count();
            let (v, l) = r?;
            Ok((v, n, l))
        }
        (Source::Cage(topo, cage), EvalPath::Vertex) => {
            let surface = GregorySurface::new(ctx, topo, cage, level)?;
            let params = deform.map(|(mode, amplitude)| DeformParams {
                mode,
                t: 1.0,
                amplitude,
                box_min: surface.box_min(),
                box_size: surface.box_size(),
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
                        surface.control_points(),
                        &pp,
                        surface.patch_count(),
                        level,
                        args.repeat,
                        profiler,
                    )
                    .map_err(anyhow::Error::from)
                })();
                r
            });
            let n = surface.patch_count();
            Ok((r?, n, None))
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
                        ControlPoints::plain(&nb),
                        &dummy,
                        n,
                        level,
                        args.repeat,
                        profiler,
                    );
                    return Ok(r?);
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
                    r
                });
                r
            })();
            Ok((r?, n, None))
        }
    }
}

/// Largest normal jump (rad, up to orientation) between coincident edge vertices of different Beziex
/// patches in an evaluated grid.
fn max_jump_beziex(_patches: &[BeziexPatch], vertices: &[SurfaceVertex], level: u32) -> f64 {
    crate::engine::cage::max_jump_coincident(vertices, level)
}

//! The `beziex` scene: a Beziex `.gzjson` model (`--model FILE.gzjson`) drawn by the vertex-pull path
//! (passes/patch_pull.rs: one instance per patch, the vertex shader evaluates the patch from its 56-point net),
//! turning slowly about the vertical axis while animation is on.
//!
//! With no `--model` the scene shows `04_Cup1.gzjson` from beziex/Beziex_We, embedded in the binary: it is a
//! beziex original shape released under CC0 1.0 (see assets/models/beziex/SOURCES.md), so it may be
//! redistributed without conditions.
//!
//! Invariants: the nets, the placeholder patch-index buffer and the grid index buffer are uploaded once and
//! only read afterwards, so one copy serves every frame in flight; the tessellation level is fixed.
use super::scene::{surface_push, FrameTargets, Orbit, Scene, ViewState, DEPTH_FORMAT};
use super::DemoArgs;
use crate::gpu::{Buffer, Context, Profiler};
use crate::passes::draw::ColorTarget;
use crate::passes::gregory_eval::grid_indices;
use crate::passes::patch_pull::{PatchKind, PatchPullPass};
use crate::surface::beziex::{load_beziex, parse_beziex, BeziexPatch};
use anyhow::Context as _;
use ash::vk;
use glam::Vec3;
use std::io::Read;
use std::path::Path;

/// The built-in model (CC0 1.0, beziex original shape).
const BUILTIN: &[u8] = include_bytes!("assets/04_Cup1.gzjson");
const BUILTIN_NAME: &str = "04_Cup1.gzjson (built in)";
/// Turntable speed (radians per second of scene time).
const SPIN: f32 = 0.4;

/// The built-in model's patches.
pub fn builtin_patches() -> crate::Result<Vec<BeziexPatch>> {
    let mut text = String::new();
    flate2::read::GzDecoder::new(BUILTIN)
        .read_to_string(&mut text)
        .map_err(|e| crate::Error::parse(BUILTIN_NAME, format!("not gzip-compressed JSON: {e}")))?;
    parse_beziex(&text, Path::new(BUILTIN_NAME))
}

/// The Beziex scene.
pub struct BeziexScene {
    pass: PatchPullPass,
    nets: Buffer,
    patch_points: Buffer,
    grid: Buffer,
    pub patch_count: u32,
    pub level: u32,
    box_min: Vec3,
    box_max: Vec3,
    name: String,
}

impl BeziexScene {
    /// Uploads `patches` and builds the vertex-pull pipeline for `format` targets at tessellation `level`.
    pub fn new(
        ctx: &Context,
        format: impl Into<ColorTarget>,
        patches: &[BeziexPatch],
        level: u32,
        name: String,
    ) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        if patches.is_empty() {
            anyhow::bail!("{name}: the model has no patches");
        }
        if !(1..=64).contains(&level) {
            anyhow::bail!("tessellation level {level} is outside 1…64");
        }
        let nets: Vec<[f32; 4]> = patches.iter().flat_map(|p| p.to_gpu()).collect();
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in &nets {
            let v = Vec3::new(p[0], p[1], p[2]);
            lo = lo.min(v);
            hi = hi.max(v);
        }
        let indices = grid_indices(1, level);
        let storage = vk::BufferUsageFlags::STORAGE_BUFFER;
        let nets = ctx.upload_buffer("beziex nets", bytemuck::cast_slice(&nets), storage)?;
        // Beziex patches read their net by instance index; the shader still needs a valid binding 1.
        let patch_points = ctx.upload_buffer(
            "beziex patch points (unused)",
            bytemuck::cast_slice(&[0u32; 4]),
            storage,
        )?;
        let grid = ctx.upload_buffer(
            "beziex grid indices",
            bytemuck::cast_slice(&indices),
            vk::BufferUsageFlags::INDEX_BUFFER,
        )?;
        let pass = PatchPullPass::new(ctx, format, DEPTH_FORMAT, false)?;
        Ok(BeziexScene {
            pass,
            nets,
            patch_points,
            grid,
            patch_count: patches.len() as u32,
            level,
            box_min: lo,
            box_max: hi,
            name,
        })
    }
}

impl Scene for BeziexScene {
    fn name(&self) -> String {
        format!(
            "beziex: {} ({} patches, level {}, vertex pull)",
            self.name, self.patch_count, self.level
        )
    }

    fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &FrameTargets,
        t: f32,
        view: &ViewState,
        profiler: &mut Profiler,
    ) -> anyhow::Result<()> {
        let mut v = *view;
        if view.animate {
            v.orbit.yaw += SPIN * t;
        }
        let push = surface_push(&v, targets, [0.8, 0.6, 0.3], self.level);
        let target = targets.draw_target();
        profiler.scope(ctx, cmd, targets.slot, "beziex vertex pull", || {
            self.pass.record(
                ctx,
                cmd,
                &target,
                Some([0.92, 0.93, 0.95, 1.0]),
                PatchKind::Beziex,
                crate::passes::gregory_eval::ControlPoints::plain(&self.nets),
                &self.patch_points,
                self.patch_count,
                self.level,
                &self.grid,
                None,
                &push,
            )
        })?;
        Ok(())
    }

    fn framing(&self) -> Orbit {
        let size = self.box_max - self.box_min;
        Orbit::framing(0.5 * (self.box_min + self.box_max), size.max_element())
    }
}

/// Builds the scene from `--model FILE.gzjson` or the built-in cup.
pub fn build(
    ctx: &Context,
    args: &DemoArgs,
    format: impl Into<ColorTarget>,
) -> anyhow::Result<Box<dyn Scene>> {
    let format: ColorTarget = format.into();
    let (patches, name) = match &args.model {
        Some(path) => (
            load_beziex(path).with_context(|| format!("--model {}", path.display()))?,
            path.file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default(),
        ),
        None => (builtin_patches()?, BUILTIN_NAME.to_string()),
    };
    Ok(Box::new(BeziexScene::new(
        ctx,
        format,
        &patches,
        args.level.unwrap_or(10),
        name,
    )?))
}

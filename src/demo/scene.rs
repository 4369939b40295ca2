//! Demo scenes. A scene owns its GPU chain (compute passes, buffers, draw pass) and records one frame into
//! the renderer's targets; the renderer owns frames, profiler, depth images and the present target.
//!
//! Invariants: on entry to `Scene::record` the color target is in `COLOR_ATTACHMENT_OPTIMAL` (contents
//! undefined) and the depth target in `DEPTH_ATTACHMENT_OPTIMAL`; the scene clears and draws both and leaves
//! the layouts unchanged. With multisampling (`--msaa`, 4 by default) both targets have the sample count
//! the scene's pipelines were built for (`ColorTarget`), and every rendering into the colour target resolves
//! into `FrameTargets::resolve`, the frame's own image (`FrameTargets::draw_target` carries it to the passes),
//! so whatever pass records last leaves the whole frame resolved. A scene's `set_level` runs with the device idle (the renderer waits). A scene's
//! GPU objects release themselves when dropped, through the release queue of `gpu::lifetime`, so a buffer
//! earlier frames used may be replaced or dropped at any point. Every GPU pass a scene records is in a
//! profiler scope.
//! Surface scenes draw through [`SurfaceLook`]: shadow map → (curvature) → ground + surface (lit path), or the
//! vertex-pull path for the surface when `ViewState::path` asks for it and the scene has control points.
use crate::engine::cage::UvTopology;
use crate::engine::flag::FlagSurface;
use crate::engine::gregory::GregorySurface;
use crate::gpu::{Buffer, Context, MemoryLocation, Profiler};
use crate::passes::adaptive_levels::AdaptiveParams;
use crate::passes::cage_deform::{DeformParams, Deformation};
use crate::passes::draw::ColorTarget;
use crate::passes::gregory_eval::{grid_indices, vertex_count, ControlPoints};
use crate::passes::patch_pull::{PatchKind, PatchPullPass};
use crate::passes::shadow_map::{light_view_proj, ShadowMap};
use crate::passes::spinner::SpinnerPass;
use crate::passes::surface_curvature::{SurfaceCurvaturePass, CURVATURE_STRIDE};
use crate::passes::surface_draw::{
    DrawTarget, IndirectDraw, LitDraw, ShadingMode, SurfaceDrawPass, SurfacePush, FLAG_GROUND,
    FLAG_SHADOWS, FLAG_UVS,
};
use crate::passes::triangles::TrianglesPass;
use ash::vk;
use glam::{Mat4, Vec3};

/// The depth format of every scene.
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// Line segments drawn in a scene's frame with the scene's camera: the pass and the per-slot buffers the
/// segments are written to.
pub struct SceneLines {
    pass: crate::passes::lines::LinesPass,
    ring: crate::passes::lines::LineRing,
}

impl SceneLines {
    /// Builds the line pipeline for `format` targets.
    pub fn new(ctx: &Context, format: impl Into<ColorTarget>) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        Ok(SceneLines {
            pass: crate::passes::lines::LinesPass::new(ctx, format, DEPTH_FORMAT)?,
            ring: crate::passes::lines::LineRing::new(super::FRAMES_IN_FLIGHT),
        })
    }

    /// Draws `vertices` (pairs) through `view`'s camera into `targets`, clearing first when `clear` is
    /// given, in the profiler scope `scope`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &FrameTargets,
        view: &ViewState,
        profiler: &mut Profiler,
        scope: &str,
        clear: Option<[f32; 4]>,
        vertices: &[crate::passes::lines::LineVertex],
    ) -> anyhow::Result<()> {
        let buf = self.ring.upload(ctx, targets.slot, vertices)?;
        let aspect = targets.extent.width as f32 / targets.extent.height.max(1) as f32;
        let target = targets.draw_target();
        let pass = &self.pass;
        profiler.scope(ctx, cmd, targets.slot, scope, || {
            pass.record(
                ctx,
                cmd,
                &target,
                clear,
                buf,
                vertices.len() as u32,
                &view.orbit.view_proj(aspect),
            )
        })?;
        Ok(())
    }
}

/// One frame's render targets.
#[derive(Clone, Copy)]
pub struct FrameTargets {
    pub slot: usize,
    pub color: vk::ImageView,
    pub depth: vk::ImageView,
    pub extent: vk::Extent2D,
    /// With multisampling: the frame's own image, which every rendering into `color` resolves to.
    pub resolve: Option<vk::ImageView>,
}

impl FrameTargets {
    /// The targets as a pass draws into them.
    pub fn draw_target(&self) -> DrawTarget {
        DrawTarget {
            color: self.color,
            depth: self.depth,
            extent: self.extent,
            resolve: self.resolve,
        }
    }
}

/// An orbit camera around `target`.
#[derive(Clone, Copy, Debug)]
pub struct Orbit {
    pub target: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub distance: f32,
}

impl Orbit {
    /// A camera framing a box of `size` centred at `centre`.
    pub fn framing(centre: Vec3, size: f32) -> Self {
        Orbit {
            target: centre,
            yaw: -0.6,
            pitch: 0.45,
            distance: 1.9 * size.max(1e-3),
        }
    }

    /// The camera after a mouse drag of (dx, dy) pixels: 0.01 rad per pixel, pitch kept inside ±1.5 rad so
    /// the camera never flips over the pole.
    ///
    /// ```
    /// use gregvox::demo::scene::Orbit;
    /// let o = Orbit::framing(glam::Vec3::ZERO, 1.0).dragged(100.0, 1e4);
    /// assert!((o.yaw - (-1.6)).abs() < 1e-6 && o.pitch == 1.5);
    /// ```
    pub fn dragged(mut self, dx: f32, dy: f32) -> Self {
        self.yaw -= 0.01 * dx;
        self.pitch = (self.pitch + 0.01 * dy).clamp(-1.5, 1.5);
        self
    }

    /// The camera after `lines` wheel steps (positive: closer), 10 % per step, distance kept positive.
    ///
    /// ```
    /// use gregvox::demo::scene::Orbit;
    /// let o = Orbit::framing(glam::Vec3::ZERO, 1.0);
    /// assert!((o.zoomed(1.0).distance - 0.9 * o.distance).abs() < 1e-6);
    /// ```
    pub fn zoomed(mut self, lines: f32) -> Self {
        self.distance = (self.distance * 0.9f32.powf(lines)).clamp(1e-3, 1e6);
        self
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(cp * cy, cp * sy, sp)
    }

    /// Vulkan clip-from-world (depth 0…1, y down), z up in the world.
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let view = Mat4::look_at_rh(self.eye(), self.target, Vec3::Z);
        let mut proj = Mat4::perspective_rh(
            0.8,
            aspect.max(1e-3),
            self.distance * 0.02,
            self.distance * 10.0,
        );
        proj.y_axis.y = -proj.y_axis.y;
        proj * view
    }
}

/// How a surface is turned into triangles for drawing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DrawPath {
    /// The compute evaluation pass writes a vertex buffer that the raster pipeline draws (default).
    Compute,
    /// The vertex shader evaluates the patches from the control points (`PatchPullPass`).
    VertexPull,
}

/// Viewer state shared by scenes (camera, shading mode, toggles).
#[derive(Clone, Copy, Debug)]
pub struct ViewState {
    pub orbit: Orbit,
    pub shading: ShadingMode,
    pub animate: bool,
    pub path: DrawPath,
}

/// A demo scene.
pub trait Scene {
    /// Name for titles and logs.
    fn name(&self) -> String;
    /// Records this frame's compute work and draw.
    fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &FrameTargets,
        t: f32,
        view: &ViewState,
        profiler: &mut Profiler,
    ) -> anyhow::Result<()>;
    /// A key the scene understands (returns whether it used it).
    fn key(&mut self, _ctx: &Context, _key: &str) -> anyhow::Result<bool> {
        Ok(false)
    }
    /// The camera that frames the scene.
    fn framing(&self) -> Orbit;
    /// The tessellation level, for scenes that have one.
    fn level(&self) -> Option<u32> {
        None
    }
    /// Switches the tessellation level (called with the device idle); returns whether the scene has one.
    fn set_level(&mut self, _ctx: &Context, _level: u32) -> anyhow::Result<bool> {
        Ok(false)
    }
    /// The points the mouse can drag now (world positions, in a fixed order: cage vertices, control
    /// points); empty when the scene has none or does not show them in `view` (a cage while it animates).
    fn handles(&self, _view: &ViewState) -> Vec<Vec3> {
        Vec::new()
    }
    /// Moves the handles to `positions` (as many as [`Scene::handles`] gave, same order) and marks
    /// `held` as the one under the cursor; the shape follows from the next recorded frame.
    fn set_handles(&mut self, _positions: &[Vec3], _held: Option<usize>) -> anyhow::Result<()> {
        Ok(())
    }
    /// The wheel turned `steps` notches while handle `index` is held (a NURBS weight); returns what
    /// changed, or `None` when the handle has nothing the wheel sets (the wheel then zooms).
    fn wheel_held(&mut self, _index: usize, _steps: f32) -> anyhow::Result<Option<String>> {
        Ok(None)
    }
    /// The edited shape as a mesh (key W writes it), for scenes whose handles are a cage.
    fn edited_cage(&self) -> Option<crate::mesh::Mesh> {
        None
    }
}

/// The light direction (towards the light) of every surface scene.
pub const LIGHT_DIR: Vec3 = Vec3::new(0.4, -0.5, 0.8);

pub(crate) fn surface_push(
    view: &ViewState,
    targets: &FrameTargets,
    color: [f32; 3],
    level: u32,
) -> SurfacePush {
    let aspect = targets.extent.width as f32 / targets.extent.height.max(1) as f32;
    let eye = view.orbit.eye();
    let light = LIGHT_DIR.normalize();
    SurfacePush {
        view_proj: view.orbit.view_proj(aspect).to_cols_array_2d(),
        eye: [eye.x, eye.y, eye.z, 1.0],
        light: [light.x, light.y, light.z, 0.35],
        color: [color[0], color[1], color[2], 1.0],
        mode: [view.shading as u32, level, 0, 0],
    }
}

fn scoped<T>(
    profiler: &mut Profiler,
    ctx: &Context,
    cmd: vk::CommandBuffer,
    slot: usize,
    name: &str,
    f: impl FnOnce() -> T,
) -> T {
    profiler.scope(ctx, cmd, slot, name, f)
}

/// Draws a surface vertex/index buffer pair (with its tessellation level) in the scene's shading, timed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw_surface(
    draw: &SurfaceDrawPass,
    ctx: &Context,
    cmd: vk::CommandBuffer,
    targets: &FrameTargets,
    view: &ViewState,
    profiler: &mut Profiler,
    color: [f32; 3],
    (vertices, indices, index_count, level): (&Buffer, &Buffer, u32, u32),
) {
    let push = surface_push(view, targets, color, level);
    let target = targets.draw_target();
    scoped(profiler, ctx, cmd, targets.slot, "surface draw", || {
        draw.record(
            ctx,
            cmd,
            &target,
            Some([0.92, 0.93, 0.95, 1.0]),
            vertices,
            indices,
            index_count,
            &push,
        )
    });
}

/// The control points of a surface, for the curvature pass and the vertex-pull path.
#[derive(Clone, Copy)]
pub struct PatchSource<'a> {
    /// The points (and their residuals, for the vertex-pull path).
    pub points: ControlPoints<'a>,
    pub patch_points: &'a Buffer,
    pub patch_count: u32,
}

/// One frame's surface for [`SurfaceLook::record`].
#[derive(Clone, Copy)]
pub struct SurfaceFrame<'a> {
    pub vertices: &'a Buffer,
    pub indices: &'a Buffer,
    pub index_count: u32,
    pub level: u32,
    /// `None`: no curvature modes (Phong instead) and no vertex-pull path.
    pub patches: Option<PatchSource<'a>>,
    pub color: [f32; 3],
    /// Adaptive tessellation: `indices` holds every level's grid and each patch draws its own through these
    /// commands. The curvature modes and the vertex-pull path work on uniform grids only (Phong and the
    /// compute path instead).
    pub indirect: Option<IndirectDraw<'a>>,
    /// UVs vertex for vertex (uniform, adaptive or ptex grids) for the checker shading.
    pub uvs: Option<&'a Buffer>,
}

/// Where a surface scene sits: a sphere around the (animated) surface and the ground plane under it.
#[derive(Clone, Copy, Debug)]
pub struct Stage {
    pub centre: Vec3,
    pub radius: f32,
    pub ground_z: f32,
}

/// How the demo draws a surface: the lit draw pass, the shadow map, the ground plane that receives the
/// shadow, the curvature pass and its (H, K) buffer, and the vertex-pull path. One per surface scene.
pub struct SurfaceLook {
    draw: SurfaceDrawPass,
    shadow: ShadowMap,
    curvature_pass: SurfaceCurvaturePass,
    pull: PatchPullPass,
    /// (H, K) per vertex of the current level; sized by [`SurfaceLook::resize`].
    curvature: Option<Buffer>,
    /// One patch's (L+1)² grid indices for the vertex-pull path, and its level.
    pull_indices: Option<(Buffer, u32)>,
    ground: Vec<Buffer>,
    stage: Stage,
}

/// Side of the demo's shadow map: 1024² keeps the shadow edges of a 1280×720 frame sharp.
const SHADOW_SIZE: u32 = 1024;

impl SurfaceLook {
    /// Builds the passes for targets of `format` and the ground plane of `stage`.
    pub fn new(
        ctx: &Context,
        format: impl Into<ColorTarget>,
        stage: Stage,
    ) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        let draw = SurfaceDrawPass::new(ctx, format, DEPTH_FORMAT)?;
        let shadow = ShadowMap::new(ctx, SHADOW_SIZE)?;
        let curvature_pass = SurfaceCurvaturePass::new(ctx)?;
        let pull = PatchPullPass::new(ctx, format, DEPTH_FORMAT, false)?;
        // The ground: a square of 3.2 radii under the stage, normal +Z (SurfaceVertex layout).
        let (c, h) = (stage.centre, 1.6 * stage.radius);
        let corners = [(-h, -h), (h, -h), (h, h), (-h, h)];
        let vertices: Vec<[f32; 8]> = corners
            .iter()
            .map(|&(x, y)| [c.x + x, c.y + y, stage.ground_z, 1.0, 0.0, 0.0, 1.0, 0.0])
            .collect();
        let indices: [u32; 6] = [0, 1, 2, 0, 2, 3];
        let ground = vec![
            ctx.upload_buffer(
                "ground vertices",
                bytemuck::cast_slice(&vertices),
                vk::BufferUsageFlags::VERTEX_BUFFER,
            )?,
            ctx.upload_buffer(
                "ground indices",
                bytemuck::cast_slice(&indices),
                vk::BufferUsageFlags::INDEX_BUFFER,
            )?,
        ];
        Ok(SurfaceLook {
            draw,
            shadow,
            curvature_pass,
            pull,
            curvature: None,
            pull_indices: None,
            ground,
            stage,
        })
    }

    /// Sizes the curvature buffer and the vertex-pull grid for `patches` patches at `level`. Replaced buffers
    /// go through the release queue, so earlier frames may still be using them.
    pub fn resize(&mut self, ctx: &Context, patches: u32, level: u32) -> anyhow::Result<()> {
        let bytes = vertex_count(patches, level) * CURVATURE_STRIDE;
        if self.curvature.as_ref().is_none_or(|b| b.size() < bytes) {
            self.curvature = Some(ctx.create_buffer(
                "surface curvature",
                bytes.max(CURVATURE_STRIDE),
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER,
                crate::gpu::MemoryLocation::GpuOnly,
            )?);
        }
        if self.pull_indices.as_ref().is_none_or(|(_, l)| *l != level) {
            let idx = grid_indices(1, level);
            self.pull_indices = Some((
                ctx.upload_buffer(
                    "patch pull grid",
                    bytemuck::cast_slice(&idx),
                    vk::BufferUsageFlags::INDEX_BUFFER,
                )?,
                level,
            ));
        }
        Ok(())
    }

    /// Records shadow map → (curvature) → ground + surface for `surface` (its compute passes already
    /// recorded), each in a profiler scope.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &FrameTargets,
        view: &ViewState,
        profiler: &mut Profiler,
        surface: &SurfaceFrame<'_>,
    ) -> anyhow::Result<()> {
        let slot = targets.slot;
        let light = light_view_proj(LIGHT_DIR, self.stage.centre, self.stage.radius);
        scoped(profiler, ctx, cmd, slot, "shadow map", || {
            self.shadow.record(
                ctx,
                cmd,
                light,
                &[LitDraw {
                    vertices: surface.vertices,
                    curvature: None,
                    uvs: None,
                    indices: surface.indices,
                    index_count: surface.index_count,
                    indirect: surface.indirect,
                }],
            )
        });
        let mut shading = view.shading;
        let mut curvature = None;
        match (surface.patches, &self.curvature) {
            (Some(p), Some(buf)) if shading.needs_curvature() && surface.indirect.is_none() => {
                scoped(profiler, ctx, cmd, slot, "surface curvature", || {
                    self.curvature_pass.record(
                        ctx,
                        cmd,
                        p.points.buffer,
                        p.patch_points,
                        p.patch_count,
                        surface.level,
                        buf,
                    )
                })?;
                curvature = Some(buf);
            }
            // Without control points (or on adaptive grids) there is no curvature to show: Phong instead.
            _ if shading.needs_curvature() => shading = ShadingMode::Phong,
            _ if shading.needs_uniform_grid(surface.uvs.is_some())
                && surface.indirect.is_some() =>
            {
                shading = ShadingMode::Phong
            }
            _ => {}
        }
        let view = ViewState { shading, ..*view };
        let mut push = surface_push(&view, targets, surface.color, surface.level);
        // Curvature colour scale: H = 2/radius (a sphere half the stage's size) maps to tanh(1).
        push.mode[2] = (0.5 * self.stage.radius).to_bits();
        push.mode[3] = FLAG_SHADOWS | if surface.uvs.is_some() { FLAG_UVS } else { 0 };
        let mut ground_push = surface_push(&view, targets, [0.78, 0.76, 0.72], 1);
        ground_push.mode[3] = FLAG_SHADOWS | FLAG_GROUND;
        let target = targets.draw_target();
        let ground = LitDraw {
            vertices: &self.ground[0],
            curvature: None,
            uvs: None,
            indices: &self.ground[1],
            index_count: 6,
            indirect: None,
        };
        let lit = LitDraw {
            vertices: surface.vertices,
            curvature,
            uvs: surface.uvs,
            indices: surface.indices,
            index_count: surface.index_count,
            indirect: surface.indirect,
        };
        let clear = Some([0.92, 0.93, 0.95, 1.0]);
        match (view.path, surface.patches, &self.pull_indices) {
            (DrawPath::VertexPull, Some(p), Some((grid, level)))
                if *level == surface.level && surface.indirect.is_none() =>
            {
                scoped(profiler, ctx, cmd, slot, "surface draw", || {
                    self.draw.record_lit(
                        ctx,
                        cmd,
                        &target,
                        clear,
                        &self.shadow,
                        &[(ground, ground_push)],
                    )
                });
                scoped(profiler, ctx, cmd, slot, "patch pull draw", || {
                    self.pull.record(
                        ctx,
                        cmd,
                        &target,
                        None,
                        PatchKind::Gregory,
                        p.points,
                        p.patch_points,
                        p.patch_count,
                        surface.level,
                        grid,
                        None,
                        &push,
                    )
                })?;
            }
            _ => scoped(profiler, ctx, cmd, slot, "surface draw", || {
                self.draw.record_lit(
                    ctx,
                    cmd,
                    &target,
                    clear,
                    &self.shadow,
                    &[(ground, ground_push), (lit, push)],
                )
            }),
        }
        Ok(())
    }
}

/// The minimal compute → raster scene: a ring of triangles written by a compute shader.
pub struct SpinnerScene {
    spinner: SpinnerPass,
    triangles: TrianglesPass,
    buffers: Vec<Buffer>,
    count: u32,
}

impl SpinnerScene {
    /// `count` triangles, drawn into targets of `format`.
    pub fn new(
        ctx: &Context,
        format: impl Into<ColorTarget>,
        count: u32,
        slots: usize,
    ) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        let count = count.clamp(1, 1 << 20);
        let spinner = SpinnerPass::new(ctx)?;
        let triangles = TrianglesPass::new(ctx, format)?;
        // One buffer per slot: frame N+1's compute must not overwrite what frame N still draws.
        let buffers = (0..slots)
            .map(|i| {
                ctx.create_buffer(
                    &format!("spinner vertices {i}"),
                    count as u64 * 48,
                    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER,
                    MemoryLocation::GpuOnly,
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SpinnerScene {
            spinner,
            triangles,
            buffers,
            count,
        })
    }
}

impl Scene for SpinnerScene {
    fn name(&self) -> String {
        "spinner".into()
    }

    fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &FrameTargets,
        t: f32,
        _view: &ViewState,
        profiler: &mut Profiler,
    ) -> anyhow::Result<()> {
        let aspect = targets.extent.width as f32 / targets.extent.height.max(1) as f32;
        let vb = &self.buffers[targets.slot];
        scoped(
            profiler,
            ctx,
            cmd,
            targets.slot,
            "spinner (compute)",
            || self.spinner.record(ctx, cmd, vb, self.count, t, aspect),
        )?;
        scoped(
            profiler,
            ctx,
            cmd,
            targets.slot,
            "triangles (raster)",
            || {
                self.triangles.record(
                    ctx,
                    cmd,
                    targets.color,
                    targets.resolve,
                    targets.extent,
                    [0.02, 0.02, 0.04, 1.0],
                    vb,
                    self.count * 3,
                    None,
                )
            },
        );
        Ok(())
    }

    fn framing(&self) -> Orbit {
        Orbit::framing(Vec3::ZERO, 1.0)
    }
}

/// The thesis's flag: 2×3 Gregory patches from animated boundary curves, Chiyokura–Kimura on/off (key C).
/// Its control points feed the curvature modes and the vertex-pull path like a cage's; +/− rebuild the flag at
/// the new level.
/// The thesis flag; paused, the corners of its boundary network are drawn and can be dragged (their
/// offsets go to the GPU in the next frame's command buffer).
pub struct FlagScene {
    flag: FlagSurface,
    look: SurfaceLook,
    pub correct: bool,
    /// Per network corner, the user's move ((columns + 1) × (rows + 1), row-major).
    offsets: Vec<glam::DVec3>,
    offsets_dirty: bool,
    held: Option<usize>,
    lines: SceneLines,
}

/// The flag's wave amplitude.
const FLAG_AMPLITUDE: f32 = 0.35;

impl FlagScene {
    /// A `columns × rows` flag at tessellation `level`.
    pub fn new(
        ctx: &Context,
        format: impl Into<ColorTarget>,
        columns: u32,
        rows: u32,
        level: u32,
    ) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        let flag = FlagSurface::new(ctx, columns, rows, level)?;
        let (w, h) = (columns as f32, rows as f32);
        // The flag waves by about ±0.35 around z = 0 (FlagScene::record's amplitude).
        let stage = Stage {
            centre: Vec3::new(0.5 * w, 0.5 * h, 0.0),
            radius: 0.5 * (w * w + h * h + 1.0).sqrt(),
            ground_z: -0.6 * w.max(h) * 0.5,
        };
        let mut look = SurfaceLook::new(ctx, format, stage)?;
        look.resize(ctx, flag.patch_count(), flag.level)?;
        Ok(FlagScene {
            flag,
            look,
            correct: true,
            offsets: vec![glam::DVec3::ZERO; (columns as usize + 1) * (rows as usize + 1)],
            offsets_dirty: false,
            held: None,
            lines: SceneLines::new(ctx, format)?,
        })
    }

    /// The flag's shape at time `t` (the paused flag is shown at 0).
    fn params(&self, t: f32) -> crate::engine::flag::FlagParams {
        crate::engine::flag::FlagParams {
            columns: self.flag.columns,
            rows: self.flag.rows,
            t: t as f64,
            amplitude: FLAG_AMPLITUDE as f64,
            correct: self.correct,
        }
    }
}

impl Scene for FlagScene {
    fn name(&self) -> String {
        format!(
            "flag {}×{} (correction {})",
            self.flag.columns,
            self.flag.rows,
            if self.correct { "on" } else { "off" }
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
        let time = if view.animate { t } else { 0.0 };
        if self.offsets_dirty {
            self.flag.record_offsets(ctx, cmd, &self.offsets)?;
            self.offsets_dirty = false;
        }
        self.flag.record(
            ctx,
            cmd,
            time,
            FLAG_AMPLITUDE,
            self.correct,
            Some((profiler, targets.slot)),
        )?;
        let surface = SurfaceFrame {
            vertices: self.flag.vertices(),
            indices: self.flag.indices(),
            index_count: self.flag.index_count(),
            level: self.flag.level,
            patches: Some(PatchSource {
                points: ControlPoints::plain(self.flag.points()),
                patch_points: self.flag.patch_points(),
                patch_count: self.flag.patch_count(),
            }),
            color: [0.85, 0.25, 0.2],
            indirect: None,
            uvs: None,
        };
        self.look
            .record(ctx, cmd, targets, view, profiler, &surface)?;
        if view.animate {
            return Ok(());
        }
        // Paused: a cross at each corner of the network, the handles.
        let corners = crate::engine::flag::flag_corners(&self.params(0.0), &self.offsets);
        let mut vertices = Vec::with_capacity(6 * corners.len());
        let points = corners.iter().map(|q| q.as_vec3());
        cross_marks(&mut vertices, points, self.held, 0.05);
        self.lines.record(
            ctx,
            cmd,
            targets,
            view,
            profiler,
            "corner marks",
            None,
            &vertices,
        )
    }

    fn handles(&self, view: &ViewState) -> Vec<Vec3> {
        if view.animate {
            return Vec::new();
        }
        crate::engine::flag::flag_corners(&self.params(0.0), &self.offsets)
            .iter()
            .map(|p| p.as_vec3())
            .collect()
    }

    fn set_handles(&mut self, positions: &[Vec3], held: Option<usize>) -> anyhow::Result<()> {
        anyhow::ensure!(
            positions.len() == self.offsets.len(),
            "{} handles given, the flag's network has {} corners",
            positions.len(),
            self.offsets.len()
        );
        let positions: Vec<glam::DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
        self.offsets = crate::engine::flag::corner_offsets(&self.params(0.0), &positions);
        self.offsets_dirty = true;
        self.held = held;
        Ok(())
    }

    fn key(&mut self, _ctx: &Context, key: &str) -> anyhow::Result<bool> {
        if key.eq_ignore_ascii_case("c") {
            self.correct = !self.correct;
            return Ok(true);
        }
        Ok(false)
    }

    fn framing(&self) -> Orbit {
        let (w, h) = (self.flag.columns as f32, self.flag.rows as f32);
        Orbit::framing(Vec3::new(0.5 * w, 0.5 * h, 0.0), w.max(h))
    }

    fn level(&self) -> Option<u32> {
        Some(self.flag.level)
    }

    fn set_level(&mut self, ctx: &Context, level: u32) -> anyhow::Result<bool> {
        // The device is idle (trait contract); the flag's buffers are sized per level, so rebuild it.
        let flag = FlagSurface::new(ctx, self.flag.columns, self.flag.rows, level)?;
        self.look.resize(ctx, flag.patch_count(), level)?;
        self.flag = flag;
        // The new surface starts from the thesis's network: give it the corners as moved.
        self.offsets_dirty = true;
        Ok(true)
    }
}

/// A quad cage as Gregory patches, deformed every frame on the GPU; paused, the cage is drawn and its
/// vertices can be dragged (the edited cage goes to the GPU in the next frame's command buffer).
pub struct CageScene {
    surface: GregorySurface,
    /// The cage's UV surface (same patches and grids), evaluated once per level: UVs do not move with the
    /// cage.
    uv: Option<GregorySurface>,
    /// The ptex layout's UVs instead: the host's UV evaluator and its values at the grid points as a vertex
    /// stream, made once per level.
    ptex_uv: Option<(Box<crate::surface::LimitEvaluator>, crate::gpu::Buffer)>,
    look: SurfaceLook,
    pub deformation: Deformation,
    name: String,
    /// Screen-space adaptive tessellation (key A): target pixels per segment, the current level as L_max.
    pub adaptive: Option<f32>,
    /// The cage as edited: rest positions in the surface's frame, the faces as loaded.
    cage: crate::mesh::Mesh,
    /// Each cage edge once.
    edges: Vec<[u32; 2]>,
    /// The cage changed since it was last recorded.
    cage_dirty: bool,
    /// The vertex being dragged.
    held: Option<usize>,
    lines: SceneLines,
}

/// Pixels per tessellation segment when key A turns adaptive tessellation on.
pub const ADAPTIVE_PIXELS: f32 = 8.0;

/// The cage's lines and vertex crosses.
const CAGE_COLOR: [f32; 3] = [0.1, 0.12, 0.16];
/// The dragged vertex's cross.
const HELD_COLOR: [f32; 3] = [1.0, 0.45, 0.05];

/// A cross of half-size `r` along the axes at each of `points` (the handles of a paused scene), the `held`
/// one 2.5 times larger in orange, appended to `out` as line segments.
fn cross_marks(
    out: &mut Vec<crate::passes::lines::LineVertex>,
    points: impl Iterator<Item = Vec3>,
    held: Option<usize>,
    r: f32,
) {
    use crate::passes::lines::LineVertex;
    for (i, q) in points.enumerate() {
        let (r, c) = if held == Some(i) {
            (2.5 * r, HELD_COLOR)
        } else {
            (r, CAGE_COLOR)
        };
        for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
            out.push(LineVertex::new((q - r * axis).to_array(), c));
            out.push(LineVertex::new((q + r * axis).to_array(), c));
        }
    }
}

impl CageScene {
    /// Whether the scene has the cage's UVs (a UV surface, or the ptex layout's UVs).
    pub fn has_uvs(&self) -> bool {
        self.uv.is_some() || self.ptex_uv.is_some()
    }

    /// Whether the surface is tessellated per ptex face (feature-adaptive patches).
    pub fn is_ptex(&self) -> bool {
        self.surface.ptex_levels().is_some()
    }
}

/// The patches whose grids the curvature buffer must hold: none in the ptex layout, which has no curvature.
fn curvature_patches(surface: &GregorySurface) -> u32 {
    if surface.ptex_levels().is_some() {
        1
    } else {
        surface.patch_count()
    }
}

impl CageScene {
    /// Wraps a built surface.
    pub fn new(
        ctx: &Context,
        format: impl Into<ColorTarget>,
        surface: GregorySurface,
        cage: crate::mesh::Mesh,
        deformation: Deformation,
        name: String,
    ) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        anyhow::ensure!(
            cage.positions.len() == surface.cage_count() as usize,
            "the cage has {} vertices, its surface {}",
            cage.positions.len(),
            surface.cage_count()
        );
        let mut edges: Vec<[u32; 2]> = (0..cage.n_faces())
            .flat_map(|f| {
                let face = cage.face(f);
                (0..face.len()).map(move |i| {
                    let (a, b) = (face[i], face[(i + 1) % face.len()]);
                    [a.min(b), a.max(b)]
                })
            })
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let lo = Vec3::from(surface.box_min());
        let size = Vec3::from(surface.box_size());
        // Twist, bend and wave move points by up to the amplitude (0.6) times the box: a generous sphere.
        let stage = Stage {
            centre: lo + 0.5 * size,
            radius: 0.75 * size.length().max(1e-3),
            ground_z: lo.z - 0.35 * size.max_element(),
        };
        let mut look = SurfaceLook::new(ctx, format, stage)?;
        look.resize(ctx, curvature_patches(&surface), surface.level())?;
        Ok(CageScene {
            surface,
            uv: None,
            ptex_uv: None,
            look,
            deformation,
            name,
            adaptive: None,
            cage,
            edges,
            cage_dirty: false,
            held: None,
            lines: SceneLines::new(ctx, format)?,
        })
    }

    /// Gives a surface in the ptex layout the cage's UVs: `uv` (the host's UV evaluator of the cage)
    /// evaluated at the grid points, once per level.
    pub fn set_ptex_uvs(
        &mut self,
        ctx: &Context,
        uv: Box<crate::surface::LimitEvaluator>,
    ) -> anyhow::Result<()> {
        let (_, buffer) = self.surface.ptex_uvs(ctx, &uv)?.ok_or_else(|| {
            anyhow::anyhow!("ptex UVs given to a surface with one grid per patch")
        })?;
        self.ptex_uv = Some((uv, buffer));
        Ok(())
    }

    /// Gives the scene the cage's UV layout (patch `k` of it is the surface's patch `k`): the checker shading
    /// then shows the cage's own UVs. Builds and evaluates the UV surface at the current level.
    pub fn set_uvs(&mut self, ctx: &Context, uv: UvTopology) -> anyhow::Result<()> {
        anyhow::ensure!(
            uv.topology.patch_points.len() == self.surface.patch_count() as usize,
            "the UV layout has {} patches, the surface {}",
            uv.topology.patch_points.len(),
            self.surface.patch_count()
        );
        let mut s = GregorySurface::new(ctx, &uv.topology, &uv.values, self.surface.level())?;
        s.evaluate(ctx, None, None)?;
        self.uv = Some(s);
        Ok(())
    }

    /// The cage's edges and a cross at each vertex (the held one larger, in orange), as line segments.
    fn cage_lines(&self) -> Vec<crate::passes::lines::LineVertex> {
        use crate::passes::lines::LineVertex;
        let p = |i: u32| self.cage.positions[i as usize].as_vec3().to_array();
        let size = Vec3::from(self.surface.box_size()).length().max(1e-6);
        let mut out = Vec::with_capacity(2 * self.edges.len() + 6 * self.cage.positions.len());
        for &[a, b] in &self.edges {
            out.push(LineVertex::new(p(a), CAGE_COLOR));
            out.push(LineVertex::new(p(b), CAGE_COLOR));
        }
        let points = self.cage.positions.iter().map(|q| q.as_vec3());
        cross_marks(&mut out, points, self.held, 0.012 * size);
        out
    }
}

impl Scene for CageScene {
    fn name(&self) -> String {
        let level = match (self.adaptive, self.surface.ptex_levels()) {
            (Some(px), _) => format!("adaptive ≤ {} at {px} px", self.surface.level()),
            (None, Some(_)) => format!("level {} per ptex face", self.surface.level()),
            (None, None) => format!("level {}", self.surface.level()),
        };
        format!(
            "{} ({} patches, {level}, {:?})",
            self.name,
            self.surface.patch_count(),
            self.deformation
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
        let deform = DeformParams {
            mode: if view.animate {
                self.deformation
            } else {
                Deformation::None
            },
            t,
            amplitude: 0.6,
            box_min: self.surface.box_min(),
            box_size: self.surface.box_size(),
        };
        if let Some(pixels_per_segment) = self.adaptive {
            let e = targets.extent;
            let (w, h) = (e.width.max(1) as f32, e.height.max(1) as f32);
            self.surface.set_adaptive(
                ctx,
                Some(AdaptiveParams {
                    view_proj: view.orbit.view_proj(w / h),
                    viewport: [w, h],
                    pixels_per_segment,
                }),
            )?;
        }
        if self.cage_dirty {
            // Recorded into this frame: frames in flight keep the cage they were recorded with.
            self.surface
                .record_cage_update(ctx, cmd, &self.cage.positions)?;
            self.cage_dirty = false;
        }
        self.surface
            .record(ctx, cmd, Some(&deform), Some((profiler, targets.slot)))?;
        if let (Some(uv), Some(_)) = (&self.uv, self.surface.adaptive()) {
            // The UVs on this frame's adaptive grids (the levels the update just computed).
            self.surface.record_adaptive_of(ctx, cmd, uv)?;
        }
        let (indices, indirect) = match self.surface.adaptive_draw() {
            Some((indices, commands)) => (
                indices,
                Some(IndirectDraw {
                    commands,
                    count: self.surface.patch_count(),
                }),
            ),
            None => (self.surface.indices(), None),
        };
        let surface = SurfaceFrame {
            vertices: self.surface.vertices(),
            indices,
            index_count: self.surface.index_count(),
            level: self.surface.level(),
            // The ptex layout's grids are not patch grids: no curvature, no vertex pull (Phong instead).
            patches: self.surface.ptex_levels().is_none().then(|| PatchSource {
                points: self.surface.control_points(),
                patch_points: self.surface.patch_points(),
                patch_count: self.surface.patch_count(),
            }),
            color: [0.3, 0.55, 0.85],
            // The UV surface's vertices share the slots of the positions' (uniform, adaptive or ptex grids).
            uvs: self
                .uv
                .as_ref()
                .map(|u| u.vertices())
                .or(self.ptex_uv.as_ref().map(|(_, b)| b)),
            indirect,
        };
        self.look
            .record(ctx, cmd, targets, view, profiler, &surface)?;
        if view.animate {
            return Ok(());
        }
        // Paused: the rest cage as edited is what the surface shows, so it is drawn for dragging.
        let vertices = self.cage_lines();
        self.lines.record(
            ctx,
            cmd,
            targets,
            view,
            profiler,
            "cage lines",
            None,
            &vertices,
        )
    }

    fn handles(&self, view: &ViewState) -> Vec<Vec3> {
        if view.animate {
            return Vec::new();
        }
        self.cage.positions.iter().map(|p| p.as_vec3()).collect()
    }

    fn set_handles(&mut self, positions: &[Vec3], held: Option<usize>) -> anyhow::Result<()> {
        anyhow::ensure!(
            positions.len() == self.cage.positions.len(),
            "{} handles given, the cage has {} vertices",
            positions.len(),
            self.cage.positions.len()
        );
        for (p, q) in self.cage.positions.iter_mut().zip(positions) {
            *p = q.as_dvec3();
        }
        self.held = held;
        self.cage_dirty = true;
        Ok(())
    }

    fn edited_cage(&self) -> Option<crate::mesh::Mesh> {
        Some(self.cage.clone())
    }

    fn key(&mut self, ctx: &Context, key: &str) -> anyhow::Result<bool> {
        if key.eq_ignore_ascii_case("a") {
            if self.surface.ptex_levels().is_some() {
                eprintln!(
                    "gregvox demo: screen-space adaptive tessellation needs one grid per patch; this cage \
                     is tessellated per ptex face"
                );
                return Ok(false);
            }
            // The parameters are refreshed from the camera every frame; switching off keeps the buffers.
            self.adaptive = match self.adaptive {
                Some(_) => {
                    self.surface.set_adaptive(ctx, None)?;
                    None
                }
                None => Some(ADAPTIVE_PIXELS),
            };
            return Ok(true);
        }
        if key.eq_ignore_ascii_case("d") {
            self.deformation = match self.deformation {
                Deformation::None => Deformation::Twist,
                Deformation::Twist => Deformation::Bend,
                Deformation::Bend => Deformation::Wave,
                Deformation::Wave => Deformation::None,
            };
            return Ok(true);
        }
        Ok(false)
    }

    fn framing(&self) -> Orbit {
        let [x, y, z] = self.surface.box_min();
        let [w, h, d] = self.surface.box_size();
        Orbit::framing(
            Vec3::new(x + 0.5 * w, y + 0.5 * h, z + 0.5 * d),
            w.max(h).max(d),
        )
    }

    fn level(&self) -> Option<u32> {
        Some(self.surface.level())
    }

    fn set_level(&mut self, ctx: &Context, level: u32) -> anyhow::Result<bool> {
        self.surface.set_level(ctx, level)?;
        if let Some(uv) = self.uv.as_mut() {
            uv.set_level(ctx, level)?;
            uv.evaluate(ctx, None, None)?;
        }
        if let Some((e, _)) = self.ptex_uv.take() {
            self.set_ptex_uvs(ctx, e)?;
        }
        self.look
            .resize(ctx, curvature_patches(&self.surface), self.surface.level())?;
        Ok(true)
    }
}

//! Demo scenes. A scene owns its GPU chain (compute passes, buffers, draw pass) and records one frame into
//! the renderer's targets; the renderer owns frames, profiler, depth images and the present target.
//!
//! Invariants: on entry to `Scene::record` the color target is in `COLOR_ATTACHMENT_OPTIMAL` (contents
//! undefined) and the depth target in `DEPTH_ATTACHMENT_OPTIMAL`; the scene clears and draws both and leaves
//! the layouts unchanged. A scene's `destroy` runs with the device idle.
use crate::engine::flag::FlagSurface;
use crate::engine::gregory::GregorySurface;
use crate::gpu::{Buffer, Context, MemoryLocation, Profiler};
use crate::passes::cage_deform::{DeformParams, Deformation};
use crate::passes::spinner::SpinnerPass;
use crate::passes::surface_draw::{DrawTarget, ShadingMode, SurfaceDrawPass, SurfacePush};
use crate::passes::triangles::TrianglesPass;
use ash::vk;
use glam::{Mat4, Vec3};

/// The depth format of every scene.
pub const DEPTH_FORMAT: vk::Format = vk::Format::D32_SFLOAT;

/// One frame's render targets.
#[derive(Clone, Copy)]
pub struct FrameTargets {
    pub slot: usize,
    pub color: vk::ImageView,
    pub depth: vk::ImageView,
    pub extent: vk::Extent2D,
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

/// Viewer state shared by scenes (camera, shading mode, toggles).
#[derive(Clone, Copy, Debug)]
pub struct ViewState {
    pub orbit: Orbit,
    pub shading: ShadingMode,
    pub animate: bool,
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
    /// Destroys the scene's resources (device idle).
    fn destroy(self: Box<Self>, ctx: &Context);
}

pub(crate) fn surface_push(
    view: &ViewState,
    targets: &FrameTargets,
    color: [f32; 3],
    level: u32,
) -> SurfacePush {
    let aspect = targets.extent.width as f32 / targets.extent.height.max(1) as f32;
    let eye = view.orbit.eye();
    let light = Vec3::new(0.4, -0.5, 0.8).normalize();
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
    let target = DrawTarget {
        color: targets.color,
        depth: targets.depth,
        extent: targets.extent,
    };
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
        format: vk::Format,
        count: u32,
        slots: usize,
    ) -> anyhow::Result<Self> {
        let count = count.clamp(1, 1 << 20);
        let spinner = SpinnerPass::new(ctx)?;
        let triangles = match TrianglesPass::new(ctx, format) {
            Ok(t) => t,
            Err(e) => {
                spinner.destroy(ctx);
                return Err(e.into());
            }
        };
        let mut s = SpinnerScene {
            spinner,
            triangles,
            buffers: Vec::new(),
            count,
        };
        for i in 0..slots {
            // One buffer per slot: frame N+1's compute must not overwrite what frame N still draws.
            match ctx.create_buffer(
                &format!("spinner vertices {i}"),
                count as u64 * 48,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER,
                MemoryLocation::GpuOnly,
            ) {
                Ok(b) => s.buffers.push(b),
                Err(e) => {
                    Box::new(s).destroy(ctx);
                    return Err(e.into());
                }
            }
        }
        Ok(s)
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

    fn destroy(self: Box<Self>, ctx: &Context) {
        for b in self.buffers {
            b.destroy(ctx);
        }
        self.spinner.destroy(ctx);
        self.triangles.destroy(ctx);
    }
}

/// The thesis's flag: 2×3 Gregory patches from animated boundary curves, Chiyokura–Kimura on/off (key C).
pub struct FlagScene {
    flag: FlagSurface,
    draw: SurfaceDrawPass,
    pub correct: bool,
}

impl FlagScene {
    /// A `columns × rows` flag at tessellation `level`.
    pub fn new(
        ctx: &Context,
        format: vk::Format,
        columns: u32,
        rows: u32,
        level: u32,
    ) -> anyhow::Result<Self> {
        let flag = FlagSurface::new(ctx, columns, rows, level)?;
        match SurfaceDrawPass::new(ctx, format, DEPTH_FORMAT) {
            Ok(draw) => Ok(FlagScene {
                flag,
                draw,
                correct: true,
            }),
            Err(e) => {
                flag.destroy(ctx);
                Err(e.into())
            }
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
        self.flag.record(
            ctx,
            cmd,
            time,
            0.35,
            self.correct,
            Some((profiler, targets.slot)),
        )?;
        draw_surface(
            &self.draw,
            ctx,
            cmd,
            targets,
            view,
            profiler,
            [0.85, 0.25, 0.2],
            (
                self.flag.vertices(),
                self.flag.indices(),
                self.flag.index_count(),
                self.flag.level,
            ),
        );
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

    fn destroy(self: Box<Self>, ctx: &Context) {
        self.flag.destroy(ctx);
        self.draw.destroy(ctx);
    }
}

/// A quad cage as Gregory patches, deformed every frame on the GPU.
pub struct CageScene {
    surface: GregorySurface,
    draw: SurfaceDrawPass,
    pub deformation: Deformation,
    name: String,
}

impl CageScene {
    /// Wraps a built surface.
    pub fn new(
        ctx: &Context,
        format: vk::Format,
        surface: GregorySurface,
        deformation: Deformation,
        name: String,
    ) -> anyhow::Result<Self> {
        match SurfaceDrawPass::new(ctx, format, DEPTH_FORMAT) {
            Ok(draw) => Ok(CageScene {
                surface,
                draw,
                deformation,
                name,
            }),
            Err(e) => {
                surface.destroy(ctx);
                Err(e.into())
            }
        }
    }
}

impl Scene for CageScene {
    fn name(&self) -> String {
        format!(
            "{} ({} patches, level {}, {:?})",
            self.name, self.surface.patch_count, self.surface.level, self.deformation
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
            box_min: self.surface.box_min,
            box_size: self.surface.box_size,
        };
        self.surface
            .record(ctx, cmd, Some(&deform), Some((profiler, targets.slot)))?;
        draw_surface(
            &self.draw,
            ctx,
            cmd,
            targets,
            view,
            profiler,
            [0.3, 0.55, 0.85],
            (
                self.surface.vertices(),
                self.surface.indices(),
                self.surface.index_count(),
                self.surface.level,
            ),
        );
        Ok(())
    }

    fn key(&mut self, _ctx: &Context, key: &str) -> anyhow::Result<bool> {
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
        let [x, y, z] = self.surface.box_min;
        let [w, h, d] = self.surface.box_size;
        Orbit::framing(
            Vec3::new(x + 0.5 * w, y + 0.5 * h, z + 0.5 * d),
            w.max(h).max(d),
        )
    }

    fn destroy(self: Box<Self>, ctx: &Context) {
        self.surface.destroy(ctx);
        self.draw.destroy(ctx);
    }
}

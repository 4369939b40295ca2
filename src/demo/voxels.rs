//! The `voxels` scene: the cage scene's deforming Gregory surface (built-in cage or `--model`), voxelized on
//! the GPU straight from its device-local vertex buffer every K frames (`--voxel-every`, resolution
//! `--voxel-res`), the bit grid ray cast by a compute shader; left half the surface, right half the voxels,
//! same camera. The ray caster runs at 1/`--voxel-scale` of the half's resolution (default 2: on lavapipe's
//! two CPU threads a full-resolution 640×720 cast costs about 250 ms, a quarter of the rays about 65 ms).
//!
//! Invariants: nothing is read back per frame. The grid frame (a cube around every pose the deformation
//! reaches) and the number of peeling passes are fixed when the scene is built, from GPU bounds and layer
//! counts of the surface sampled over the deformation's cycle (setup-time readbacks only). The ray caster's
//! output image is per frame slot, so it is recreated on resize only once that slot's previous frame has
//! completed (the renderer waited for it in `begin_frame`).
use super::scene::{draw_surface, FrameTargets, Orbit, Scene, ViewState, DEPTH_FORMAT};
use super::DemoArgs;
use crate::engine::cage::{builtin_cage, load_cage_topology, tagged_cage_topologies};
use crate::engine::gregory::{GregorySurface, SurfaceBounds};
use crate::engine::voxelize::{PeelVoxelizer, ResidentVoxelizer};
use crate::gpu::{Buffer, Context, Image, MemoryLocation, Profiler};
use crate::mesh::Cage;
use crate::passes::cage_deform::{DeformParams, Deformation};
use crate::passes::draw::ColorTarget;
use crate::passes::peel::PeelGeometry;
use crate::passes::surface_draw::SurfaceDrawPass;
use crate::passes::voxel_raycast::{bricks_bytes, VoxelRaycastPass};
use crate::surface::Tangents;
use crate::voxel::cpu::FillRule;
use crate::voxel::grid::{Axis, GridFrame};
use crate::voxel::raycast::{RayCamera, RayShading};
use anyhow::Context as _;
use ash::vk;
use glam::Vec3;

/// The surface's colour (as the cage scene) and the background (the surface pass's clear colour).
const COLOR: [f32; 3] = [0.3, 0.55, 0.85];
const BACKGROUND: [f32; 3] = [0.92, 0.93, 0.95];
/// The raster camera's vertical field of view (`Orbit::view_proj`), so both halves show the same view.
const FOVY: f32 = 0.8;
/// The deformation amplitude of the cage scene.
const AMPLITUDE: f32 = 0.6;
/// Largest `--voxel-res`: one binding holds the whole grid and the per-frame cost grows as R³.
pub const MAX_VOXEL_RES: u32 = 512;

/// Times at which the surface is sampled to place the grid and count layers: the twist and bend are
/// 2π-periodic in t, the wave's two terms repeat after 4 and 10/3, so [0, 20) with their extremes added
/// covers every pose up to the sampling step (the margin below takes up the rest).
fn sample_times() -> Vec<f32> {
    let mut t: Vec<f32> = (0..48).map(|i| i as f32 * 20.0 / 48.0).collect();
    t.extend([
        std::f32::consts::FRAC_PI_2,
        3.0 * std::f32::consts::FRAC_PI_2,
    ]);
    t
}

/// Options of the scene.
#[derive(Clone, Copy, Debug)]
pub struct VoxelsOptions {
    pub deformation: Deformation,
    pub res: u32,
    pub every: u32,
    /// The ray caster runs at 1/scale of the half's resolution in each direction (nearest upscaling).
    pub scale: u32,
}

/// The live voxels scene.
pub struct VoxelsScene {
    surface: GregorySurface,
    draw: SurfaceDrawPass,
    voxelizer: ResidentVoxelizer,
    raycast: VoxelRaycastPass,
    bricks: Buffer,
    images: Vec<Option<Image>>,
    pub options: VoxelsOptions,
    frames: u64,
    name: String,
}

fn deform(surface: &GregorySurface, mode: Deformation, t: f32) -> DeformParams {
    DeformParams {
        mode,
        t,
        amplitude: AMPLITUDE,
        box_min: surface.box_min(),
        box_size: surface.box_size(),
    }
}

/// Places the grid around every sampled pose (plus a margin of 2 % of the side and one voxel) and measures
/// the deepest column along z over the poses; returns (frame, layers to peel).
fn plan_grid(
    ctx: &Context,
    surface: &GregorySurface,
    mode: Deformation,
    res: u32,
) -> anyhow::Result<(GridFrame, u32)> {
    let bounds = SurfaceBounds::new(ctx)?;
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for t in sample_times() {
        ctx.one_shot(|cmd| {
            surface.record(ctx, cmd, Some(&deform(surface, mode, t)), None)?;
            bounds.record(ctx, cmd, surface)
        })?;
        let (l, h) = bounds.read(ctx)?;
        for a in 0..3 {
            lo[a] = lo[a].min(l[a]);
            hi[a] = hi[a].max(h[a]);
        }
    }
    let side = (0..3).map(|a| hi[a] - lo[a]).fold(0.0f32, f32::max);
    let margin = 0.02 * side + side / res as f32;
    let lo = lo.map(|x| x - margin);
    let hi = hi.map(|x| x + margin);
    let frame = GridFrame::from_points(&[lo, hi], res)?;

    let counter = PeelVoxelizer::new(ctx, 32)?;
    let geom = PeelGeometry {
        vertices: surface.vertices(),
        indices: surface.indices(),
        index_count: surface.index_count(),
        bounds: None,
        mesh: None,
    };
    let mut deepest = 0;
    for t in sample_times() {
        ctx.one_shot(|cmd| surface.record(ctx, cmd, Some(&deform(surface, mode, t)), None))?;
        let (layers, _) = counter.count_layers(ctx, &geom, &frame, Axis::Z)?;
        deepest = deepest.max(layers);
    }
    // Two spare passes for poses between samples (extra passes cost time, never correctness).
    Ok((frame, deepest + 2))
}

impl VoxelsScene {
    /// Wraps a built surface: plans the grid, builds the resident voxelizer and the passes.
    pub fn new(
        ctx: &Context,
        format: impl Into<ColorTarget>,
        surface: GregorySurface,
        options: VoxelsOptions,
        name: String,
    ) -> anyhow::Result<Self> {
        let format: ColorTarget = format.into();
        if !(1..=8).contains(&options.scale) {
            anyhow::bail!("--voxel-scale {} is outside 1…8", options.scale);
        }
        if !(2..=MAX_VOXEL_RES).contains(&options.res) {
            anyhow::bail!("--voxel-res {} is outside 2…{MAX_VOXEL_RES}", options.res);
        }
        let (frame, layers) = plan_grid(ctx, &surface, options.deformation, options.res)?;
        let voxelizer = ResidentVoxelizer::new(ctx, 32, frame, layers, FillRule::Winding)?;
        let draw = SurfaceDrawPass::new(ctx, format, DEPTH_FORMAT)?;
        let raycast = VoxelRaycastPass::new(ctx, format)?;
        let bricks = ctx.create_buffer(
            "voxel bricks",
            bricks_bytes(frame.dims[0]),
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuOnly,
        )?;
        Ok(VoxelsScene {
            surface,
            draw,
            voxelizer,
            raycast,
            bricks,
            images: (0..super::FRAMES_IN_FLIGHT).map(|_| None).collect(),
            options: VoxelsOptions {
                every: options.every.max(1),
                ..options
            },
            frames: 0,
            name,
        })
    }

    /// The surface (tests compare against the one-shot voxelizer on its current vertex buffer).
    pub fn surface(&self) -> &GregorySurface {
        &self.surface
    }

    /// The resident voxelizer (its frame, layer count and device-local grid).
    pub fn voxelizer(&self) -> &ResidentVoxelizer {
        &self.voxelizer
    }

    /// The ray caster's camera and shading for a `width`×`height` half in `view`.
    pub fn ray_setup(view: &ViewState, width: u32, height: u32) -> (RayCamera, RayShading) {
        let o: Orbit = view.orbit;
        let cam = RayCamera::look_at(
            o.eye(),
            o.target,
            Vec3::Z,
            FOVY,
            width as f32 / height.max(1) as f32,
        );
        // The light and ambient of the surface shader's push constants (scene::surface_push).
        let light = Vec3::new(0.4, -0.5, 0.8).normalize();
        let shading = RayShading {
            light: light.to_array(),
            ambient: 0.35,
            color: COLOR,
            background: BACKGROUND,
        };
        (cam, shading)
    }

    /// Makes sure `slot` has an output image of `extent`.
    fn image(&mut self, ctx: &Context, slot: usize, extent: vk::Extent2D) -> anyhow::Result<()> {
        if self.images[slot]
            .as_ref()
            .is_some_and(|i| i.extent2d() != extent)
        {
            // Released through the queue; the slot's previous frame has completed.
            self.images[slot] = None;
        }
        if self.images[slot].is_none() {
            self.images[slot] = Some(VoxelRaycastPass::create_image(
                ctx,
                &format!("voxel raycast image {slot}"),
                extent.width,
                extent.height,
            )?);
        }
        Ok(())
    }
}

impl Scene for VoxelsScene {
    fn name(&self) -> String {
        format!(
            "voxels: {} ({} patches, {}³ voxels every {} frame(s), {} peeling passes, {:?})",
            self.name,
            self.surface.patch_count(),
            self.voxelizer.frame.dims[0],
            self.options.every,
            self.voxelizer.layers,
            self.options.deformation
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
        let mode = if view.animate {
            self.options.deformation
        } else {
            Deformation::None
        };
        self.surface.record(
            ctx,
            cmd,
            Some(&deform(&self.surface, mode, t)),
            Some((profiler, targets.slot)),
        )?;
        if self.frames % self.options.every as u64 == 0 {
            let geom = PeelGeometry {
                vertices: self.surface.vertices(),
                indices: self.surface.indices(),
                index_count: self.surface.index_count(),
                bounds: None,
                mesh: None,
            };
            let vox = &self.voxelizer;
            profiler.scope(ctx, cmd, targets.slot, "voxelize (resident)", || {
                vox.record(ctx, cmd, &geom)
            })?;
        }
        self.frames += 1;

        let (w, h) = (targets.extent.width, targets.extent.height);
        let left = (w / 2).max(1);
        let right = vk::Extent2D {
            width: (w - left).max(1),
            height: h,
        };
        let half = FrameTargets {
            extent: vk::Extent2D {
                width: left,
                height: h,
            },
            ..*targets
        };
        draw_surface(
            &self.draw,
            ctx,
            cmd,
            &half,
            view,
            profiler,
            COLOR,
            (
                self.surface.vertices(),
                self.surface.indices(),
                self.surface.index_count(),
                self.surface.level(),
            ),
        );
        if w < 2 {
            return Ok(());
        }
        let scale = self.options.scale;
        let cast = vk::Extent2D {
            width: right.width.div_ceil(scale),
            height: right.height.div_ceil(scale),
        };
        let (cam, shading) = Self::ray_setup(view, cast.width, cast.height);
        self.image(ctx, targets.slot, cast)?;
        let image = self.images[targets.slot].as_ref().unwrap();
        let (raycast, grid, bricks, frame) = (
            &self.raycast,
            self.voxelizer.grid(),
            &self.bricks,
            &self.voxelizer.frame,
        );
        profiler.scope(ctx, cmd, targets.slot, "voxel raycast", || {
            raycast.record(ctx, cmd, grid, bricks, frame, image, None, &cam, &shading)
        })?;
        profiler.scope(ctx, cmd, targets.slot, "voxel show", || {
            raycast.record_show(
                ctx,
                cmd,
                image,
                targets.color,
                targets.resolve,
                vk::Offset2D {
                    x: left as i32,
                    y: 0,
                },
                right,
                scale,
            )
        });
        Ok(())
    }

    fn key(&mut self, ctx: &Context, key: &str) -> anyhow::Result<bool> {
        if !key.eq_ignore_ascii_case("d") {
            return Ok(false);
        }
        // D cycles the deformation as in the cage scene. The grid frame and peeling depth belong to one
        // deformation, so they are planned again, with the device idled first (a key press may take that
        // pause). The old voxelizer is released through the release queue when it is replaced, so frames in
        // flight that still use it stay valid.
        ctx.wait_idle()?;
        let mode = match self.options.deformation {
            Deformation::None => Deformation::Twist,
            Deformation::Twist => Deformation::Bend,
            Deformation::Bend => Deformation::Wave,
            Deformation::Wave => Deformation::None,
        };
        let (frame, layers) = plan_grid(ctx, &self.surface, mode, self.voxelizer.frame.dims[0])?;
        self.voxelizer = ResidentVoxelizer::new(ctx, 32, frame, layers, FillRule::Winding)?;
        self.options.deformation = mode;
        // The next frame voxelizes whatever --voxel-every says.
        self.frames = 0;
        Ok(true)
    }

    fn framing(&self) -> Orbit {
        let [x, y, z] = self.surface.box_min();
        let [w, h, d] = self.surface.box_size();
        Orbit::framing(
            Vec3::new(x + 0.5 * w, y + 0.5 * h, z + 0.5 * d),
            w.max(h).max(d),
        )
    }
}

/// Builds the voxels scene from the demo arguments (cage as in the cage scene).
pub fn build(
    ctx: &Context,
    args: &DemoArgs,
    format: impl Into<ColorTarget>,
) -> anyhow::Result<Box<dyn Scene>> {
    let format: ColorTarget = format.into();
    let (t, name) = match &args.model {
        Some(path) => {
            let t = load_cage_topology(path)?;
            let name = path
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
            (t, name)
        }
        None => {
            let cage = Cage::from(builtin_cage(4, 2, 2));
            let t = tagged_cage_topologies(&cage, Tangents::OpenSubdiv, false)?;
            (t, "built-in box cage".to_string())
        }
    };
    if let Some(n) = &t.note {
        eprintln!("gregvox demo: {n}");
    }
    let surface = t
        .gregory_surface(ctx, args.level.unwrap_or(8))
        .context("building the voxels scene's Gregory surface")?;
    Ok(Box::new(VoxelsScene::new(
        ctx,
        format,
        surface,
        VoxelsOptions {
            deformation: args.deform,
            res: args.voxel_res,
            every: args.voxel_every,
            scale: args.voxel_scale,
        },
        name,
    )?))
}

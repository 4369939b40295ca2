//! `gregvox demo`: a window (winit + swapchain) or an offscreen image ring writing PNG frames, driven by the
//! same renderer and frame loop; every GPU pass runs in a profiler scope.
//!
//! Invariants: the context outlives everything here; at exit the frame loop waits for the device, then the
//! renderer, the present target and the window are dropped, in that order, before the context; their GPU
//! objects release themselves through the release queue of `gpu::lifetime`.
//! The offscreen ring has one image per frame slot, so a frame's PNG is written when its slot comes round
//! again (after that slot's fence) or at the end. Time is `frame × --time-step` offscreen (default 1/60 s,
//! so frames are reproducible whatever the machine's speed) and in a window when `--time-step` is given;
//! otherwise the window uses wall-clock time. Scene switches and level changes wait for the device first.
use crate::args::ProfileArgs;
use crate::gpu::present::begin_color_target;
use crate::gpu::resources::image_barrier;
use crate::gpu::{
    Context, ContextDesc, Frames, Image, ImageDesc, OffscreenTarget, PresentTarget, Profiler,
};
use crate::passes::cage_deform::Deformation;
use crate::passes::draw::ColorTarget;
use crate::passes::surface_draw::ShadingMode;
use anyhow::{bail, Context as _};
use ash::vk;
use clap::Args;
use scene::{DrawPath, FlagScene, FrameTargets, Scene, SpinnerScene, ViewState, DEPTH_FORMAT};
use std::path::PathBuf;

pub mod beziex;
pub mod cage;
pub mod curves;
pub mod hud;
pub mod scene;
pub mod voxels;
pub mod window;

/// Frames in flight.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// Arguments of `gregvox demo`.
#[derive(Clone, Debug, Args)]
pub struct DemoArgs {
    /// Render through the offscreen target and write PNG frames instead of opening a window.
    #[arg(long)]
    pub offscreen: bool,
    /// Number of frames to render (offscreen default 60; windowed: run until closed unless given).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Output folder for PNG frames (offscreen; default `out/demo`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Image or window size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Write every K-th frame as PNG (0: only the last; the last is always written).
    #[arg(long, default_value_t = 0)]
    pub every: u64,
    /// Multisample anti-aliasing: samples per pixel of surfaces and lines (1, 2, 4 or 8; the largest the
    /// device has for colour and depth together when it lacks the one asked for). Memory: each frame in
    /// flight holds a colour and a depth image of that many samples (4×: 32 bytes a pixel, 265 MB for each
    /// 4K frame); a size the device cannot allocate fails with the allocator's message.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub msaa: u32,
    /// Draw the overlay (scene, level, shading, frame and pass times) into offscreen frames too; the
    /// window shows it from the start (key H hides it).
    #[arg(long)]
    pub hud: bool,
    /// The scene.
    #[arg(long, value_enum, default_value = "flag")]
    pub scene: SceneKind,
    /// Tessellation level (1–64; default 10 for the flag as in the thesis, 8 for cages).
    #[arg(long)]
    pub level: Option<u32>,
    /// Shading mode.
    #[arg(long, value_enum, default_value = "phong")]
    pub shading: ShadingMode,
    /// Flag: start with the Chiyokura–Kimura correction off.
    #[arg(long)]
    pub no_correction: bool,
    /// Cage: the OBJ quad cage (default: a cage built into the binary).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Cage: screen-space adaptive tessellation at this many pixels per segment, the level as the maximum
    /// (key A toggles it at 8 px).
    #[arg(long, value_name = "PIXELS", value_parser = parse_pixels)]
    pub adaptive: Option<f32>,
    /// Cage: the deformation.
    #[arg(long, value_enum, default_value = "twist")]
    pub deform: Deformation,
    /// Fixed time step in seconds per frame (offscreen default 1/60; windowed default: wall-clock time).
    #[arg(long, value_name = "SECONDS", value_parser = parse_time_step)]
    pub time_step: Option<f32>,
    /// Draw the surface with the vertex-pull path instead of the compute evaluation (key V).
    #[arg(long)]
    pub vertex_pull: bool,
    /// Windowed: press these keys (comma-separated names as in the key list: `s,+,v,Space,2,p,t`), one every
    /// 5 frames, as if typed: lets CI exercise every control under Xvfb. Window operations go in the same list:
    /// `resize:WxH`, `minimize`, `restore`; so does the left button: `press:X:Y`, `move:X:Y`, `release`
    /// (window pixels; a press on a vertex of the paused cage scene drags it, elsewhere it orbits).
    #[arg(long, value_name = "KEYS", value_delimiter = ',')]
    pub keys: Vec<String>,
    /// Number of triangles in the spinner scene.
    #[arg(long, default_value_t = 48)]
    pub triangles: u32,
    /// Soak testing (hidden): print the resident set size after this many frames and again at the end.
    #[arg(long, hide = true, value_name = "FRAME")]
    pub soak_report: Option<u64>,
    /// Voxels: grid resolution (voxels per side, 2–512).
    #[arg(long, default_value_t = 64)]
    pub voxel_res: u32,
    /// Voxels: voxelize every K-th frame (the ray caster shows the last grid in between).
    #[arg(long, default_value_t = 1)]
    pub voxel_every: u32,
    /// Voxels: ray cast at 1/S of the window's resolution in each direction (1–8; 1 = every pixel).
    #[arg(long, default_value_t = 2)]
    pub voxel_scale: u32,
    #[command(flatten)]
    pub profile: ProfileArgs,
    /// The ids of the options given on the command line (not filled by clap's defaults): set by the CLI,
    /// for [`DemoArgs::check_scene_options`].
    #[arg(skip)]
    pub given: Vec<String>,
}

/// The scenes each scene-specific option applies to (by clap id = field name).
const SCENE_OPTIONS: &[(&str, &str, &[SceneKind])] = &[
    ("no_correction", "--no-correction", &[SceneKind::Flag]),
    (
        "model",
        "--model",
        &[SceneKind::Cage, SceneKind::Voxels, SceneKind::Beziex],
    ),
    ("adaptive", "--adaptive", &[SceneKind::Cage]),
    ("deform", "--deform", &[SceneKind::Cage, SceneKind::Voxels]),
    ("triangles", "--triangles", &[SceneKind::Spinner]),
    ("voxel_res", "--voxel-res", &[SceneKind::Voxels]),
    ("voxel_every", "--voxel-every", &[SceneKind::Voxels]),
    ("voxel_scale", "--voxel-scale", &[SceneKind::Voxels]),
    (
        "level",
        "--level",
        &[
            SceneKind::Flag,
            SceneKind::Cage,
            SceneKind::Voxels,
            SceneKind::Beziex,
        ],
    ),
    (
        "vertex_pull",
        "--vertex-pull",
        &[SceneKind::Flag, SceneKind::Cage],
    ),
    (
        "shading",
        "--shading",
        &[
            SceneKind::Flag,
            SceneKind::Cage,
            SceneKind::Voxels,
            SceneKind::Beziex,
        ],
    ),
];

impl DemoArgs {
    /// Options that the starting scene would ignore. Offscreen the scene never changes, so each is an
    /// error; in a window the number keys switch scenes (and an option of another scene applies there),
    /// so each is a note. Options of one mode given in the other (`--keys` offscreen, `--every` in a
    /// window) and view options the scene cannot honour (`--vertex-pull` or curvature shading with
    /// `--adaptive`) are errors. Returns the notes to print.
    pub fn check_scene_options(&self) -> anyhow::Result<Vec<String>> {
        let given = |id: &str| self.given.iter().any(|g| g == id);
        let scene = self.scene.name();
        let mut notes = Vec::new();
        for (id, flag, scenes) in SCENE_OPTIONS {
            if !given(id) || scenes.contains(&self.scene) {
                continue;
            }
            let names: Vec<String> = scenes.iter().map(|s| s.name()).collect();
            let text = format!(
                "{flag} applies to --scene {}, not to --scene {scene}",
                names.join(" or ")
            );
            if self.offscreen {
                bail!("{text}");
            }
            notes.push(format!(
                "{text}: it takes effect when a number key switches to one of them"
            ));
        }
        if self.offscreen && given("keys") {
            bail!("--keys scripts the window; --offscreen has none");
        }
        if !self.offscreen && given("every") {
            bail!("--every chooses the PNG frames of --offscreen, which is not given");
        }
        // The window's keys can turn --adaptive off (A) or change the shading (S); offscreen they cannot.
        let mut view = |text: String| -> anyhow::Result<()> {
            if self.offscreen {
                bail!("{text}");
            }
            notes.push(format!(
                "{text}: it takes effect once A turns --adaptive off"
            ));
            Ok(())
        };
        if self.adaptive.is_some() && self.scene == SceneKind::Cage {
            if self.vertex_pull {
                view(
                    "--vertex-pull draws uniform grids, and --adaptive draws per-patch levels"
                        .into(),
                )?;
            }
            // The checker reads the cage's UVs where it has them (known once it is loaded: the scene says
            // so when it has none); the other modes need the uniform grid whatever the cage.
            if self.shading.needs_uniform_grid(true) {
                let name = clap::ValueEnum::to_possible_value(&self.shading)
                    .map(|v| v.get_name().to_string())
                    .unwrap_or_default();
                view(format!(
                    "--shading {name} needs a uniform grid, and --adaptive draws per-patch levels \
                     (phong, normals, zebra and, with the cage's UVs, checker work with it)"
                ))?;
            }
        }
        Ok(notes)
    }
}

/// Prints this process's resident set size (`VmRSS` of /proc/self/status, KiB) and the GPU bytes allocated
/// with the objects still awaiting release, for the soak test.
fn soak_report(ctx: &Context, frame: &str) {
    eprintln!(
        "gregvox demo: soak gpu_bytes {frame} {} awaiting {}",
        ctx.allocated_bytes(),
        ctx.objects_awaiting_release()
    );
    let rss = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmRSS:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<u64>().ok())
        });
    match rss {
        Some(kib) => eprintln!("gregvox demo: soak rss_kib {frame} {kib}"),
        None => eprintln!("gregvox demo: soak rss_kib {frame} unavailable"),
    }
}

/// The sample count `asked` (1, 2, 4 or 8; others round down to a power of two) or the largest below it
/// that the device has for colour and depth attachments together.
///
/// ```
/// use ash::vk;
/// let has = vk::SampleCountFlags::TYPE_1 | vk::SampleCountFlags::TYPE_2 | vk::SampleCountFlags::TYPE_4;
/// assert_eq!(gregvox::demo::sample_count(4, has), vk::SampleCountFlags::TYPE_4);
/// assert_eq!(gregvox::demo::sample_count(8, has), vk::SampleCountFlags::TYPE_4);
/// assert_eq!(gregvox::demo::sample_count(3, has), vk::SampleCountFlags::TYPE_2);
/// assert_eq!(gregvox::demo::sample_count(1, has), vk::SampleCountFlags::TYPE_1);
/// ```
pub fn sample_count(asked: u32, device: vk::SampleCountFlags) -> vk::SampleCountFlags {
    let mut n = asked.clamp(1, 8).next_power_of_two();
    if n > asked.max(1) {
        n /= 2;
    }
    while n > 1 && !device.contains(vk::SampleCountFlags::from_raw(n)) {
        n /= 2;
    }
    vk::SampleCountFlags::from_raw(n)
}

/// The sample count the demo renders with on `ctx` for `args`.
pub fn frame_samples(ctx: &Context, args: &DemoArgs) -> vk::SampleCountFlags {
    let l = &ctx.limits;
    sample_count(
        args.msaa,
        l.framebuffer_color_sample_counts & l.framebuffer_depth_sample_counts,
    )
}

/// Parses a positive, finite pixel count.
fn parse_pixels(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(p) if p.is_finite() && p > 0.0 => Ok(p),
        _ => Err(format!("'{s}' is not a positive number of pixels")),
    }
}

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size '{s}' is not WIDTHxHEIGHT"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("width in '{s}' is not a whole number"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("height in '{s}' is not a whole number"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size '{s}' must be between 1x1 and 16384x16384"));
    }
    Ok((w, h))
}

/// Parses a `--time-step`: a finite number of seconds ≥ 0.
pub fn parse_time_step(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
        _ => Err(format!(
            "time step '{s}' is not a number of seconds ≥ 0 (e.g. 0.0166)"
        )),
    }
}

/// The demo's renderer: frames in flight, the profiler, per-slot depth images and the current scene.
pub struct Renderer {
    pub frames: Frames,
    pub profiler: Profiler,
    depth: Vec<Option<Image>>,
    /// Per slot, the multisampled colour image the scene draws into (resolved into the frame's image).
    msaa: Vec<Option<Image>>,
    /// Samples per pixel of the colour and depth targets; the scene's pipelines were built for it.
    pub samples: vk::SampleCountFlags,
    pub scene: Box<dyn Scene>,
    pub view: ViewState,
    /// Draw the overlay ([`hud`]); with the keys listed when `hud_keys`.
    pub hud: bool,
    pub hud_keys: bool,
    /// The overlay shows the frame and pass times (off: "-", the same every run, for golden frames).
    pub hud_times: bool,
    overlay: Option<hud::Hud>,
    /// Smoothed wall time between frames drawn (ms), for the overlay and the window title.
    pub frame_ms: f64,
    last_draw: Option<std::time::Instant>,
}

impl Renderer {
    /// Builds the renderer around `scene`.
    pub fn new(
        ctx: &Context,
        scene: Box<dyn Scene>,
        shading: ShadingMode,
        path: DrawPath,
    ) -> anyhow::Result<Self> {
        let frames = Frames::new(ctx, FRAMES_IN_FLIGHT)?;
        let profiler = Profiler::new(ctx, FRAMES_IN_FLIGHT, 64)?;
        let view = ViewState {
            orbit: scene.framing(),
            shading,
            animate: true,
            path,
        };
        Ok(Renderer {
            frames,
            profiler,
            depth: (0..FRAMES_IN_FLIGHT).map(|_| None).collect(),
            msaa: (0..FRAMES_IN_FLIGHT).map(|_| None).collect(),
            samples: vk::SampleCountFlags::TYPE_1,
            scene,
            view,
            hud: false,
            hud_keys: false,
            hud_times: true,
            overlay: None,
            frame_ms: 0.0,
            last_draw: None,
        })
    }

    /// Starts a frame: waits until the next slot's previous frame has completed (its pixels and timings
    /// are then final), collects its timings and starts recording. Returns the slot.
    pub fn begin_frame(&mut self, ctx: &Context) -> anyhow::Result<(usize, vk::CommandBuffer)> {
        let (slot, cmd) = self.frames.begin(ctx)?;
        self.profiler.collect(ctx, slot)?;
        Ok((slot, cmd))
    }

    fn depth_view(
        &mut self,
        ctx: &Context,
        slot: usize,
        extent: vk::Extent2D,
    ) -> anyhow::Result<&Image> {
        let stale = self.depth[slot]
            .as_ref()
            .is_some_and(|d| d.extent2d() != extent || d.samples() != self.samples);
        if stale {
            // Released through the queue; the slot's previous frame has completed (begin_frame waited).
            self.depth[slot] = None;
        }
        if self.depth[slot].is_none() {
            let mut desc = ImageDesc::d2(
                extent.width,
                extent.height,
                DEPTH_FORMAT,
                vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            );
            desc.samples = self.samples;
            self.depth[slot] = Some(ctx.create_image(&format!("demo depth {slot}"), &desc)?);
        }
        Ok(self.depth[slot].as_ref().unwrap())
    }

    /// The slot's multisampled colour image for `extent` and `format` (rebuilt when either changes), or
    /// `None` with one sample.
    fn msaa_view(
        &mut self,
        ctx: &Context,
        slot: usize,
        extent: vk::Extent2D,
        format: vk::Format,
    ) -> anyhow::Result<Option<&Image>> {
        if self.samples == vk::SampleCountFlags::TYPE_1 {
            return Ok(None);
        }
        let stale = self.msaa[slot].as_ref().is_some_and(|m| {
            m.extent2d() != extent || m.format() != format || m.samples() != self.samples
        });
        if stale {
            // Released through the queue; the slot's previous frame has completed (begin_frame waited).
            self.msaa[slot] = None;
        }
        if self.msaa[slot].is_none() {
            let mut desc = ImageDesc::d2(
                extent.width,
                extent.height,
                format,
                vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSIENT_ATTACHMENT,
            );
            desc.samples = self.samples;
            self.msaa[slot] = Some(ctx.create_image(&format!("demo msaa colour {slot}"), &desc)?);
        }
        Ok(self.msaa[slot].as_ref())
    }

    /// Records and submits the frame begun by [`Renderer::begin_frame`] at time `t` into `target`.
    /// Returns whether a frame was presented.
    pub fn draw(
        &mut self,
        ctx: &Context,
        (slot, cmd): (usize, vk::CommandBuffer),
        target: &mut dyn PresentTarget,
        t: f32,
    ) -> anyhow::Result<bool> {
        let Some(img) = target.acquire(ctx, slot)? else {
            // Nothing to draw into (minimised, or the swapchain was rebuilt): keep the slot cycling.
            self.frames.submit(ctx, &[], &[])?;
            return Ok(false);
        };
        let depth = self.depth_view(ctx, slot, img.extent)?;
        let (depth_image, depth_view, depth_range) = (depth.raw(), depth.view(), depth.range());
        begin_color_target(ctx, cmd, img.image);
        image_barrier(
            ctx,
            cmd,
            depth_image,
            depth_range,
            vk::ImageLayout::UNDEFINED,
            vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
            (
                vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
            ),
            (
                vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS
                    | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ
                    | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
            ),
        );
        let (color, resolve) = match self.msaa_view(ctx, slot, img.extent, target.format())? {
            Some(msaa) => {
                let (image, view, range) = (msaa.raw(), msaa.view(), msaa.range());
                // Its contents are undefined each frame: the scene clears it.
                image_barrier(
                    ctx,
                    cmd,
                    image,
                    range,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                    (
                        vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                        vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                    ),
                    (
                        vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT,
                        vk::AccessFlags2::COLOR_ATTACHMENT_READ
                            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE,
                    ),
                );
                (view, Some(img.view))
            }
            None => (img.view, None),
        };
        let targets = FrameTargets {
            slot,
            color,
            depth: depth_view,
            extent: img.extent,
            resolve,
        };
        let view = self.view;
        self.scene
            .record(ctx, cmd, &targets, t, &view, &mut self.profiler)?;
        let now = std::time::Instant::now();
        if let Some(last) = self.last_draw.replace(now) {
            let ms = now.duration_since(last).as_secs_f64() * 1e3;
            self.frame_ms = if self.frame_ms == 0.0 {
                ms
            } else {
                0.9 * self.frame_ms + 0.1 * ms
            };
        }
        if self.hud {
            if self.overlay.is_none() {
                self.overlay = Some(hud::Hud::new(
                    ctx,
                    ColorTarget {
                        format: target.format(),
                        samples: self.samples,
                    },
                )?);
            }
            let info = hud::HudInfo {
                scene: self.scene.name(),
                level: self.scene.level(),
                shading: format!("{:?}", view.shading),
                path: match view.path {
                    DrawPath::Compute => "compute".into(),
                    DrawPath::VertexPull => "vertex pull".into(),
                },
                animate: view.animate,
                frame_ms: self.frame_ms,
                passes: self
                    .profiler
                    .stats()
                    .into_iter()
                    .map(|p| (p.name, p.median_ms))
                    .collect(),
                keys: self.hud_keys,
                times: self.hud_times,
            };
            if let Some(overlay) = self.overlay.as_mut() {
                overlay.record(
                    ctx,
                    cmd,
                    &targets,
                    &hud::hud_lines(&info),
                    &mut self.profiler,
                )?;
            }
        }
        target.record_finish(ctx, cmd, &img);
        let waits: Vec<(vk::Semaphore, vk::PipelineStageFlags)> = img
            .acquired
            .iter()
            .map(|&s| (s, vk::PipelineStageFlags::COLOR_ATTACHMENT_OUTPUT))
            .collect();
        let signals: Vec<vk::Semaphore> = img.rendered.iter().copied().collect();
        self.frames.submit(ctx, &waits, &signals)?;
        target.present(ctx, &img)?;
        Ok(true)
    }

    /// Replaces the scene (waits for the device: the old scene's buffers may be in use) and frames it.
    pub fn replace_scene(&mut self, ctx: &Context, scene: Box<dyn Scene>) -> anyhow::Result<()> {
        self.finish(ctx)?;
        self.scene = scene;
        self.view.orbit = self.scene.framing();
        Ok(())
    }

    /// Sets the scene's tessellation level (waits for the device first); false if it has none.
    pub fn set_level(&mut self, ctx: &Context, level: u32) -> anyhow::Result<bool> {
        self.finish(ctx)?;
        self.scene.set_level(ctx, level)
    }

    /// Waits for all frames and collects their timings.
    pub fn finish(&mut self, ctx: &Context) -> anyhow::Result<()> {
        self.frames.wait_all(ctx)?;
        for slot in 0..self.frames.len() {
            self.profiler.collect(ctx, slot)?;
        }
        Ok(())
    }
}

/// The scenes of `gregvox demo`, in the order of the number keys (1 = the first). Adding a scene is a
/// variant here and an arm in [`build_scene`]; keys, golden tests and docs follow [`SceneKind::all`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneKind {
    /// The thesis flag: 2×3 Gregory patches from animated boundary curves (C toggles the correction).
    Flag,
    /// A quad cage as Gregory patches, deformed on the GPU (D cycles the deformation).
    Cage,
    /// The minimal compute → raster smoke scene.
    Spinner,
    /// The deforming cage surface voxelized on the GPU every frame, ray cast beside the surface.
    Voxels,
    /// Bézier, B-spline and NURBS curves: control polygons, de Casteljau at a moving t, curvature.
    Curves,
    /// A Beziex `.gzjson` model (`--model`) drawn by the vertex-pull path.
    Beziex,
}

impl SceneKind {
    /// Every scene, in declaration order.
    pub fn all() -> &'static [SceneKind] {
        <SceneKind as clap::ValueEnum>::value_variants()
    }

    /// The scene's `--scene` name.
    pub fn name(self) -> String {
        clap::ValueEnum::to_possible_value(&self)
            .map(|v| v.get_name().to_string())
            .unwrap_or_default()
    }
}

/// The draw path `args` asks for.
pub fn draw_path(args: &DemoArgs) -> DrawPath {
    if args.vertex_pull {
        DrawPath::VertexPull
    } else {
        DrawPath::Compute
    }
}

/// Builds the scene `args` asks for, drawing into `format` targets.
pub fn build_scene(
    ctx: &Context,
    args: &DemoArgs,
    format: impl Into<ColorTarget>,
) -> anyhow::Result<Box<dyn Scene>> {
    let format: ColorTarget = format.into();
    Ok(match args.scene {
        SceneKind::Spinner => Box::new(SpinnerScene::new(
            ctx,
            format,
            args.triangles,
            FRAMES_IN_FLIGHT,
        )?),
        SceneKind::Flag => {
            let mut s = FlagScene::new(ctx, format, 3, 2, args.level.unwrap_or(10))?;
            s.correct = !args.no_correction;
            Box::new(s)
        }
        SceneKind::Cage => cage::build(ctx, args, format)?,
        SceneKind::Voxels => voxels::build(ctx, args, format)?,
        SceneKind::Curves => curves::build(ctx, format)?,
        SceneKind::Beziex => beziex::build(ctx, args, format)?,
    })
}

/// Runs `gregvox demo`.
pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
    for note in args.check_scene_options()? {
        eprintln!("gregvox demo: note: {note}");
    }
    // Outputs before any work. The offscreen folder is made once the scene stands, so profile outputs
    // inside it are checked as part of it.
    let frames_dir = args.out.as_deref().unwrap_or("out/demo".as_ref());
    if args.offscreen {
        crate::io::check_output_folder(frames_dir)?;
    }
    for path in args.profile.profile_json.iter().chain(&args.profile.trace) {
        match path
            .parent()
            .filter(|p| !p.as_os_str().is_empty() && !p.exists())
        {
            Some(folder) if args.offscreen && folder.starts_with(frames_dir) => {
                crate::io::check_output_folder(folder)?
            }
            _ => crate::io::check_output(path)?,
        }
    }
    if args.offscreen {
        run_offscreen(args)
    } else {
        window::run_windowed(args)
    }
}

fn run_offscreen(args: &DemoArgs) -> anyhow::Result<()> {
    let frames = args.frames.unwrap_or(60);
    if frames == 0 {
        bail!("--frames must be at least 1");
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("out/demo"));
    let ctx = Context::with_desc(&ContextDesc::default())?;
    let (w, h) = args.size;
    let mut target = OffscreenTarget::new(&ctx, w, h, FRAMES_IN_FLIGHT)?;
    let samples = frame_samples(&ctx, args);
    let scene = build_scene(
        &ctx,
        args,
        ColorTarget {
            format: target.format(),
            samples,
        },
    )?;
    let mut renderer = Renderer::new(&ctx, scene, args.shading, draw_path(args))?;
    renderer.samples = samples;
    renderer.hud = args.hud;
    // Only once the scene stands: a refused model or option leaves no empty output folder behind.
    std::fs::create_dir_all(&out)
        .with_context(|| format!("cannot create the output folder {}", out.display()))?;
    let dt = args.time_step.unwrap_or(1.0 / 60.0);
    let result = offscreen_loop(
        &ctx,
        &mut renderer,
        &mut target,
        (frames, dt, args.soak_report),
        args.every,
        &out,
    );
    let report = renderer.finish(&ctx).and(result).and_then(|written| {
        args.profile.emit(&renderer.profiler)?;
        eprintln!(
            "gregvox demo: {frames} frames rendered offscreen, {written} PNG file(s) in {}",
            out.display()
        );
        Ok(())
    });
    // `renderer`, `target` and `ctx` drop here, in that order (the module invariant).
    report
}

fn offscreen_loop(
    ctx: &Context,
    renderer: &mut Renderer,
    target: &mut OffscreenTarget,
    (frames, dt, soak_at): (u64, f32, Option<u64>),
    every: u64,
    out: &std::path::Path,
) -> anyhow::Result<u64> {
    let mut pending: Vec<Option<u64>> = vec![None; FRAMES_IN_FLIGHT];
    let mut written = 0;
    let mut save = |target: &OffscreenTarget,
                    slot: usize,
                    pending: &mut Vec<Option<u64>>|
     -> anyhow::Result<()> {
        if let Some(f) = pending[slot].take() {
            if target.has_frame(slot) {
                target.write_png(slot, &out.join(format!("frame_{f:05}.png")))?;
                written += 1;
            }
        }
        Ok(())
    };
    for f in 0..frames {
        // Fixed time step: offscreen frames are reproducible whatever the machine's speed.
        let t = f as f32 * dt;
        let begun = renderer.begin_frame(ctx)?;
        save(target, begun.0, &mut pending)?;
        renderer.draw(ctx, begun, target, t)?;
        if f + 1 == frames || (every > 0 && f % every == 0) {
            pending[begun.0] = Some(f);
        }
        if soak_at == Some(f + 1) {
            soak_report(ctx, "warm");
        }
    }
    renderer.frames.wait_all(ctx)?;
    for slot in 0..FRAMES_IN_FLIGHT {
        save(target, slot, &mut pending)?;
    }
    if soak_at.is_some() {
        soak_report(ctx, "end");
    }
    Ok(written)
}

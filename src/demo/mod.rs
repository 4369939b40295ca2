//! `gregvox demo`: a window (winit + swapchain) or an offscreen image ring writing PNG frames, driven by the
//! same renderer and frame loop; every GPU pass runs in a profiler scope.
//!
//! Invariants: the context outlives everything here; at exit the frame loop waits for the device, then the
//! renderer, the present target and the window are destroyed, in that order, before the context drops.
//! The offscreen ring has one image per frame slot, so a frame's PNG is written when its slot comes round
//! again (after that slot's fence) or at the end.
use crate::cli::profile::ProfileArgs;
use crate::gpu::present::begin_color_target;
use crate::gpu::{
    Buffer, Context, ContextDesc, Frames, MemoryLocation, OffscreenTarget, PresentTarget, Profiler,
};
use crate::passes::spinner::SpinnerPass;
use crate::passes::triangles::TrianglesPass;
use anyhow::{bail, Context as _};
use ash::vk;
use clap::Args;
use std::path::PathBuf;

mod window;

/// Frames in flight.
pub const FRAMES_IN_FLIGHT: usize = 2;

/// Arguments of `gregvox demo`.
#[derive(Debug, Args)]
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
    /// Number of triangles in the spinner scene.
    #[arg(long, default_value_t = 48)]
    pub triangles: u32,
    #[command(flatten)]
    pub profile: ProfileArgs,
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

/// The demo's renderer: per-slot vertex buffers written by compute and drawn by graphics.
pub struct Renderer {
    pub frames: Frames,
    pub profiler: Profiler,
    spinner: SpinnerPass,
    triangles: TrianglesPass,
    vertex_buffers: Vec<Buffer>,
    count: u32,
}

impl Renderer {
    /// Builds the passes for targets of `format`.
    pub fn new(ctx: &Context, format: vk::Format, count: u32) -> anyhow::Result<Self> {
        let count = count.clamp(1, 1 << 20);
        let frames = Frames::new(ctx, FRAMES_IN_FLIGHT)?;
        let profiler = Profiler::new(ctx, FRAMES_IN_FLIGHT, 32)?;
        let spinner = SpinnerPass::new(ctx)?;
        let triangles = TrianglesPass::new(ctx, format)?;
        let mut r = Renderer {
            frames,
            profiler,
            spinner,
            triangles,
            vertex_buffers: Vec::new(),
            count,
        };
        for i in 0..FRAMES_IN_FLIGHT {
            // One buffer per slot: frame N+1's compute must not overwrite what frame N still draws.
            match ctx.create_buffer(
                &format!("spinner vertices {i}"),
                count as u64 * 48,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::VERTEX_BUFFER,
                MemoryLocation::GpuOnly,
            ) {
                Ok(b) => r.vertex_buffers.push(b),
                Err(e) => {
                    r.destroy(ctx);
                    return Err(e.into());
                }
            }
        }
        Ok(r)
    }

    /// Starts a frame: waits until the next slot's previous frame has completed (its pixels and timings
    /// are then final), collects its timings and starts recording. Returns the slot.
    pub fn begin_frame(&mut self, ctx: &Context) -> anyhow::Result<(usize, vk::CommandBuffer)> {
        let (slot, cmd) = self.frames.begin(ctx)?;
        self.profiler.collect(ctx, slot)?;
        Ok((slot, cmd))
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
        let aspect = img.extent.width as f32 / img.extent.height.max(1) as f32;
        let vb = &self.vertex_buffers[slot];
        let s = self.profiler.begin(ctx, cmd, slot, "spinner (compute)");
        self.spinner.record(ctx, cmd, vb, self.count, t, aspect)?;
        self.profiler.end(ctx, cmd, s);
        begin_color_target(ctx, cmd, img.image);
        let s = self.profiler.begin(ctx, cmd, slot, "triangles (raster)");
        self.triangles.record(
            ctx,
            cmd,
            img.view,
            img.extent,
            [0.02, 0.02, 0.04, 1.0],
            vb,
            self.count * 3,
            None,
        );
        self.profiler.end(ctx, cmd, s);
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

    /// Waits for all frames and collects their timings.
    pub fn finish(&mut self, ctx: &Context) -> anyhow::Result<()> {
        self.frames.wait_all(ctx)?;
        for slot in 0..self.frames.len() {
            self.profiler.collect(ctx, slot)?;
        }
        Ok(())
    }

    /// Destroys everything (waits for the device first).
    pub fn destroy(self, ctx: &Context) {
        let _ = ctx.wait_idle();
        self.frames.destroy(ctx);
        for b in self.vertex_buffers {
            b.destroy(ctx);
        }
        self.spinner.destroy(ctx);
        self.triangles.destroy(ctx);
        self.profiler.destroy(ctx);
    }
}

/// Runs `gregvox demo`.
pub fn run(args: &DemoArgs) -> anyhow::Result<()> {
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
    std::fs::create_dir_all(&out)
        .with_context(|| format!("cannot create the output folder {}", out.display()))?;
    let ctx = Context::with_desc(&ContextDesc::default())?;
    let (w, h) = args.size;
    let mut target = OffscreenTarget::new(&ctx, w, h, FRAMES_IN_FLIGHT)?;
    let mut renderer = match Renderer::new(&ctx, target.format(), args.triangles) {
        Ok(r) => r,
        Err(e) => {
            Box::new(target).destroy(&ctx);
            return Err(e);
        }
    };
    let result = offscreen_loop(&ctx, &mut renderer, &mut target, frames, args.every, &out);
    let report = renderer.finish(&ctx).and(result).and_then(|written| {
        args.profile.emit(&renderer.profiler)?;
        eprintln!(
            "gregvox demo: {frames} frames rendered offscreen, {written} PNG file(s) in {}",
            out.display()
        );
        Ok(())
    });
    renderer.destroy(&ctx);
    Box::new(target).destroy(&ctx);
    report
}

fn offscreen_loop(
    ctx: &Context,
    renderer: &mut Renderer,
    target: &mut OffscreenTarget,
    frames: u64,
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
        let t = f as f32 / 60.0;
        let begun = renderer.begin_frame(ctx)?;
        save(target, begun.0, &mut pending)?;
        renderer.draw(ctx, begun, target, t)?;
        if f + 1 == frames || (every > 0 && f % every == 0) {
            pending[begun.0] = Some(f);
        }
    }
    renderer.frames.wait_all(ctx)?;
    for slot in 0..FRAMES_IN_FLIGHT {
        save(target, slot, &mut pending)?;
    }
    Ok(written)
}

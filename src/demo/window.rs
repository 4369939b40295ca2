//! The windowed demo loop (winit 0.30 `ApplicationHandler` + [`SwapchainTarget`]).
//!
//! Invariants: the context is created before the event loop runs, with the surface extensions the display
//! needs; the window and swapchain are created in `resumed`; resize and minimise go to the target, which
//! rebuilds or skips frames; after the loop ends, renderer → swapchain → window are destroyed before the
//! context. An error inside the loop stops it and is returned from [`run_windowed`].
use super::{DemoArgs, Renderer};
use crate::gpu::{Context, ContextDesc, PresentTarget, SwapchainTarget};
use anyhow::Context as _;
use ash::vk;
use std::ffi::CStr;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

struct App<'a> {
    ctx: &'a Context,
    args: &'a DemoArgs,
    window: Option<Window>,
    target: Option<SwapchainTarget>,
    renderer: Option<Renderer>,
    frames_drawn: u64,
    start: Instant,
    last_title: Instant,
    last_frame: Instant,
    frame_ms: f64,
    error: Option<anyhow::Error>,
}

impl App<'_> {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    fn create(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let (w, h) = self.args.size;
        let attrs = Window::default_attributes()
            .with_title("gregvox")
            .with_inner_size(winit::dpi::PhysicalSize::new(w, h));
        let window = event_loop
            .create_window(attrs)
            .context("cannot create a window")?;
        let size = window.inner_size();
        let display = window
            .display_handle()
            .context("no display handle")?
            .as_raw();
        let handle = window.window_handle().context("no window handle")?.as_raw();
        let target = SwapchainTarget::new(
            self.ctx,
            display,
            handle,
            size.width,
            size.height,
            super::FRAMES_IN_FLIGHT,
            true,
        )?;
        let renderer = match super::build_scene(self.ctx, self.args, target.format())
            .and_then(|scene| Renderer::new(self.ctx, scene, self.args.shading))
        {
            Ok(r) => r,
            Err(e) => {
                Box::new(target).destroy(self.ctx);
                return Err(e);
            }
        };
        self.window = Some(window);
        self.target = Some(target);
        self.renderer = Some(renderer);
        Ok(())
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let (Some(renderer), Some(target)) = (self.renderer.as_mut(), self.target.as_mut()) else {
            return Ok(());
        };
        let t = self.start.elapsed().as_secs_f32();
        let begun = renderer.begin_frame(self.ctx)?;
        if renderer.draw(self.ctx, begun, target, t)? {
            self.frames_drawn += 1;
        }
        let now = Instant::now();
        let dt = now.duration_since(self.last_frame).as_secs_f64() * 1e3;
        self.last_frame = now;
        self.frame_ms = if self.frame_ms == 0.0 {
            dt
        } else {
            0.9 * self.frame_ms + 0.1 * dt
        };
        if now.duration_since(self.last_title).as_secs_f64() > 0.5 {
            self.last_title = now;
            let mut title = format!("gregvox — {:.2} ms/frame", self.frame_ms);
            for p in renderer.profiler.stats() {
                title.push_str(&format!(" | {} {:.3} ms", p.name, p.median_ms));
            }
            if let Some(w) = &self.window {
                w.set_title(&title);
            }
        }
        if self.args.frames.is_some_and(|n| self.frames_drawn >= n) {
            event_loop.exit();
        }
        Ok(())
    }
}

impl ApplicationHandler for App<'_> {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            if let Err(e) = self.create(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key: Key::Named(NamedKey::Escape),
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => event_loop.exit(),
            WindowEvent::Resized(size) => {
                if let Some(t) = self.target.as_mut() {
                    t.resize(vk::Extent2D {
                        width: size.width,
                        height: size.height,
                    });
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.redraw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}

/// Runs the demo in a window until it is closed (or `--frames` frames were presented).
pub fn run_windowed(args: &DemoArgs) -> anyhow::Result<()> {
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow::anyhow!(
            "no display to open a window on ({e}); run `gregvox demo --offscreen` instead"
        )
    })?;
    let display = event_loop
        .display_handle()
        .context("no display handle")?
        .as_raw();
    let extensions = ash_window::enumerate_required_extensions(display).map_err(|r| {
        anyhow::anyhow!("this display needs surface extensions the Vulkan loader lacks: {r}")
    })?;
    // SAFETY: ash-window returns pointers to static, NUL-terminated extension names.
    let surface_extensions: Vec<&'static CStr> = extensions
        .iter()
        .map(|&p| unsafe { CStr::from_ptr(p) })
        .collect();
    let ctx = Context::with_desc(&ContextDesc {
        surface_extensions,
        ..Default::default()
    })?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let now = Instant::now();
    let mut app = App {
        ctx: &ctx,
        args,
        window: None,
        target: None,
        renderer: None,
        frames_drawn: 0,
        start: now,
        last_title: now,
        last_frame: now,
        frame_ms: 0.0,
        error: None,
    };
    let run = event_loop.run_app(&mut app);
    let mut result = run.map_err(anyhow::Error::from);
    if let Some(e) = app.error.take() {
        result = Err(e);
    }
    if let Some(mut r) = app.renderer.take() {
        let finished = r.finish(&ctx).and_then(|()| args.profile.emit(&r.profiler));
        r.destroy(&ctx);
        if result.is_ok() {
            result = finished;
        }
    }
    if let Some(t) = app.target.take() {
        Box::new(t).destroy(&ctx);
    }
    drop(app.window.take());
    if result.is_ok() {
        eprintln!("gregvox demo: {} frames presented", app.frames_drawn);
    }
    result
}

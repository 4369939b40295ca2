//! The windowed demo loop (winit 0.30 `ApplicationHandler` + [`SwapchainTarget`]) and its controls.
//!
//! Invariants: the context is created before the event loop runs, with the surface extensions the display
//! needs; the window and swapchain are created in `resumed`; resize and minimise go to the target, which
//! rebuilds or skips frames; after the loop ends, renderer → swapchain → window are dropped, in that order,
//! before the context. An error inside the loop stops it and is returned from [`run_windowed`].
//! Keys are handled in two steps so the mapping is testable without a window: [`key_action`] is a pure
//! function of (key name, [`Controls`]) → [`Action`], and `App::apply` carries the action out. Adding a key
//! (e.g. the adaptive level, A) is one arm in `key_action` plus, for a new kind of action, one arm in `apply`.
//! The mouse the same way: [`pick`] and [`unproject`] are pure functions of the camera and the cursor, and
//! the press/move/release handlers serve real events and scripted ones (`press:X:Y` in `--keys`) alike. A
//! press within [`PICK_RADIUS`] of a handle the scene shows (`Scene::handles`: the paused cage's vertices)
//! holds it; moves keep it at its picked NDC depth (the plane parallel to the view); the release is one
//! undo step. The scene records the edited cage into the next frame's command buffer, so frames in flight
//! keep theirs.
//! Cost: a press projects every handle, O(handles); a move sets them all again (`set_handles` takes the
//! whole list, so undo and reset are the same call), and the next frame uploads the scene's whole cage or
//! corner list (`vkCmdUpdateBuffer`, 16 bytes a vertex: 47 KB for the 2,930-vertex quad Spot, 16 MB a
//! frame for a million-vertex cage, where a staging copy would be the better tool). Nothing is done per
//! pixel or per patch on the CPU.
use super::scene::DrawPath;
use super::{DemoArgs, Renderer, SceneKind};
use crate::gpu::{Context, ContextDesc, PresentTarget, SwapchainTarget};
use crate::passes::draw::ColorTarget;
use crate::passes::gregory_eval::MAX_LEVEL;
use crate::passes::surface_draw::ShadingMode;
use anyhow::Context as _;
use ash::vk;
use std::ffi::CStr;
use std::path::PathBuf;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::window::{Window, WindowId};

/// What the key handler needs to know of the viewer's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Controls {
    pub scene: SceneKind,
    /// The scene's tessellation level, if it has one.
    pub level: Option<u32>,
    pub shading: ShadingMode,
    pub animate: bool,
    pub path: DrawPath,
}

/// What a key asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    Quit,
    /// Rebuild the scene in place (number keys, in [`SceneKind::all`] order).
    SwitchScene(SceneKind),
    /// Tessellation level (+/−).
    SetLevel(u32),
    /// Deformation / animation on or off (space).
    SetAnimate(bool),
    /// Compute evaluation or vertex pull (V).
    SetPath(DrawPath),
    /// Next shading mode (S).
    SetShading(ShadingMode),
    /// Write the next frame as a PNG (P).
    Screenshot,
    /// Print the per-pass GPU time table (T).
    PrintProfile,
    /// Undo the last drag (Z).
    Undo,
    /// Put every dragged handle back where the scene started (R).
    Reset,
    /// Write the edited cage as `gregvox-cage-NNN.obj` (W).
    WriteCage,
    /// Show or hide the overlay (H).
    ToggleHud,
    /// A key the scene itself may use (C: flag correction, D: cage deformation, …), lower case.
    SceneKey(String),
}

/// The action of `key` (a logical key name: the character typed, "Space" or "Escape") in state `c`;
/// `None` when the key does nothing there (a level already at its bound, the current scene's number).
///
/// ```
/// use gregvox::demo::window::{key_action, Action, Controls};
/// use gregvox::demo::{scene::DrawPath, SceneKind};
/// use gregvox::passes::surface_draw::ShadingMode;
/// let c = Controls { scene: SceneKind::Flag, level: Some(10), shading: ShadingMode::Phong,
///                    animate: true, path: DrawPath::Compute };
/// assert_eq!(key_action("+", &c), Some(Action::SetLevel(11)));
/// assert_eq!(key_action("s", &c), Some(Action::SetShading(ShadingMode::Normals)));
/// ```
pub fn key_action(key: &str, c: &Controls) -> Option<Action> {
    let lower = key.to_lowercase();
    match lower.as_str() {
        "escape" | "q" => Some(Action::Quit),
        "+" | "=" => c
            .level
            .filter(|&l| l < MAX_LEVEL)
            .map(|l| Action::SetLevel(l + 1)),
        "-" | "_" => c.level.filter(|&l| l > 1).map(|l| Action::SetLevel(l - 1)),
        "space" | " " => Some(Action::SetAnimate(!c.animate)),
        "v" => Some(Action::SetPath(match c.path {
            DrawPath::Compute => DrawPath::VertexPull,
            DrawPath::VertexPull => DrawPath::Compute,
        })),
        "s" => Some(Action::SetShading(c.shading.next())),
        "p" => Some(Action::Screenshot),
        "t" => Some(Action::PrintProfile),
        "z" => Some(Action::Undo),
        "r" => Some(Action::Reset),
        "w" => Some(Action::WriteCage),
        "h" => Some(Action::ToggleHud),
        k if k.len() == 1 && k.as_bytes()[0].is_ascii_digit() => {
            let n = (k.as_bytes()[0] - b'0') as usize;
            let kind = *SceneKind::all().get(n.checked_sub(1)?)?;
            (kind != c.scene).then_some(Action::SwitchScene(kind))
        }
        k if k.chars().count() == 1 && k.chars().all(|ch| ch.is_alphabetic()) => {
            Some(Action::SceneKey(k.to_string()))
        }
        _ => None,
    }
}

/// A scripted window operation (`--keys` entries that are not keys), so CI exercises the swapchain paths a
/// user triggers with the mouse or the window manager.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WindowAction {
    /// `resize:WxH`: ask for this inner size (the swapchain is rebuilt at the size the window gets).
    Resize(u32, u32),
    /// `minimize`: minimise; frames are skipped until `restore`.
    Minimize,
    /// `restore`: back from minimised.
    Restore,
}

/// The window operation a scripted entry names, if it names one.
///
/// ```
/// use gregvox::demo::window::{window_action, WindowAction};
/// assert_eq!(window_action("resize:400x300"), Some(WindowAction::Resize(400, 300)));
/// assert_eq!(window_action("minimize"), Some(WindowAction::Minimize));
/// assert_eq!(window_action("resize:0x300"), None);
/// assert_eq!(window_action("s"), None);
/// ```
pub fn window_action(entry: &str) -> Option<WindowAction> {
    match entry.to_ascii_lowercase().as_str() {
        "minimize" | "minimise" => Some(WindowAction::Minimize),
        "restore" => Some(WindowAction::Restore),
        e => {
            let (w, h) = e.strip_prefix("resize:")?.split_once('x')?;
            let (w, h) = (w.parse().ok()?, h.parse().ok()?);
            (w > 0 && h > 0).then_some(WindowAction::Resize(w, h))
        }
    }
}

/// A scripted mouse operation (`--keys` entries `press:X:Y`, `move:X:Y`, `release`: the left button, at
/// window pixels; `wheel:N`), carried out by the same handlers as the real events.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MouseAction {
    Press(f64, f64),
    Move(f64, f64),
    Release,
    /// `wheel:N`: N notches (positive: away from the user, closer / heavier).
    Wheel(f32),
}

/// The mouse operation a scripted entry names, if it names one.
///
/// ```
/// use gregvox::demo::window::{mouse_action, MouseAction};
/// assert_eq!(mouse_action("press:120:80"), Some(MouseAction::Press(120.0, 80.0)));
/// assert_eq!(mouse_action("move:130.5:60"), Some(MouseAction::Move(130.5, 60.0)));
/// assert_eq!(mouse_action("release"), Some(MouseAction::Release));
/// assert_eq!(mouse_action("wheel:-2"), Some(MouseAction::Wheel(-2.0)));
/// assert_eq!(mouse_action("press:1"), None);
/// assert_eq!(mouse_action("p"), None);
/// ```
pub fn mouse_action(entry: &str) -> Option<MouseAction> {
    let entry = entry.to_ascii_lowercase();
    if entry == "release" {
        return Some(MouseAction::Release);
    }
    if let Some(n) = entry.strip_prefix("wheel:") {
        let n: f32 = n.parse().ok()?;
        return n.is_finite().then_some(MouseAction::Wheel(n));
    }
    let (kind, rest) = entry.split_once(':')?;
    let (x, y) = rest.split_once(':')?;
    let (x, y): (f64, f64) = (x.parse().ok()?, y.parse().ok()?);
    if !(x.is_finite() && y.is_finite()) {
        return None;
    }
    match kind {
        "press" => Some(MouseAction::Press(x, y)),
        "move" => Some(MouseAction::Move(x, y)),
        _ => None,
    }
}

/// How close (window pixels) a press must come to a handle's projection to pick it.
pub const PICK_RADIUS: f64 = 12.0;

/// The handle a press at `cursor` (window pixels) picks: the nearest projection within [`PICK_RADIUS`]
/// of the handles in front of the camera, the one nearer the eye among projections equally close (to a
/// tenth of a pixel). Returns its index and its depth (NDC z), which the drag keeps.
///
/// ```
/// use gregvox::demo::window::pick;
/// use glam::{Mat4, Vec3};
/// let vp = Mat4::IDENTITY; // NDC = world: x, y in −1…1 map to a 200×100 window
/// let handles = [Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.5, 0.5, 0.5)];
/// assert_eq!(pick(&handles, &vp, [200.0, 100.0], (151.0, 74.0)).map(|h| h.0), Some(1));
/// assert_eq!(pick(&handles, &vp, [200.0, 100.0], (40.0, 10.0)), None);
/// ```
pub fn pick(
    handles: &[glam::Vec3],
    view_proj: &glam::Mat4,
    viewport: [f64; 2],
    cursor: (f64, f64),
) -> Option<(usize, f32)> {
    let mut best: Option<(f64, f32, usize)> = None;
    for (i, p) in handles.iter().enumerate() {
        let c = *view_proj * p.extend(1.0);
        if c.w <= 0.0 {
            continue;
        }
        let ndc = c.truncate() / c.w;
        if !(0.0..=1.0).contains(&ndc.z) {
            continue;
        }
        let x = (ndc.x as f64 + 1.0) * 0.5 * viewport[0];
        let y = (ndc.y as f64 + 1.0) * 0.5 * viewport[1];
        let d = (x - cursor.0).hypot(y - cursor.1);
        if d > PICK_RADIUS {
            continue;
        }
        let better = match best {
            None => true,
            Some((bd, bz, _)) => d < bd - 0.1 || (d <= bd + 0.1 && ndc.z < bz),
        };
        if better {
            best = Some((d, ndc.z, i));
        }
    }
    best.map(|(_, z, i)| (i, z))
}

/// The world point under `cursor` (window pixels) at NDC depth `z`: a dragged handle stays in the plane
/// parallel to the view through where it was picked.
///
/// ```
/// use gregvox::demo::window::unproject;
/// use glam::{Mat4, Vec3};
/// let vp = Mat4::perspective_rh(0.8, 2.0, 0.1, 10.0) * Mat4::look_at_rh(Vec3::Z * 3.0, Vec3::ZERO, Vec3::Y);
/// let p = Vec3::new(0.3, -0.2, 0.4);
/// let c = vp * p.extend(1.0);
/// let ndc = c.truncate() / c.w;
/// let cursor = ((ndc.x as f64 + 1.0) * 100.0, (ndc.y as f64 + 1.0) * 50.0);
/// assert!((unproject(&vp, [200.0, 100.0], cursor, ndc.z) - p).length() < 1e-4);
/// ```
pub fn unproject(
    view_proj: &glam::Mat4,
    viewport: [f64; 2],
    cursor: (f64, f64),
    z: f32,
) -> glam::Vec3 {
    let ndc = glam::Vec3::new(
        (2.0 * cursor.0 / viewport[0] - 1.0) as f32,
        (2.0 * cursor.1 / viewport[1] - 1.0) as f32,
        z,
    );
    view_proj.inverse().project_point3(ndc)
}

/// A handle being dragged.
struct Held {
    index: usize,
    /// NDC depth where it was picked.
    depth: f32,
    /// Every handle before the drag (the undo entry).
    before: Vec<glam::Vec3>,
}

/// The name [`key_action`] expects for a winit logical key.
fn key_name(key: &Key) -> Option<String> {
    match key {
        Key::Character(s) => Some(s.to_string()),
        Key::Named(NamedKey::Space) => Some("Space".into()),
        Key::Named(NamedKey::Escape) => Some("Escape".into()),
        _ => None,
    }
}

struct App<'a> {
    ctx: &'a Context,
    args: DemoArgs,
    window: Option<Window>,
    target: Option<SwapchainTarget>,
    renderer: Option<Renderer>,
    frames_drawn: u64,
    start: Instant,
    last_title: Instant,
    left_down: bool,
    /// The last cursor position (window pixels).
    cursor: (f64, f64),
    /// The handle the left button holds (instead of orbiting).
    held: Option<Held>,
    /// Handles before each finished drag, the latest last (Z).
    undo: Vec<Vec<glam::Vec3>>,
    /// The scene's handles before its first drag (R).
    original: Option<Vec<glam::Vec3>>,
    cages_written: u32,
    /// Where the next screenshot goes, once its frame has been captured.
    screenshot: Option<PathBuf>,
    screenshots_taken: u32,
    /// Keys still to press (--keys).
    scripted: std::collections::VecDeque<String>,
    /// A size asked for by a scripted resize, reported once a frame is presented at it.
    resize_pending: Option<(u32, u32)>,
    /// Frames skipped while minimised.
    skipped: u64,
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
        let samples = super::frame_samples(self.ctx, &self.args);
        let scene = super::build_scene(
            self.ctx,
            &self.args,
            ColorTarget {
                format: target.format(),
                samples,
            },
        )?;
        let mut renderer = Renderer::new(
            self.ctx,
            scene,
            self.args.shading,
            super::draw_path(&self.args),
        )?;
        renderer.samples = samples;
        // The window shows the overlay with the keys from the start (H hides it).
        renderer.hud = true;
        renderer.hud_keys = true;
        self.window = Some(window);
        self.target = Some(target);
        self.renderer = Some(renderer);
        Ok(())
    }

    fn window_action(&mut self, action: WindowAction) {
        let (Some(window), Some(target)) = (self.window.as_ref(), self.target.as_mut()) else {
            return;
        };
        match action {
            WindowAction::Resize(w, h) => {
                self.resize_pending = Some((w, h));
                // Some platforms apply the size at once (no Resized event follows), others report it.
                if let Some(size) = window.request_inner_size(winit::dpi::PhysicalSize::new(w, h)) {
                    target.resize(vk::Extent2D {
                        width: size.width,
                        height: size.height,
                    });
                }
            }
            WindowAction::Minimize => {
                window.set_minimized(true);
                // Windows reports a minimised window as 0×0; X11 without a window manager has no minimised
                // state at all. Telling the target directly takes the same path everywhere.
                target.resize(vk::Extent2D::default());
            }
            WindowAction::Restore => {
                window.set_minimized(false);
                let size = window.inner_size();
                target.resize(vk::Extent2D {
                    width: size.width,
                    height: size.height,
                });
            }
        }
    }

    fn controls(&self) -> Option<Controls> {
        let r = self.renderer.as_ref()?;
        Some(Controls {
            scene: self.args.scene,
            level: r.scene.level(),
            shading: r.view.shading,
            animate: r.view.animate,
            path: r.view.path,
        })
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) -> anyhow::Result<()> {
        match key_name(key) {
            Some(name) => self.key_named(event_loop, &name),
            None => Ok(()),
        }
    }

    fn key_named(&mut self, event_loop: &ActiveEventLoop, name: &str) -> anyhow::Result<()> {
        let Some(controls) = self.controls() else {
            return Ok(());
        };
        if let Some(action) = key_action(name, &controls) {
            self.apply(event_loop, action)?;
        }
        Ok(())
    }

    fn apply(&mut self, event_loop: &ActiveEventLoop, action: Action) -> anyhow::Result<()> {
        let ctx = self.ctx;
        let (Some(renderer), Some(target)) = (self.renderer.as_mut(), self.target.as_mut()) else {
            return Ok(());
        };
        match action {
            Action::Quit => event_loop.exit(),
            Action::SwitchScene(kind) => {
                let mut args = self.args.clone();
                args.scene = kind;
                // Levels and models are per scene: a new scene starts from its own defaults.
                args.level = None;
                renderer.finish(ctx)?;
                // A scene that cannot be built (e.g. one that needs --model) leaves the current one on.
                let format = ColorTarget {
                    format: target.format(),
                    samples: renderer.samples,
                };
                match super::build_scene(ctx, &args, format) {
                    Ok(scene) => {
                        renderer.replace_scene(ctx, scene)?;
                        self.args.scene = kind;
                        self.held = None;
                        self.undo.clear();
                        self.original = None;
                        eprintln!("gregvox demo: scene {}", renderer.scene.name());
                    }
                    Err(e) => eprintln!("gregvox demo: cannot switch to {}: {e:#}", kind.name()),
                }
            }
            Action::SetLevel(level) => {
                if renderer.set_level(ctx, level)? {
                    eprintln!("gregvox demo: level {level}");
                }
            }
            Action::SetAnimate(on) => renderer.view.animate = on,
            Action::SetPath(path) => {
                renderer.view.path = path;
                eprintln!("gregvox demo: {path:?} path");
            }
            Action::SetShading(mode) => {
                renderer.view.shading = mode;
                eprintln!("gregvox demo: shading {mode:?}");
            }
            Action::Screenshot => {
                target.request_capture(ctx)?;
                let dir = self.args.out.clone().unwrap_or_else(|| PathBuf::from("."));
                std::fs::create_dir_all(&dir).with_context(|| {
                    format!("cannot create the screenshot folder {}", dir.display())
                })?;
                self.screenshots_taken += 1;
                self.screenshot = Some(dir.join(format!(
                    "gregvox-screenshot-{:03}.png",
                    self.screenshots_taken
                )));
            }
            Action::PrintProfile => eprint!("{}", renderer.profiler.table()),
            Action::Undo => match self.undo.pop() {
                Some(before) => {
                    renderer.scene.set_handles(&before, None)?;
                    eprintln!("gregvox demo: undo ({} left)", self.undo.len());
                }
                None => eprintln!("gregvox demo: nothing to undo"),
            },
            Action::Reset => {
                if let Some(original) = self.original.clone() {
                    let now = renderer.scene.handles(&renderer.view);
                    if now.len() == original.len() {
                        self.undo.push(now);
                    }
                    renderer.scene.set_handles(&original, None)?;
                    eprintln!("gregvox demo: reset");
                }
            }
            Action::ToggleHud => {
                renderer.hud = !renderer.hud;
                eprintln!(
                    "gregvox demo: overlay {}",
                    if renderer.hud { "on" } else { "off" }
                );
            }
            Action::WriteCage => match renderer.scene.edited_cage() {
                Some(cage) => {
                    let dir = self.args.out.clone().unwrap_or_else(|| PathBuf::from("."));
                    std::fs::create_dir_all(&dir).with_context(|| {
                        format!("cannot create the output folder {}", dir.display())
                    })?;
                    self.cages_written += 1;
                    let path = dir.join(format!("gregvox-cage-{:03}.obj", self.cages_written));
                    crate::mesh::write_obj(&path, &cage)?;
                    eprintln!("gregvox demo: cage written to {}", path.display());
                }
                None => eprintln!("gregvox demo: this scene has no cage to write"),
            },
            Action::SceneKey(k) => {
                renderer.scene.key(ctx, &k)?;
            }
        }
        Ok(())
    }

    /// The camera and viewport the cursor is read against (the current frame's).
    fn camera(&self) -> Option<(glam::Mat4, [f64; 2])> {
        let (r, t) = (self.renderer.as_ref()?, self.target.as_ref()?);
        let e = t.extent();
        if e.width == 0 || e.height == 0 {
            return None;
        }
        let aspect = e.width as f32 / e.height as f32;
        Some((
            r.view.orbit.view_proj(aspect),
            [e.width as f64, e.height as f64],
        ))
    }

    /// Left button down at `cursor`: picks a handle of the scene if one is near, else starts an orbit.
    fn mouse_press(&mut self, cursor: (f64, f64)) -> anyhow::Result<()> {
        self.left_down = true;
        self.cursor = cursor;
        let (Some((view_proj, viewport)), Some(r)) = (self.camera(), self.renderer.as_mut()) else {
            return Ok(());
        };
        let handles = r.scene.handles(&r.view);
        if let Some((index, depth)) = pick(&handles, &view_proj, viewport, cursor) {
            if self.original.is_none() {
                self.original = Some(handles.clone());
            }
            r.scene.set_handles(&handles, Some(index))?;
            eprintln!(
                "gregvox demo: picked handle {index} at {:.1} {:.1}",
                cursor.0, cursor.1
            );
            self.held = Some(Held {
                index,
                depth,
                before: handles,
            });
        }
        Ok(())
    }

    /// The cursor moved to `cursor`: drags the held handle in its view plane, or orbits.
    fn mouse_move(&mut self, cursor: (f64, f64)) -> anyhow::Result<()> {
        let last = self.cursor;
        self.cursor = cursor;
        if !self.left_down {
            return Ok(());
        }
        let camera = self.camera();
        let Some(r) = self.renderer.as_mut() else {
            return Ok(());
        };
        match (&self.held, camera) {
            (Some(h), Some((view_proj, viewport))) => {
                let mut handles = r.scene.handles(&r.view);
                if handles.len() == h.before.len() {
                    handles[h.index] = unproject(&view_proj, viewport, cursor, h.depth);
                    r.scene.set_handles(&handles, Some(h.index))?;
                }
            }
            (Some(_), None) => {}
            (None, _) => {
                r.view.orbit = r
                    .view
                    .orbit
                    .dragged((cursor.0 - last.0) as f32, (cursor.1 - last.1) as f32);
            }
        }
        Ok(())
    }

    /// Left button up: ends a drag (one undo step) or an orbit.
    fn mouse_release(&mut self) -> anyhow::Result<()> {
        self.left_down = false;
        let Some(h) = self.held.take() else {
            return Ok(());
        };
        let Some(r) = self.renderer.as_mut() else {
            return Ok(());
        };
        let handles = r.scene.handles(&r.view);
        if handles.len() == h.before.len() {
            r.scene.set_handles(&handles, None)?;
            let p = handles[h.index];
            eprintln!(
                "gregvox demo: moved handle {} to {:.6} {:.6} {:.6} (cursor {:.1} {:.1})",
                h.index, p.x, p.y, p.z, self.cursor.0, self.cursor.1
            );
            self.undo.push(h.before);
        }
        Ok(())
    }

    /// The wheel turned `lines` notches: sets what the held handle has (a NURBS weight), else zooms.
    fn mouse_wheel(&mut self, lines: f32) -> anyhow::Result<()> {
        let Some(r) = self.renderer.as_mut() else {
            return Ok(());
        };
        if let Some(h) = &self.held {
            if let Some(what) = r.scene.wheel_held(h.index, lines)? {
                eprintln!("gregvox demo: {what}");
                return Ok(());
            }
        }
        r.view.orbit = r.view.orbit.zoomed(lines);
        Ok(())
    }

    fn mouse(&mut self, action: MouseAction) -> anyhow::Result<()> {
        match action {
            MouseAction::Press(x, y) => self.mouse_press((x, y)),
            MouseAction::Move(x, y) => self.mouse_move((x, y)),
            MouseAction::Release => self.mouse_release(),
            MouseAction::Wheel(lines) => self.mouse_wheel(lines),
        }
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) -> anyhow::Result<()> {
        let (Some(renderer), Some(target)) = (self.renderer.as_mut(), self.target.as_mut()) else {
            return Ok(());
        };
        let t = match self.args.time_step {
            Some(dt) => self.frames_drawn as f32 * dt,
            None => self.start.elapsed().as_secs_f32(),
        };
        let begun = renderer.begin_frame(self.ctx)?;
        if renderer.draw(self.ctx, begun, target, t)? {
            self.frames_drawn += 1;
            let e = target.extent();
            if self.resize_pending == Some((e.width, e.height)) {
                self.resize_pending = None;
                eprintln!("gregvox demo: presenting at {}x{}", e.width, e.height);
            }
        } else {
            self.skipped += 1;
        }
        if self.screenshot.is_some() {
            // Rare: waiting for the frame here keeps the capture simple.
            renderer.finish(self.ctx)?;
            if let Some((w, h, rgba)) = target.take_capture()? {
                let path = self.screenshot.take().expect("checked above");
                crate::gpu::present::write_png_rgba(&path, w, h, &rgba)?;
                eprintln!("gregvox demo: screenshot {}", path.display());
            }
        }
        let now = Instant::now();
        if now.duration_since(self.last_title).as_secs_f64() > 0.5 {
            self.last_title = now;
            let mut title = format!(
                "gregvox — {} — {:.2} ms/frame",
                renderer.scene.name(),
                renderer.frame_ms
            );
            for p in renderer.profiler.stats() {
                title.push_str(&format!(" | {} {:.3} ms", p.name, p.median_ms));
            }
            if let Some(w) = &self.window {
                w.set_title(&title);
            }
        }
        // Scripted keys (--keys): one every 5 frames, after the frame that was just drawn.
        if self.frames_drawn % 5 == 0 && self.frames_drawn > 0 {
            if let Some(k) = self.scripted.pop_front() {
                eprintln!("gregvox demo: key {k}");
                match (window_action(&k), mouse_action(&k)) {
                    (Some(a), _) => self.window_action(a),
                    (None, Some(m)) => self.mouse(m)?,
                    (None, None) => self.key_named(event_loop, &k)?,
                }
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
        let result = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key,
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => self.key(event_loop, &logical_key),
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => match state {
                ElementState::Pressed => self.mouse_press(self.cursor),
                ElementState::Released => self.mouse_release(),
            },
            WindowEvent::CursorMoved { position, .. } => self.mouse_move((position.x, position.y)),
            WindowEvent::MouseWheel { delta, .. } => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    // About 40 pixels per wheel notch.
                    MouseScrollDelta::PixelDelta(p) => (p.y / 40.0) as f32,
                };
                self.mouse_wheel(lines)
            }
            WindowEvent::Resized(size) => {
                if let Some(t) = self.target.as_mut() {
                    t.resize(vk::Extent2D {
                        width: size.width,
                        height: size.height,
                    });
                }
                Ok(())
            }
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
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
        args: args.clone(),
        window: None,
        target: None,
        renderer: None,
        frames_drawn: 0,
        start: now,
        last_title: now,
        left_down: false,
        cursor: (0.0, 0.0),
        held: None,
        undo: Vec::new(),
        original: None,
        cages_written: 0,
        screenshot: None,
        screenshots_taken: 0,
        scripted: args.keys.iter().map(|k| k.trim().to_string()).collect(),
        resize_pending: None,
        skipped: 0,
        error: None,
    };
    let run = event_loop.run_app(&mut app);
    let mut result = run.map_err(anyhow::Error::from);
    if let Some(e) = app.error.take() {
        result = Err(e);
    }
    if let Some(mut r) = app.renderer.take() {
        let finished = r.finish(&ctx).and_then(|()| args.profile.emit(&r.profiler));
        if result.is_ok() {
            result = finished;
        }
    }
    // The swapchain (and its surface) before the window it was made for.
    drop(app.target.take());
    drop(app.window.take());
    if result.is_ok() {
        eprintln!(
            "gregvox demo: {} frames presented, {} skipped (minimised or out of date)",
            app.frames_drawn, app.skipped
        );
    }
    result
}

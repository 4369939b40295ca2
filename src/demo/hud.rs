//! The demo's on-screen overlay: the scene, its level or adaptive setting, the shading, the frame time and
//! every pass's GPU time, and the keys, drawn into the frame (the window by default, key H; offscreen PNGs
//! with `--hud`) by [`OverlayPass`] as pixel rectangles: a translucent panel, then the text.
//!
//! The text is a 5×7 pixel font of gregvox's own ([`FONT`]: capitals, digits and the punctuation the
//! overlay prints; lower case is shown as capitals, a few accented letters and symbols fold to their base,
//! anything else to '?'), each glyph pixel a `scale`×`scale` square, `scale` 2 from 720 rows up (readable
//! at 1280×720), 1 below. Every glyph row is cut into runs of set pixels and each run drawn as one
//! rectangle with integer corners, which the rasterizer covers exactly: the frame holds the same pixels as
//! [`text_rects`] says, which `tests/demo_hud.rs` checks against a CPU composite.
//!
//! With `Renderer::hud_times` off the times print as "-", so the overlay is the same every run: the golden
//! frame `cage_hud` (`tests/demo_golden.rs`) holds it.
//!
//! Cost: two triangles per run (at most 3 runs a glyph row, 21 a glyph), rebuilt on the CPU each frame
//! into the frame slot's own host-visible buffer ([`LineRing`]); lines longer than the target is wide are
//! cut, and no more lines are drawn than fit, so a tiny window or a huge pass table costs nothing more.
use super::scene::{FrameTargets, DEPTH_FORMAT};
use crate::gpu::{Context, Profiler};
use crate::passes::draw::ColorTarget;
use crate::passes::lines::{LineRing, LineVertex};
use crate::passes::overlay::OverlayPass;
use ash::vk;

/// Glyph width and height in font pixels; glyphs advance by 6 and lines by 9.
pub const GLYPH_W: u32 = 5;
pub const GLYPH_H: u32 = 7;
pub const ADVANCE: u32 = 6;
pub const LINE_HEIGHT: u32 = 9;
/// Panel margin around the text, in font pixels.
pub const MARGIN: u32 = 3;
/// Text and panel colours (RGBA; the panel is blended over the frame).
pub const TEXT_COLOR: [f32; 4] = [0.96, 0.96, 0.93, 1.0];
pub const PANEL_COLOR: [f32; 4] = [0.04, 0.05, 0.07, 0.62];

/// The font: each glyph's 7 rows top to bottom, bit 4 the leftmost pixel.
pub const FONT: &[(char, [u8; 7])] = &[
    (
        'A',
        [
            0b01110, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ],
    ),
    (
        'B',
        [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110,
        ],
    ),
    (
        'C',
        [
            0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110,
        ],
    ),
    (
        'D',
        [
            0b11110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b11110,
        ],
    ),
    (
        'E',
        [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111,
        ],
    ),
    (
        'F',
        [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
    ),
    (
        'G',
        [
            0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111,
        ],
    ),
    (
        'H',
        [
            0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ],
    ),
    (
        'I',
        [
            0b01110, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
    ),
    (
        'J',
        [
            0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100,
        ],
    ),
    (
        'K',
        [
            0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001,
        ],
    ),
    (
        'L',
        [
            0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111,
        ],
    ),
    (
        'M',
        [
            0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001,
        ],
    ),
    (
        'N',
        [
            0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001,
        ],
    ),
    (
        'O',
        [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        'P',
        [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
    ),
    (
        'Q',
        [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101,
        ],
    ),
    (
        'R',
        [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001,
        ],
    ),
    (
        'S',
        [
            0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110,
        ],
    ),
    (
        'T',
        [
            0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100,
        ],
    ),
    (
        'U',
        [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        'V',
        [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100,
        ],
    ),
    (
        'W',
        [
            0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010,
        ],
    ),
    (
        'X',
        [
            0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001,
        ],
    ),
    (
        'Y',
        [
            0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100, 0b00100,
        ],
    ),
    (
        'Z',
        [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111,
        ],
    ),
    (
        '0',
        [
            0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110,
        ],
    ),
    (
        '1',
        [
            0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
    ),
    (
        '2',
        [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111,
        ],
    ),
    (
        '3',
        [
            0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110,
        ],
    ),
    (
        '4',
        [
            0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010,
        ],
    ),
    (
        '5',
        [
            0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110,
        ],
    ),
    (
        '6',
        [
            0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        '7',
        [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000,
        ],
    ),
    (
        '8',
        [
            0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110,
        ],
    ),
    (
        '9',
        [
            0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100,
        ],
    ),
    (
        '.',
        [
            0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b01100,
        ],
    ),
    (
        ',',
        [
            0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b00100, 0b01000,
        ],
    ),
    (
        ':',
        [
            0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b01100, 0b00000,
        ],
    ),
    (
        '-',
        [
            0b00000, 0b00000, 0b00000, 0b11111, 0b00000, 0b00000, 0b00000,
        ],
    ),
    (
        '+',
        [
            0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0b00000,
        ],
    ),
    (
        '/',
        [
            0b00000, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b00000,
        ],
    ),
    (
        '(',
        [
            0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010,
        ],
    ),
    (
        ')',
        [
            0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000,
        ],
    ),
    (
        '%',
        [
            0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011,
        ],
    ),
    (
        '=',
        [
            0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000,
        ],
    ),
    (
        '|',
        [
            0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100,
        ],
    ),
    (
        '<',
        [
            0b00010, 0b00100, 0b01000, 0b10000, 0b01000, 0b00100, 0b00010,
        ],
    ),
    (
        '>',
        [
            0b01000, 0b00100, 0b00010, 0b00001, 0b00010, 0b00100, 0b01000,
        ],
    ),
    (
        '[',
        [
            0b01110, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b01110,
        ],
    ),
    (
        ']',
        [
            0b01110, 0b00010, 0b00010, 0b00010, 0b00010, 0b00010, 0b01110,
        ],
    ),
    (
        '_',
        [
            0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b11111,
        ],
    ),
    (
        '*',
        [
            0b00000, 0b00100, 0b10101, 0b01110, 0b10101, 0b00100, 0b00000,
        ],
    ),
    (
        '?',
        [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b00000, 0b00100,
        ],
    ),
    (
        '!',
        [
            0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00000, 0b00100,
        ],
    ),
    (
        '\'',
        [
            0b00100, 0b00100, 0b01000, 0b00000, 0b00000, 0b00000, 0b00000,
        ],
    ),
];

/// The character `c` is drawn as: capitals for lower case, a few accented letters and symbols folded to
/// their base, '?' for anything the font lacks.
pub fn fold(c: char) -> char {
    let c = match c {
        'à' | 'á' | 'â' | 'ä' | 'À' | 'Á' | 'Ä' => 'A',
        'é' | 'è' | 'ê' | 'ë' | 'É' | 'È' => 'E',
        'í' | 'ï' => 'I',
        'ó' | 'ö' | 'ô' | 'Ö' | 'Ó' => 'O',
        'ú' | 'ü' | 'Ü' => 'U',
        'ç' | 'Ç' => 'C',
        '≤' => '<',
        '≥' | '→' => '>',
        '×' => 'X',
        '–' | '—' | '−' => '-',
        '…' | '·' => '.',
        '²' => '2',
        '³' => '3',
        '"' => '\'',
        c => c.to_ascii_uppercase(),
    };
    if c == ' ' || FONT.iter().any(|(g, _)| *g == c) {
        c
    } else {
        '?'
    }
}

/// The rows of `c` as drawn ([`fold`]); a space is blank.
pub fn glyph(c: char) -> [u8; 7] {
    let c = fold(c);
    FONT.iter()
        .find(|(g, _)| *g == c)
        .map_or([0; 7], |(_, rows)| *rows)
}

/// The overlay's scale for a target `height` pixels high: 2 from 720 up, else 1.
pub fn hud_scale(height: u32) -> u32 {
    if height >= 720 {
        2
    } else {
        1
    }
}

/// The lines that fit a `width`×`height` target at `scale`, each cut to the characters that fit.
fn fitted(lines: &[String], scale: u32, width: u32, height: u32) -> Vec<Vec<char>> {
    let cols = (width / scale).saturating_sub(2 * MARGIN) / ADVANCE;
    let rows = (height / scale).saturating_sub(2 * MARGIN) / LINE_HEIGHT;
    lines
        .iter()
        .take(rows as usize)
        .map(|l| l.chars().take(cols as usize).collect())
        .collect()
}

/// The panel behind `lines` (x0, y0, x1, y1 in pixels, exclusive ends), or `None` when nothing fits.
pub fn panel_rect(lines: &[String], scale: u32, width: u32, height: u32) -> Option<[u32; 4]> {
    let fit = fitted(lines, scale, width, height);
    let cols = fit.iter().map(|l| l.len() as u32).max()?;
    if cols == 0 {
        return None;
    }
    let w = 2 * MARGIN + cols * ADVANCE - (ADVANCE - GLYPH_W);
    let h = 2 * MARGIN + fit.len() as u32 * LINE_HEIGHT - (LINE_HEIGHT - GLYPH_H);
    Some([0, 0, w * scale, h * scale])
}

/// The text's pixel rectangles (x0, y0, x1, y1, exclusive ends): one per run of set pixels in a glyph row.
pub fn text_rects(lines: &[String], scale: u32, width: u32, height: u32) -> Vec<[u32; 4]> {
    let mut out = Vec::new();
    for (row, line) in fitted(lines, scale, width, height).iter().enumerate() {
        for (col, &c) in line.iter().enumerate() {
            let (x0, y0) = (
                MARGIN + col as u32 * ADVANCE,
                MARGIN + row as u32 * LINE_HEIGHT,
            );
            for (r, bits) in glyph(c).iter().enumerate() {
                let mut x = 0;
                while x < GLYPH_W {
                    if bits >> (GLYPH_W - 1 - x) & 1 == 0 {
                        x += 1;
                        continue;
                    }
                    let start = x;
                    while x < GLYPH_W && bits >> (GLYPH_W - 1 - x) & 1 == 1 {
                        x += 1;
                    }
                    let y = y0 + r as u32;
                    out.push([
                        (x0 + start) * scale,
                        y * scale,
                        (x0 + x) * scale,
                        (y + 1) * scale,
                    ]);
                }
            }
        }
    }
    out
}

fn quad(out: &mut Vec<LineVertex>, [x0, y0, x1, y1]: [u32; 4], color: [f32; 4]) {
    let v = |x: u32, y: u32| LineVertex {
        position: [x as f32, y as f32, 0.0, 1.0],
        color,
    };
    out.extend([
        v(x0, y0),
        v(x1, y0),
        v(x1, y1),
        v(x0, y0),
        v(x1, y1),
        v(x0, y1),
    ]);
}

/// The overlay's triangles (window pixels) for `lines` in a `width`×`height` target: the panel, then the
/// text.
pub fn hud_triangles(lines: &[String], scale: u32, width: u32, height: u32) -> Vec<LineVertex> {
    let mut out = Vec::new();
    if let Some(panel) = panel_rect(lines, scale, width, height) {
        quad(&mut out, panel, PANEL_COLOR);
    }
    for r in text_rects(lines, scale, width, height) {
        quad(&mut out, r, TEXT_COLOR);
    }
    out
}

/// What the overlay shows.
#[derive(Clone, Debug, Default)]
pub struct HudInfo {
    pub scene: String,
    pub level: Option<u32>,
    pub shading: String,
    pub path: String,
    pub animate: bool,
    /// Smoothed wall time per frame (ms).
    pub frame_ms: f64,
    /// (pass, median GPU ms).
    pub passes: Vec<(String, f64)>,
    /// Show the keys (the window; offscreen frames have none).
    pub keys: bool,
    /// Show the times; without them ("-") the overlay is the same every run (golden frames).
    pub times: bool,
}

/// The overlay's lines for `info`.
pub fn hud_lines(info: &HudInfo) -> Vec<String> {
    let mut lines = vec![format!("GREGVOX  {}", info.scene)];
    let level = info
        .level
        .map_or_else(String::new, |l| format!("LEVEL {l}  "));
    lines.push(format!(
        "{level}SHADING {}  PATH {}  {}",
        info.shading,
        info.path,
        if info.animate { "PLAYING" } else { "PAUSED" }
    ));
    if info.times {
        lines.push(format!("FRAME {:.2} MS", info.frame_ms));
    } else {
        lines.push("FRAME - MS".into());
    }
    for (name, ms) in &info.passes {
        if info.times {
            lines.push(format!("  {name:<18} {ms:>8.3} MS"));
        } else {
            lines.push(format!("  {name:<18} {:>8} MS", "-"));
        }
    }
    if info.keys {
        lines.push(String::new());
        lines.extend(
            [
                "1-9 SCENE  +/- LEVEL  SPACE PLAY/PAUSE  S SHADING",
                "V PATH  A ADAPTIVE  D DEFORM  C CORRECTION",
                "P SCREENSHOT  T TIMES  H OVERLAY  Q QUIT",
                "DRAG ORBIT  WHEEL ZOOM",
                "PAUSED: DRAG A VERTEX, CORNER OR POINT (WHEEL: NURBS WEIGHT)",
                "Z UNDO  R RESET  W WRITE CAGE",
            ]
            .map(String::from),
        );
    }
    lines
}

/// The overlay pass and its per-slot vertex buffers.
pub struct Hud {
    pass: OverlayPass,
    ring: LineRing,
    /// Vertices drawn in the last recorded frame.
    pub drawn: u32,
}

impl Hud {
    /// Builds the pipeline for `color` targets (and the demo's depth format).
    pub fn new(ctx: &Context, color: impl Into<ColorTarget>) -> anyhow::Result<Self> {
        Ok(Hud {
            pass: OverlayPass::new(ctx, color, DEPTH_FORMAT)?,
            ring: LineRing::new(super::FRAMES_IN_FLIGHT),
            drawn: 0,
        })
    }

    /// Draws `lines` over the frame in `targets` (after the scene), in the profiler scope "overlay".
    pub fn record(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        targets: &FrameTargets,
        lines: &[String],
        profiler: &mut Profiler,
    ) -> anyhow::Result<()> {
        let e = targets.extent;
        let vertices = hud_triangles(lines, hud_scale(e.height), e.width, e.height);
        let buf = self.ring.upload(ctx, targets.slot, &vertices)?;
        let target = targets.draw_target();
        let pass = &self.pass;
        profiler.scope(ctx, cmd, targets.slot, "overlay", || {
            pass.record(ctx, cmd, &target, buf, vertices.len() as u32)
        })?;
        self.drawn = vertices.len() as u32;
        Ok(())
    }
}

//! The demo's overlay: its font draws every character the overlay prints, its rectangles are the glyphs'
//! pixels, the GPU frame holds exactly those pixels over the panel's blend (a CPU composite as the
//! oracle), and `gregvox demo --offscreen --hud` changes the panel's pixels and no other.
mod common;

use ash::vk;
use clap::Parser;
use common::{render_frame, with_gpu, FRAME_FORMAT};
use gregvox::demo::hud::{
    fold, glyph, hud_lines, hud_triangles, panel_rect, text_rects, HudInfo, FONT, GLYPH_H, GLYPH_W,
    PANEL_COLOR, TEXT_COLOR,
};
use gregvox::demo::{build_scene, DemoArgs, SceneKind};
use gregvox::gpu::resources::memory_barrier;
use gregvox::passes::draw::begin_color_depth;
use gregvox::passes::overlay::OverlayPass;
use std::collections::HashSet;

#[derive(Parser)]
struct Cli {
    #[command(flatten)]
    demo: DemoArgs,
}

const FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

#[test]
fn the_font_has_one_distinct_glyph_per_character_and_folds_what_it_lacks() {
    let mut seen = HashSet::new();
    for (c, rows) in FONT {
        assert!(
            rows.iter().all(|r| *r < 1 << GLYPH_W),
            "'{c}' is wider than 5"
        );
        assert!(rows.iter().any(|r| *r != 0), "'{c}' is blank");
        assert!(seen.insert(*rows), "'{c}' looks like another glyph");
        assert_eq!(fold(*c), *c);
    }
    assert_eq!(fold('a'), 'A');
    assert_eq!(fold('é'), 'E');
    assert_eq!(fold('≤'), '<');
    assert_eq!(fold('€'), '?');
    assert_eq!(glyph(' '), [0; 7]);
    assert_eq!(glyph('q'), glyph('Q'));
}

#[test]
fn every_scene_name_and_the_key_list_print_without_a_missing_glyph() {
    with_gpu(|ctx| {
        for &kind in SceneKind::all() {
            let args = Cli::try_parse_from(["demo", "--offscreen", "--scene", &kind.name()])
                .unwrap()
                .demo;
            // A scene that needs a model (Beziex) is skipped: its name is the file's.
            let Ok(scene) = build_scene(ctx, &args, FORMAT) else {
                continue;
            };
            let info = HudInfo {
                scene: scene.name(),
                level: scene.level(),
                shading: "Mean".into(),
                path: "vertex pull".into(),
                animate: false,
                frame_ms: 16.67,
                passes: vec![("gregory_eval".into(), 0.125)],
                keys: true,
                times: true,
            };
            for line in hud_lines(&info) {
                for c in line.chars() {
                    assert_ne!(fold(c), '?', "'{c}' of {line:?} ({})", kind.name());
                }
            }
        }
    });
}

#[test]
fn the_text_rectangles_cover_exactly_the_glyph_pixels() {
    for scale in [1, 2, 3] {
        let text = vec!["A5%".to_string(), "g?".to_string()];
        let mut covered = HashSet::new();
        for [x0, y0, x1, y1] in text_rects(&text, scale, 1000, 1000) {
            for y in y0..y1 {
                for x in x0..x1 {
                    assert!(covered.insert((x, y)), "pixel ({x}, {y}) covered twice");
                }
            }
        }
        let mut expect = HashSet::new();
        for (row, line) in text.iter().enumerate() {
            for (col, c) in line.chars().enumerate() {
                for (r, bits) in glyph(c).iter().enumerate() {
                    for b in 0..GLYPH_W {
                        if bits >> (GLYPH_W - 1 - b) & 1 == 1 {
                            let x = (3 + col as u32 * 6 + b) * scale;
                            let y = (3 + row as u32 * 9 + r as u32) * scale;
                            for dy in 0..scale {
                                for dx in 0..scale {
                                    expect.insert((x + dx, y + dy));
                                }
                            }
                        }
                    }
                }
            }
        }
        assert_eq!(covered, expect, "scale {scale}");
        let [_, _, w, h] = panel_rect(&text, scale, 1000, 1000).unwrap();
        assert_eq!((w, h), ((6 + 3 * 6 - 1) * scale, (6 + 9 + GLYPH_H) * scale));
    }
    // What does not fit is not drawn: a 20-pixel-wide target holds two characters a line.
    let long = vec!["ABCDEFG".to_string(); 100];
    let rects = text_rects(&long, 1, 20, 40);
    assert!(rects.iter().all(|r| r[2] <= 20 && r[3] <= 40));
    assert!(panel_rect(&long, 1, 4, 4).is_none());
}

/// The 8-bit value a float colour channel is stored as.
fn unorm(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

#[test]
fn the_overlay_frame_holds_the_text_over_the_blended_panel_pixel_for_pixel() {
    let (w, h) = (160u32, 100u32);
    let lines: Vec<String> = [
        "GREGVOX 0.125 MS",
        "LEVEL 8 | +/- (Z)",
        "wide line cut at the edge",
    ]
    .map(String::from)
    .to_vec();
    let bg = [0.8f32, 0.3, 0.2, 1.0];
    let px = with_gpu(|ctx| {
        let pass = OverlayPass::new(ctx, FRAME_FORMAT, vk::Format::D32_SFLOAT).unwrap();
        let vertices = hud_triangles(&lines, 1, w, h);
        let buffer = ctx
            .upload_buffer(
                "hud vertices",
                bytemuck::cast_slice(&vertices),
                vk::BufferUsageFlags::VERTEX_BUFFER,
            )
            .unwrap();
        render_frame(ctx, w, h, |cmd, target| {
            // The "scene": a clear.
            begin_color_depth(ctx, cmd, target, Some(bg));
            ctx.cmd_end_rendering(cmd);
            memory_barrier(
                ctx,
                cmd,
                (
                    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT
                        | vk::PipelineStageFlags2::LATE_FRAGMENT_TESTS,
                    vk::AccessFlags2::COLOR_ATTACHMENT_WRITE
                        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_WRITE,
                ),
                (
                    vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT
                        | vk::PipelineStageFlags2::EARLY_FRAGMENT_TESTS,
                    vk::AccessFlags2::COLOR_ATTACHMENT_READ
                        | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE
                        | vk::AccessFlags2::DEPTH_STENCIL_ATTACHMENT_READ,
                ),
            );
            pass.record(ctx, cmd, target, &buffer, vertices.len() as u32)
        })
    });

    // The CPU composite: the clear, the panel blended over it (src·a + dst·(1 − a)), the text on top.
    let panel = panel_rect(&lines, 1, w, h).unwrap();
    let text: HashSet<(u32, u32)> = text_rects(&lines, 1, w, h)
        .iter()
        .flat_map(|&[x0, y0, x1, y1]| (y0..y1).flat_map(move |y| (x0..x1).map(move |x| (x, y))))
        .collect();
    let a = PANEL_COLOR[3];
    let mut text_pixels = 0;
    for y in 0..h {
        for x in 0..w {
            let i = ((y * w + x) * 4) as usize;
            let got = &px[i..i + 3];
            let inside = x < panel[2] && y < panel[3];
            let want: [u8; 3] = if text.contains(&(x, y)) {
                text_pixels += 1;
                [0, 1, 2].map(|c| unorm(TEXT_COLOR[c]))
            } else if inside {
                [0, 1, 2]
                    .map(|c| unorm(PANEL_COLOR[c] * a + unorm(bg[c]) as f32 / 255.0 * (1.0 - a)))
            } else {
                [0, 1, 2].map(|c| unorm(bg[c]))
            };
            // The clear's and the text's conversion to 8 bits may round either way; the blend adds one more.
            let slack = if inside && !text.contains(&(x, y)) {
                2
            } else {
                1
            };
            assert!(
                got.iter().zip(want).all(|(g, w)| g.abs_diff(w) <= slack),
                "pixel ({x}, {y}): {got:?}, the composite {want:?}"
            );
        }
    }
    assert!(text_pixels > 300, "{text_pixels} text pixels");
}

#[test]
fn the_offscreen_hud_changes_the_panel_pixels_and_no_other() {
    let dir = std::env::temp_dir().join(format!("gregvox-hud-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let run = |hud: bool| {
        let out_dir = dir.join(if hud { "hud" } else { "plain" });
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_gregvox"));
        cmd.args(["demo", "--offscreen", "--frames", "3", "--size", "320x240"])
            .args(["--scene", "cage"])
            .arg("--out")
            .arg(&out_dir)
            .env("GREGVOX_VALIDATION", "1");
        if hud {
            cmd.arg("--hud");
        }
        let out = cmd.output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{err}");
        assert!(!err.contains("vulkan validation"), "{err}");
        common::read_png(&out_dir.join("frame_00002.png")).2
    };
    let (plain, hud) = (run(false), run(true));
    let (w, h) = (320u32, 240u32);
    // The same frame (a fixed time step) with and without the overlay: they differ only inside the
    // panel at the top-left corner, at most 3 + 10 lines of 9 pixels (the cage scene's passes and the
    // overlay's own), and the text there is near white.
    let (mut changed, mut bright, mut bottom, mut right) = (0, 0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = ((y * w + x) * 4) as usize;
            let (p, q) = (&plain[i..i + 3], &hud[i..i + 3]);
            if p != q {
                changed += 1;
                bottom = bottom.max(y);
                right = right.max(x);
                if q.iter().all(|&c| c >= 225) {
                    bright += 1;
                }
            }
        }
    }
    assert!(changed > 5000, "{changed} pixels under the overlay");
    assert!(bright > 300, "{bright} text pixels");
    assert!(bottom < 6 + 13 * 9, "the overlay reaches row {bottom}");
    assert!(right > 100, "the overlay ends at column {right}");
    let _ = std::fs::remove_dir_all(&dir);
}

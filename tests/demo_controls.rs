//! The demo's controls without a window: the key → action mapping (`key_action`, a pure function of the key
//! and the viewer state), the orbit camera's mouse response and the scene table the number keys follow.
use gregvox::demo::scene::{DrawPath, Orbit};
use gregvox::demo::window::{key_action, Action, Controls};
use gregvox::demo::{parse_time_step, SceneKind};
use gregvox::passes::gregory_eval::MAX_LEVEL;
use gregvox::passes::surface_draw::ShadingMode;

fn state() -> Controls {
    Controls {
        scene: SceneKind::Flag,
        level: Some(10),
        shading: ShadingMode::Phong,
        animate: true,
        path: DrawPath::Compute,
    }
}

#[test]
fn number_keys_switch_to_the_scenes_in_table_order() {
    let c = state();
    for (i, &kind) in SceneKind::all().iter().enumerate().take(9) {
        let key = (i + 1).to_string();
        let expected = (kind != c.scene).then_some(Action::SwitchScene(kind));
        assert_eq!(key_action(&key, &c), expected, "key {key}");
    }
}

#[test]
fn the_current_scenes_number_and_numbers_past_the_table_do_nothing() {
    let c = state();
    assert_eq!(key_action("1", &c), None, "1 is the flag, already shown");
    assert_eq!(key_action("0", &c), None);
    let past = SceneKind::all().len() + 1;
    if past <= 9 {
        assert_eq!(key_action(&past.to_string(), &c), None);
    }
}

#[test]
fn plus_and_minus_step_the_level_within_1_to_max() {
    let mut c = state();
    assert_eq!(key_action("+", &c), Some(Action::SetLevel(11)));
    assert_eq!(
        key_action("=", &c),
        Some(Action::SetLevel(11)),
        "+ without shift"
    );
    assert_eq!(key_action("-", &c), Some(Action::SetLevel(9)));
    c.level = Some(1);
    assert_eq!(key_action("-", &c), None, "level 1 is the lowest");
    c.level = Some(MAX_LEVEL);
    assert_eq!(key_action("+", &c), None, "MAX_LEVEL is the highest");
    c.level = None;
    assert_eq!(key_action("+", &c), None, "a scene without a level");
}

#[test]
fn space_toggles_the_deformation() {
    let mut c = state();
    assert_eq!(key_action("Space", &c), Some(Action::SetAnimate(false)));
    c.animate = false;
    assert_eq!(key_action("Space", &c), Some(Action::SetAnimate(true)));
}

#[test]
fn v_toggles_between_the_compute_and_the_vertex_pull_path() {
    let mut c = state();
    assert_eq!(
        key_action("v", &c),
        Some(Action::SetPath(DrawPath::VertexPull))
    );
    c.path = DrawPath::VertexPull;
    assert_eq!(
        key_action("V", &c),
        Some(Action::SetPath(DrawPath::Compute))
    );
}

#[test]
fn s_cycles_through_every_shading_mode_and_back() {
    let mut c = state();
    let mut seen = Vec::new();
    for _ in 0..ShadingMode::ALL.len() {
        match key_action("s", &c) {
            Some(Action::SetShading(m)) => {
                seen.push(m);
                c.shading = m;
            }
            other => panic!("s gave {other:?}"),
        }
    }
    assert_eq!(c.shading, ShadingMode::Phong, "the cycle closes");
    for m in ShadingMode::ALL {
        assert!(seen.contains(&m), "{m:?} is reachable");
    }
}

#[test]
fn p_t_escape_and_scene_keys() {
    let c = state();
    assert_eq!(key_action("p", &c), Some(Action::Screenshot));
    assert_eq!(key_action("T", &c), Some(Action::PrintProfile));
    assert_eq!(key_action("Escape", &c), Some(Action::Quit));
    assert_eq!(key_action("C", &c), Some(Action::SceneKey("c".into())));
    assert_eq!(key_action("d", &c), Some(Action::SceneKey("d".into())));
    assert_eq!(key_action("F1", &c), None, "named keys nobody uses");
    assert_eq!(key_action("", &c), None);
}

#[test]
fn dragging_orbits_and_the_wheel_zooms() {
    let o = Orbit::framing(glam::Vec3::ZERO, 2.0);
    let d = o.dragged(50.0, -20.0);
    assert!((d.yaw - (o.yaw - 0.5)).abs() < 1e-6, "0.01 rad per pixel");
    assert!((d.pitch - (o.pitch - 0.2)).abs() < 1e-6);
    assert_eq!(d.distance, o.distance, "dragging keeps the distance");
    assert_eq!(o.dragged(0.0, -1e5).pitch, -1.5, "never over the pole");
    let z = o.zoomed(2.0);
    assert!(
        (z.distance - o.distance * 0.81).abs() < 1e-5,
        "10 % per step"
    );
    assert!((o.zoomed(-1.0).distance - o.distance / 0.9).abs() < 1e-5);
    assert!(
        o.zoomed(1e6).distance > 0.0,
        "zoom never reaches the target"
    );
}

#[test]
fn time_steps_must_be_non_negative_numbers() {
    assert_eq!(parse_time_step("0.5"), Ok(0.5));
    assert_eq!(parse_time_step("0"), Ok(0.0));
    for bad in ["-1", "x", "inf", "NaN", ""] {
        let e = parse_time_step(bad).unwrap_err();
        assert!(e.contains("time step"), "{bad}: {e}");
    }
}

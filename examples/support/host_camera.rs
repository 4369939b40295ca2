//! What both example hosts (`ash_host`, `wgpu_host`) share so their frames compare with each other and
//! with gregvox's own renderer: the clear colour and the camera that frames a cage.
//!
//! Not an example of its own (cargo builds only top-level files and folders with a `main.rs`); each host
//! includes it with `#[path]`.

/// The hosts' clear colour (linear RGBA, written to an UNORM target).
pub const CLEAR: [f32; 4] = [0.08, 0.09, 0.11, 1.0];

/// A camera that frames the box `lo`–`hi` (z up), as gregvox's demo places its own; Vulkan clip space
/// (y down). Returns the view-projection matrix and the eye.
pub fn camera(lo: glam::Vec3, hi: glam::Vec3, aspect: f32) -> (glam::Mat4, glam::Vec3) {
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let eye = centre + radius * glam::Vec3::new(1.6, -2.2, 1.3);
    let view = glam::Mat4::look_at_rh(eye, centre, glam::Vec3::Z);
    let distance = (eye - centre).length();
    let mut proj =
        glam::Mat4::perspective_rh(0.8, aspect.max(1e-3), distance * 0.02, distance * 10.0);
    proj.y_axis.y = -proj.y_axis.y;
    (proj * view, eye)
}

/// The camera framing a surface's rest cage in a `width`×`height` frame.
pub fn frame_cage(rest: &[glam::DVec3], width: u32, height: u32) -> (glam::Mat4, glam::Vec3) {
    let lo = rest
        .iter()
        .fold(glam::DVec3::splat(f64::INFINITY), |a, p| a.min(*p))
        .as_vec3();
    let hi = rest
        .iter()
        .fold(glam::DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p))
        .as_vec3();
    camera(lo, hi, width as f32 / height as f32)
}

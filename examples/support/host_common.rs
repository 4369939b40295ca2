//! What both example hosts (`ash_host`, `wgpu_host`) share so their frames compare with each other and
//! with gregvox's own renderer: the clear colour and the camera that frames a cage.
//!
//! Not an example of its own (cargo builds only top-level files and folders with a `main.rs`); each host
//! includes it with `#[path]`. It also parses the options both hosts take.

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

/// The options both hosts take, written into the host's own option struct.
pub struct CommonArgs<'a> {
    pub width: &'a mut u32,
    pub height: &'a mut u32,
    pub frames: &'a mut u32,
    pub level: &'a mut u32,
    pub out: &'a mut Option<std::path::PathBuf>,
    pub validation: &'a mut bool,
}

/// Parses `args`: `--offscreen` (the only mode), `--validation`, `--frames N`, `--out DIR`, `--level L`,
/// `--size WxH` into `common`, and every other option through `extra(name, next)`, which returns
/// `Some(true)` when it took `next` as the option's value, `Some(false)` for a flag and `None` for an
/// option it does not know (then the error shows `usage`).
pub fn parse_args(
    args: &[String],
    usage: &str,
    common: CommonArgs<'_>,
    mut extra: impl FnMut(&str, Option<&str>) -> anyhow::Result<Option<bool>>,
) -> anyhow::Result<()> {
    use anyhow::{anyhow, bail, Context as _};
    let mut i = 0;
    while i < args.len() {
        let name = args[i].as_str();
        let next = args.get(i + 1).map(String::as_str);
        let value = || next.ok_or_else(|| anyhow!("{name} needs a value"));
        let took_value = match name {
            "--offscreen" => false,
            "--validation" => {
                *common.validation = true;
                false
            }
            "--frames" => {
                *common.frames = value()?.parse().context("--frames")?;
                true
            }
            "--out" => {
                *common.out = Some(value()?.into());
                true
            }
            "--level" => {
                *common.level = value()?.parse().context("--level")?;
                true
            }
            "--size" => {
                let v = value()?;
                let (a, b) = v
                    .split_once('x')
                    .ok_or_else(|| anyhow!("--size {v}: expected WxH"))?;
                *common.width = a.parse().context("--size")?;
                *common.height = b.parse().context("--size")?;
                true
            }
            _ => match extra(name, next)? {
                Some(took) => took,
                None => bail!("unknown argument {name} (usage: {usage})"),
            },
        };
        i += if took_value { 2 } else { 1 };
    }
    Ok(())
}

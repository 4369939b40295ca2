//! The cage scene's input: an OBJ quad cage (or the built-in one) turned into a GPU Gregory surface, with
//! the cage itself kept for drawing and dragging its vertices.
use super::scene::{CageScene, Scene};
use super::DemoArgs;
use crate::engine::cage::{builtin_cage, cage_topology, load_cage};
use crate::engine::gregory::GregorySurface;
use crate::gpu::Context;
use crate::passes::draw::ColorTarget;
use crate::surface::Tangents;

/// Builds the cage scene.
pub fn build(
    ctx: &Context,
    args: &DemoArgs,
    format: impl Into<ColorTarget>,
) -> anyhow::Result<Box<dyn Scene>> {
    let format: ColorTarget = format.into();
    let (mesh, topo, cage, note, name, uv) = match &args.model {
        Some(path) => {
            let (m, t, c, n, uv) = load_cage(path)?;
            (
                m,
                t,
                c,
                n,
                path.file_name()
                    .map(|f| f.to_string_lossy().into_owned())
                    .unwrap_or_default(),
                uv,
            )
        }
        None => {
            let mesh = builtin_cage(4, 2, 2);
            let (t, c, n) = cage_topology(&mesh, Tangents::OpenSubdiv)?;
            (mesh, t, c, n, "built-in box cage".to_string(), None)
        }
    };
    if let Some(n) = note {
        eprintln!("gregvox demo: {n}");
    }
    let surface = GregorySurface::new(ctx, &topo, &cage, args.level.unwrap_or(8))?;
    let mut scene = CageScene::new(ctx, format, surface, mesh, args.deform, name)?;
    if let Some(uv) = uv {
        // The checker shading reads the cage's own UVs (OpenSubdiv's face-varying surface) when it has them.
        scene.set_uvs(ctx, uv)?;
    }
    scene.adaptive = args.adaptive;
    Ok(Box::new(scene))
}

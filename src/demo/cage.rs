//! The cage scene's input: an OBJ quad cage (or the built-in one) turned into a GPU Gregory surface, with
//! the cage itself kept for drawing and dragging its vertices.
use super::scene::{CageScene, Scene};
use super::DemoArgs;
use crate::engine::cage::{builtin_cage, load_cage, tagged_cage_topologies, Layout};
use crate::gpu::Context;
use crate::mesh::Cage;
use crate::passes::draw::ColorTarget;
use crate::surface::Tangents;

/// Builds the cage scene.
pub fn build(
    ctx: &Context,
    args: &DemoArgs,
    format: impl Into<ColorTarget>,
) -> anyhow::Result<Box<dyn Scene>> {
    let format: ColorTarget = format.into();
    let (mesh, t, name) = match &args.model {
        Some(path) => {
            let (m, t) = load_cage(path)?;
            let name = path
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_default();
            (m, t, name)
        }
        None => {
            let mesh = builtin_cage(4, 2, 2);
            let t = tagged_cage_topologies(&Cage::from(mesh.clone()), Tangents::OpenSubdiv, false)?;
            (mesh, t, "built-in box cage".to_string())
        }
    };
    if let Some(n) = &t.note {
        eprintln!("gregvox demo: {n}");
    }
    let surface = t.gregory_surface(ctx, args.level.unwrap_or(8))?;
    let mut scene = CageScene::new(ctx, format, surface, mesh, args.deform, name)?;
    // The checker shading reads the cage's own UVs (OpenSubdiv's face-varying surface) when it has them.
    match (t.uv, t.layout) {
        (Some(uv), _) => scene.set_uvs(ctx, uv)?,
        (None, Layout::Ptex { uv: Some(e), .. }) => scene.set_ptex_uvs(ctx, e)?,
        _ => {}
    }
    scene.adaptive = args.adaptive;
    if scene.adaptive.is_some() && scene.is_ptex() {
        eprintln!(
            "gregvox demo: --adaptive needs one grid per patch; this cage is tessellated per ptex face, \
             uniformly"
        );
        scene.adaptive = None;
    }
    if scene.adaptive.is_some()
        && args.shading == crate::passes::surface_draw::ShadingMode::Checker
        && !scene.has_uvs()
    {
        eprintln!(
            "gregvox demo: --shading checker on --adaptive grids reads the cage's UVs, and this cage has \
             none: Phong until A turns --adaptive off"
        );
    }
    Ok(Box::new(scene))
}

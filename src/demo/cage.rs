//! The cage scene's input: an OBJ quad cage (or the built-in one) turned into a GPU Gregory surface.
use super::scene::{CageScene, Scene};
use super::DemoArgs;
use crate::gpu::Context;
use ash::vk;

/// Builds the cage scene.
pub fn build(
    _ctx: &Context,
    _args: &DemoArgs,
    _format: vk::Format,
) -> anyhow::Result<Box<dyn Scene>> {
    let _ = CageScene::new;
    anyhow::bail!("the cage scene needs the ACC-2 stencils, which are not built yet")
}

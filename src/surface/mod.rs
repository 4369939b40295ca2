//! Gregory patches from cages (ACC-2 stencils), Beziex patches, CPU reference tessellator.
pub mod beziex;

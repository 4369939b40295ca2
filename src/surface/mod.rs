//! Gregory patches from cages (ACC-2 stencils), Beziex loader, CPU reference tessellator.

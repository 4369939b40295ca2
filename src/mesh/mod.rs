//! OBJ loading and mesh connectivity as sparse matrices (`MeshMatrix`): topology, normals, subdivision.

#!/usr/bin/env python3
"""Writes tests/fixtures/mesh_formats/: one small open mesh in every format gregvox reads, written by
other tools (trimesh; plyfile for the big-endian PLY), so the Rust loaders are tested against files they
did not write.

    pip install trimesh plyfile numpy
    python3 scripts/oracle/mesh_formats.py            # from the repository root

The mesh: assets/models/suzanne.obj as trimesh reads it (quads split into triangles), every coordinate
rounded to a multiple of 2^-8 (its shortest edge is 2^-6, so no edge collapses). Why 2^-8: trimesh's ASCII PLY writer prints 8 decimals
('%.8f'), so a multiple of 2^-8 (at most 8 fractional decimal digits) is exact there, in every other text
format, and in f32 (|x| < 8, so 11 bits above the point and 8 below fit a 24-bit mantissa). Exact
duplicates made by the rounding are merged and faces that lose a corner are dropped, so the OBJ shares
every vertex and has no unreferenced one: its topology is the one every welded format must give.
Suzanne is open (the eyes are separate closed parts, the head has a boundary), so open/closed, components
and boundary loops all matter.

The glTF files exercise what exporters do: m.glb holds the mesh as two meshes on two nodes, each with its
own copy of the vertices along the cut (seam vertices split, welded back by the loader); m_moved.glb puts
the whole mesh under a parent node scaling by 2 and a child node translating by (4, -2, 1), so the world
position is 2p + (8, -4, 2) (exact in f32 and f64); m.gltf + m.bin is the two-part scene with an external
buffer, m_embedded.gltf the same with the buffer as a base64 data: URI.

Every file is read back here with trimesh/plyfile and checked to hold exactly the quantized positions.
"""
import importlib.metadata
import json
import os
import sys

import numpy as np
import plyfile
import trimesh

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SRC = os.path.join(ROOT, "assets", "models", "suzanne.obj")
OUT = os.path.join(ROOT, "tests", "fixtures", "mesh_formats")
STEP = 2.0**-8
MOVE_SCALE = 2.0
MOVE_TRANSLATION = np.array([4.0, -2.0, 1.0])  # the child's; the world shift is 2 * this = (8, -4, 2)


def base_mesh():
    m = trimesh.load(SRC, process=False, force="mesh")
    v = np.round(np.asarray(m.vertices, dtype=np.float64) / STEP) * STEP
    f = np.asarray(m.faces, dtype=np.int64)
    # merge exact duplicates (rounding may make some), drop faces that lose a corner, drop unreferenced
    uniq, inv = np.unique(v, axis=0, return_inverse=True)
    f = inv.reshape(-1)[f]
    ok = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    f = f[ok]
    used = np.unique(f)
    remap = -np.ones(len(uniq), dtype=np.int64)
    remap[used] = np.arange(len(used))
    v = uniq[used]
    f = remap[f]
    assert np.all(v == np.round(v / STEP) * STEP) and np.abs(v).max() < 8
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def part(mesh, faces):
    """The sub-mesh of `faces` with only its own vertices (seam vertices duplicated across parts)."""
    used, inv = np.unique(mesh.faces[faces], return_inverse=True)
    return trimesh.Trimesh(vertices=mesh.vertices[used], faces=inv.reshape(-1, 3), process=False)


def two_part_scene(mesh):
    half = len(mesh.faces) // 2
    s = trimesh.Scene()
    s.add_geometry(part(mesh, np.arange(half)), node_name="front", geom_name="front")
    s.add_geometry(part(mesh, np.arange(half, len(mesh.faces))), node_name="back", geom_name="back")
    return s


def moved_scene(mesh):
    s = trimesh.Scene()
    parent = np.eye(4)
    parent[:3, :3] *= MOVE_SCALE
    s.graph.update(frame_from=s.graph.base_frame, frame_to="scaled", matrix=parent)
    child = np.eye(4)
    child[:3, 3] = MOVE_TRANSLATION
    s.add_geometry(mesh, node_name="moved", geom_name="m", parent_node_name="scaled", transform=child)
    return s


def write(name, data):
    mode = "w" if isinstance(data, str) else "wb"
    with open(os.path.join(OUT, name), mode) as fh:
        fh.write(data)


def write_be_ply(mesh, path):
    """Big-endian PLY by plyfile: double coordinates, an extra vertex property, a uint8 list count with
    int32 indices, and an extra element after the faces (all of which a reader must skip or handle)."""
    n = len(mesh.vertices)
    vert = np.zeros(n, dtype=[("x", ">f8"), ("y", ">f8"), ("z", ">f8"), ("quality", ">u2")])
    vert["x"], vert["y"], vert["z"] = mesh.vertices.T
    vert["quality"] = np.arange(n) % 1000
    face = np.zeros(len(mesh.faces), dtype=[("vertex_indices", "O"), ("flags", ">i2")])
    face["vertex_indices"] = [np.asarray(f, dtype=">i4") for f in mesh.faces]
    extra = np.array([(1.5, 7)], dtype=[("weight", ">f4"), ("id", ">i4")])
    plyfile.PlyData(
        [
            plyfile.PlyElement.describe(vert, "vertex"),
            plyfile.PlyElement.describe(face, "face", val_types={"vertex_indices": "i4"},
                                        len_types={"vertex_indices": "u1"}),
            plyfile.PlyElement.describe(extra, "material"),
        ],
        text=False,
        byte_order=">",
        comments=["written by plyfile for gregvox's loader tests"],
    ).write(path)


def check_positions(name, expected, transform=None):
    """Re-reads `name` with trimesh (plyfile for the big-endian PLY) and checks the position set exactly."""
    path = os.path.join(OUT, name)
    if name == "m_be.ply":
        d = plyfile.PlyData.read(path)["vertex"]
        got = np.stack([d["x"], d["y"], d["z"]], axis=1).astype(np.float64)
    else:
        loaded = trimesh.load(path, process=False)
        if isinstance(loaded, trimesh.Scene):
            got = np.concatenate([g.vertices for g in loaded.dump()], axis=0)
        else:
            got = np.asarray(loaded.vertices)
    want = expected if transform is None else transform(expected)
    a = np.unique(np.asarray(got, dtype=np.float64), axis=0)
    b = np.unique(want, axis=0)
    if a.shape != b.shape or not np.array_equal(a, b):
        sys.exit(f"{name}: positions read back differ from the quantized mesh")


def main():
    os.makedirs(OUT, exist_ok=True)
    mesh = base_mesh()
    write("m.obj", trimesh.exchange.obj.export_obj(mesh, include_normals=False, include_color=False,
                                                   include_texture=False, digits=8))
    write("m_ascii.stl", trimesh.exchange.stl.export_stl_ascii(mesh))
    write("m_binary.stl", trimesh.exchange.stl.export_stl(mesh))
    write("m_ascii.ply", trimesh.exchange.ply.export_ply(mesh, encoding="ascii", vertex_normal=False,
                                                         include_attributes=False))
    write("m_le.ply", trimesh.exchange.ply.export_ply(mesh, encoding="binary", vertex_normal=False,
                                                      include_attributes=False))
    write_be_ply(mesh, os.path.join(OUT, "m_be.ply"))
    write("m.off", trimesh.exchange.off.export_off(mesh, digits=8))
    write("m.glb", trimesh.exchange.gltf.export_glb(two_part_scene(mesh), include_normals=False))
    write("m_moved.glb", trimesh.exchange.gltf.export_glb(moved_scene(mesh), include_normals=False))
    files = trimesh.exchange.gltf.export_gltf(two_part_scene(mesh), include_normals=False,
                                              merge_buffers=True)
    doc = json.loads(files.pop("model.gltf"))
    (bin_name, bin_data), = files.items()
    doc["buffers"][0]["uri"] = "m.bin"  # trimesh names it gltf_buffer_*.bin; renamed with its reference
    write("m.gltf", json.dumps(doc, indent=1))
    write("m.bin", bin_data)
    emb = trimesh.exchange.gltf.export_gltf(two_part_scene(mesh), include_normals=False,
                                            embed_buffers=True)
    write("m_embedded.gltf", emb["model.gltf"].decode() if isinstance(emb["model.gltf"], bytes)
          else emb["model.gltf"])

    v = np.asarray(mesh.vertices)
    for name in ["m.obj", "m_ascii.stl", "m_binary.stl", "m_ascii.ply", "m_le.ply", "m_be.ply", "m.off",
                 "m.glb", "m.gltf", "m_embedded.gltf"]:
        check_positions(name, v)
    check_positions("m_moved.glb", v, lambda p: MOVE_SCALE * (p + MOVE_TRANSLATION))
    total = sum(os.path.getsize(os.path.join(OUT, f)) for f in os.listdir(OUT))
    print(f"{len(v)} vertices, {len(mesh.faces)} triangles; {total} bytes in {OUT}")
    print(f"trimesh {trimesh.__version__}, plyfile {importlib.metadata.version('plyfile')}, numpy {np.__version__}, "
          f"python {sys.version.split()[0]}")


if __name__ == "__main__":
    main()

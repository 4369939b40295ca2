#!/usr/bin/env python3
"""Generate the mesh oracle fixtures in tests/fixtures/mesh/ from libigl and trimesh.

Run from the repository root (models in assets/models):
    python3 -m pip install -r tests/oracle/requirements-mesh.txt
    python3 tests/oracle/gen_mesh.py

Traps handled:
- meshes are read with a plain text reader (positions as given, no welding, unreferenced vertices kept);
  trimesh always gets process=False;
- libigl gives NaN normals to unreferenced vertices: the fixture keeps them, the Rust test skips them;
- trimesh.vertex_normals is ANGLE weighted, libigl's default is AREA.

Binary files are little-endian: *.f64 = rows of 3 float64; *.u32 = flat uint32.
"""
import json
import os
import sys
from importlib.metadata import version

import igl
import numpy as np
import scipy
import trimesh

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = os.path.join(ROOT, "assets", "models")
OUT = os.path.join(ROOT, "tests", "fixtures", "mesh")


def read_obj(path):
    """Positions in file order and polygon faces (0-based), like gregvox::mesh::load_obj."""
    V, F = [], []
    with open(path) as fh:
        for line in fh:
            t = line.split("#")[0].split()
            if not t:
                continue
            if t[0] == "v":
                V.append([float(x) for x in t[1:4]])
            elif t[0] == "f":
                face = []
                for tok in t[1:]:
                    i = int(tok.split("/")[0])
                    face.append(i - 1 if i > 0 else len(V) + i)
                F.append(face)
    return np.array(V, dtype=np.float64), F


def tri(F):
    return np.array(F, dtype=np.int64)


def write_f64(name, a):
    np.ascontiguousarray(a, dtype="<f8").tofile(os.path.join(OUT, name))


def write_u32(name, a):
    np.ascontiguousarray(a, dtype="<u4").tofile(os.path.join(OUT, name))


def main():
    os.makedirs(OUT, exist_ok=True)
    summary = {
        "versions": {
            "libigl": version("libigl"),
            "trimesh": trimesh.__version__,
            "numpy": np.__version__,
            "scipy": scipy.__version__,
        },
        "meshes": {},
    }
    for name in ["stanford-bunny", "spot", "cow", "teapot"]:
        V, Fl = read_obj(os.path.join(MODELS, name + ".obj"))
        F = tri(Fl)
        referenced = np.zeros(len(V), dtype=bool)
        referenced[F.ravel()] = True
        info = {}
        # 1. AREA vertex normals (libigl default), all vertices (NaN rows = unreferenced).
        if name in ("stanford-bunny", "spot", "cow"):
            N = igl.per_vertex_normals(V, F)
            write_f64(f"{name}.normals_area.f64", N)
        if name == "spot":
            # ANGLE weighting: trimesh's vertex_normals (= libigl ANGLE).
            tm = trimesh.Trimesh(V, F, process=False)
            write_f64(f"{name}.normals_angle_trimesh.f64", np.asarray(tm.vertex_normals))
        # 2. Face adjacency pattern: upper-triangle pairs (i < j) in row-major order.
        A = igl.facet_adjacency_matrix(F).tocoo()
        pairs = np.array(sorted({(int(i), int(j)) for i, j in zip(A.row, A.col) if i < j}), dtype=np.int64)
        write_u32(f"{name}.facet_adjacency.u32", pairs.ravel())
        info["facet_adjacency_pairs"] = int(len(pairs))
        # 3. Components.
        info["facet_components"] = int(igl.facet_components(F)[0])
        tm = trimesh.Trimesh(V, F, process=False)
        body = int(tm.body_count)
        info["trimesh_body_count"] = body
        info["unreferenced_vertices"] = int((~referenced).sum())
        info["vertex_components"] = body - int((~referenced).sum())
        # 4. Edge manifoldness and boundary.
        ok, BF, E, EMAP, BE = igl.is_edge_manifold(F)
        info["edge_manifold"] = bool(ok)
        uE = igl.edges(F)
        info["edges"] = int(len(uE))
        # boundary edges = undirected edges used by exactly one face
        dir_e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
        und = np.sort(dir_e, axis=1)
        _, counts = np.unique(und, axis=0, return_counts=True)
        info["boundary_edges"] = int((counts == 1).sum())
        info["non_manifold_edges"] = int((counts > 2).sum())
        info["trimesh_is_watertight"] = bool(tm.is_watertight)
        # 5. Non-manifold (pinched) vertices among referenced ones.
        vm = igl.is_vertex_manifold(F)
        info["non_manifold_vertices"] = [int(v) for v in np.nonzero(~vm & referenced)[0]]
        # 6. Valence = igl.adjacency_list sizes; ordered rings (sorted=True, CCW) for spot.
        adj = igl.adjacency_list(F)
        hist = {}
        for v in range(len(V)):
            if referenced[v]:
                k = len(adj[v])
                hist[str(k)] = hist.get(str(k), 0) + 1
        info["valence_histogram"] = hist
        if name == "spot":
            rings = igl.adjacency_list(F, True)
            with open(os.path.join(OUT, "spot.one_rings.json"), "w") as fh:
                json.dump([list(map(int, r)) for r in rings], fh, separators=(",", ":"))
            # faces per vertex = degree counts of vertex_triangle_adjacency
            VF, NI = igl.vertex_triangle_adjacency(F, len(V))
            write_u32("spot.faces_per_vertex.u32", np.diff(NI))
            # 7. Loop subdivision, one level: libigl (Warren β) and trimesh (Loop's β).
            NV, NF = igl.loop(V, F, 1)
            write_f64("spot.loop_igl.f64", NV)
            TV, TF = trimesh.remesh.subdivide_loop(V, F, iterations=1)
            write_f64("spot.loop_trimesh.f64", TV)
            info["loop_igl_vertices"] = int(len(NV))
            info["loop_trimesh_vertices"] = int(len(TV))
        if name == "cow":
            # Loop's β on the pinched cow: trimesh sees both fans of vertex 253 (libigl sees one, notes A.6)
            TV, TF = trimesh.remesh.subdivide_loop(V, F, iterations=1)
            write_f64("cow.loop_trimesh.f64", TV)
        summary["meshes"][name] = info
        print(name, json.dumps(info)[:200], file=sys.stderr)
    # suzanne: polygons; components via trimesh on a fan triangulation (the same vertex graph).
    V, Fl = read_obj(os.path.join(MODELS, "suzanne.obj"))
    Ft = np.array([[f[0], f[k], f[k + 1]] for f in Fl for k in range(1, len(f) - 1)], dtype=np.int64)
    tm = trimesh.Trimesh(V, Ft, process=False)
    summary["meshes"]["suzanne"] = {"trimesh_body_count": int(tm.body_count)}
    with open(os.path.join(OUT, "summary.json"), "w") as fh:
        json.dump(summary, fh, indent=1, sort_keys=True)


if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Time libigl and trimesh on the work that benches/mesh.rs measures for gregvox (CPU).

Run from the repository root: python3 tests/oracle/bench_mesh_peers.py [--repeat N] [--json OUT]

Meshes: the Stanford bunny (69,451 triangles, read as given) and the bunny after two Loop levels with
libigl (1,111,216 triangles), the same sizes as gregvox's `bunny` and `bunny_loop2`.

What each peer does (stated honestly; neither library has Catmull–Clark):
- normals, libigl: igl.per_vertex_normals(V, F) (AREA weighting, = gregvox NormalWeighting::Area);
- normals, trimesh: a fresh trimesh.Trimesh(V, F, process=False).vertex_normals (ANGLE weighting,
  includes face normals and corner angles; construction without processing is included);
- one subdivision level, libigl: igl.loop(V, F, 1) (Loop, Warren β) and igl.upsample(V, F, 1) (midpoint
  split, no smoothing);
- one subdivision level, trimesh: trimesh.remesh.subdivide_loop(V, F, 1) (Loop, Loop's β) and
  trimesh.remesh.subdivide(V, F) (midpoint split).
Compare them with gregvox's `loop_level` (same operation) and `cc_level` (Catmull–Clark: more output,
one quad per corner). Times are the median of --repeat runs after one warm-up, single process.
"""
import argparse
import json
import os
import platform
import statistics
import time
from importlib.metadata import version

import igl
import numpy as np
import trimesh

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = os.path.join(ROOT, "assets", "models")


def read_obj(path):
    V, F = [], []
    with open(path) as fh:
        for line in fh:
            t = line.split("#")[0].split()
            if not t:
                continue
            if t[0] == "v":
                V.append([float(x) for x in t[1:4]])
            elif t[0] == "f":
                F.append([int(x.split("/")[0]) - 1 for x in t[1:]])
    return np.array(V, dtype=np.float64), np.array(F, dtype=np.int64)


def median_time(fn, repeat):
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    V, F = read_obj(os.path.join(MODELS, "stanford-bunny.obj"))
    # trimesh.remesh.subdivide_loop fails on unreferenced vertices (valence 0 → β = NaN): give every peer
    # the bunny without its 1,113 unreferenced vertices (gregvox keeps them; their cost is negligible).
    used = np.unique(F)
    remap = np.full(len(V), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    V, F = np.ascontiguousarray(V[used]), remap[F]
    V2, F2 = igl.loop(V, F, 2)
    meshes = {"bunny": (V, F), "bunny_loop2": (np.ascontiguousarray(V2), np.ascontiguousarray(F2))}
    ops = {
        "normals/libigl per_vertex_normals (AREA)": lambda V, F: igl.per_vertex_normals(V, F),
        "normals/trimesh vertex_normals (ANGLE)": lambda V, F: trimesh.Trimesh(V, F, process=False).vertex_normals,
        "subdivide/libigl loop (Warren)": lambda V, F: igl.loop(V, F, 1),
        "subdivide/libigl upsample (midpoint)": lambda V, F: igl.upsample(V, F, 1),
        "subdivide/trimesh subdivide_loop (Loop beta)": lambda V, F: trimesh.remesh.subdivide_loop(V, F, 1),
        "subdivide/trimesh subdivide (midpoint)": lambda V, F: trimesh.remesh.subdivide(V, F),
    }
    results = []
    print(f"# {platform.processor() or platform.machine()}, python {platform.python_version()}, "
          f"libigl {version('libigl')}, trimesh {trimesh.__version__}, numpy {np.__version__}")
    print(f"{'mesh':12} {'faces':>9} {'operation':48} {'ms':>10} {'Mfaces/s':>9}")
    for mname, (MV, MF) in meshes.items():
        for oname, fn in ops.items():
            repeat = args.repeat if len(MF) < 200_000 else max(2, args.repeat // 2)
            t = median_time(lambda: fn(MV, MF), repeat)
            rate = len(MF) / t / 1e6
            results.append({"mesh": mname, "faces": int(len(MF)), "op": oname, "seconds": t})
            print(f"{mname:12} {len(MF):9d} {oname:48} {t * 1e3:10.2f} {rate:9.2f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(results, fh, indent=1)


if __name__ == "__main__":
    main()

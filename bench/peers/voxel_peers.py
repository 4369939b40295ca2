#!/usr/bin/env python3
"""Voxelization peers for `gregvox bench` (suite `voxel`), timed in the same run as gregvox.

Usage: voxel_peers.py MESH.obj RES OX OY OZ PITCH REPEATS [--no-trimesh] [--no-igl]

The grid is gregvox's: RES^3 voxels of edge PITCH whose minimum corner is (OX, OY, OZ); voxel (i, j, k) is
solid when its centre is inside.
- libigl: igl.fast_winding_number(V, F, centres) >= 0.5 at every voxel centre (libigl's own threading).
  Timed: the winding-number call and the threshold (building the centre array is not timed).
- trimesh: trimesh.Trimesh(V, F).voxelized(PITCH).fill() (surface voxels by subdivision, then a
  flood fill). trimesh places its own grid (voxel centres at integer multiples of PITCH), so it is the same
  pitch and extent, not the same voxel centres.
Prints one JSON object: {"igl_s", "igl_solid", "trimesh_s", "trimesh_solid", "versions"} (median seconds
of REPEATS runs after one warm-up for RES <= 128; a single run above).
"""
import json
import statistics
import sys
import time
from importlib.metadata import version

import numpy as np


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
                idx = [int(x.split("/")[0]) for x in t[1:]]
                idx = [i - 1 if i > 0 else len(V) + i for i in idx]
                for k in range(1, len(idx) - 1):
                    F.append([idx[0], idx[k], idx[k + 1]])
    return np.array(V, dtype=np.float64), np.array(F, dtype=np.int64)


def timed(fn, repeat):
    out = None
    times = []
    for r in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def main():
    a = sys.argv[1:]
    flags = {x for x in a if x.startswith("--")}
    a = [x for x in a if not x.startswith("--")]
    path, res = a[0], int(a[1])
    origin = np.array([float(a[2]), float(a[3]), float(a[4])])
    pitch, repeat = float(a[5]), max(1, int(a[6]))
    if res > 128:
        repeat = 1
    V, F = read_obj(path)
    out = {"versions": {}}
    if "--no-igl" not in flags:
        import igl
        out["versions"]["libigl"] = version("libigl")
        ax = origin[0] + (np.arange(res) + 0.5) * pitch
        ay = origin[1] + (np.arange(res) + 0.5) * pitch
        az = origin[2] + (np.arange(res) + 0.5) * pitch
        Q = np.stack(np.meshgrid(ax, ay, az, indexing="ij"), axis=-1).reshape(-1, 3)
        fn = lambda: igl.fast_winding_number(V, F, Q) >= 0.5
        if res <= 128:
            fn()
        s, inside = timed(fn, repeat)
        out["igl_s"] = s
        out["igl_solid"] = int(inside.sum())
    if "--no-trimesh" not in flags:
        import trimesh
        out["versions"]["trimesh"] = trimesh.__version__
        mesh = trimesh.Trimesh(V, F, process=False)
        fn = lambda: mesh.voxelized(pitch).fill()
        if res <= 128:
            fn()
        s, grid = timed(fn, repeat)
        out["trimesh_s"] = s
        out["trimesh_solid"] = int(grid.filled_count)
    print(json.dumps(out))


if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""The level-set peer of `gregvox bench` (suite `writers`, table `level_set`): OpenVDB's own
meshToLevelSet through its Python module (Debian `python3-openvdb`, so run by the system Python).

Usage: levelset_peer.py MESH.obj VOXEL_SIZE ORIGIN_X,ORIGIN_Y,ORIGIN_Z HALF_WIDTH REPEATS

Builds `FloatGrid.createLevelSetFromPolygons` (exact distances in the band, the sign from OpenVDB's
flood fill of the narrow band, made for closed meshes) with a transform putting voxel centres where
gregvox puts them, REPEATS times after one warm-up, and prints one JSON object: the median seconds and
the active voxel count.
"""
import json
import statistics
import sys
import time

import numpy as np
import pyopenvdb as vdb


def read_obj(path):
    V, F = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p:
                continue
            if p[0] == "v":
                V.append([float(x) for x in p[1:4]])
            elif p[0] == "f":
                idx = [int(x.split("/")[0]) for x in p[1:]]
                idx = [i - 1 if i > 0 else len(V) + i for i in idx]
                F.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return np.array(V, dtype=np.float32), np.array(F, dtype=np.int32)


def main():
    V, F = read_obj(sys.argv[1])
    h = float(sys.argv[2])
    origin = [float(x) for x in sys.argv[3].split(",")]
    half_width = float(sys.argv[4])
    repeats = max(1, int(sys.argv[5]))
    xf = vdb.createLinearTransform(voxelSize=h)
    xf.translate([o + 0.5 * h for o in origin])

    def build():
        return vdb.FloatGrid.createLevelSetFromPolygons(V, triangles=F, transform=xf, halfWidth=half_width)

    build()
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        g = build()
        times.append(time.perf_counter() - t)
    print(json.dumps({"seconds": statistics.median(times), "active": int(g.activeVoxelCount())}))


if __name__ == "__main__":
    main()

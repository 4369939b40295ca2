#!/usr/bin/env python3
"""The quality of reduced meshes, measured independently of gregvox (trimesh sampling, libigl distances).

Run from the repository root:
    python3 tests/oracle/simplify_quality.py REFERENCE.obj OUT1.obj [OUT2.obj ...] [--samples N] [--seed S]

For each output: N area-weighted surface samples of the reference plus its vertices, and N of the output
plus its vertices; the distance of each to the other surface (igl.point_mesh_squared_distance, exact
point-triangle distances); prints one JSON line per output with `faces`, `hausdorff` (the largest of the
two one-sided maxima) and `mean` (the mean of both directions' samples), both in percent of the
reference's bounding-box diagonal. `gregvox bench --suite simplify` runs it on every reducer's output.
"""
import argparse
import json

import igl
import numpy as np
import trimesh


def load(path):
    m = trimesh.load(path, force="mesh", process=False)
    return np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces, dtype=np.int64), m


def samples(mesh, v, n, seed):
    pts, _ = trimesh.sample.sample_surface(mesh, n, seed=seed)
    used = np.unique(np.asarray(mesh.faces).ravel())
    return np.vstack([np.asarray(pts, dtype=np.float64), v[used]])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("reference")
    ap.add_argument("outputs", nargs="+")
    ap.add_argument("--samples", type=int, default=200000)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    rv, rf, rm = load(a.reference)
    diag = float(np.linalg.norm(rv[np.unique(rf)].max(0) - rv[np.unique(rf)].min(0)))
    ref_pts = samples(rm, rv, a.samples, a.seed)
    for path in a.outputs:
        ov, of, om = load(path)
        if len(of) == 0:
            print(json.dumps({"mesh": path, "faces": 0, "hausdorff": None, "mean": None}), flush=True)
            continue
        out_pts = samples(om, ov, a.samples, a.seed + 1)
        d1 = np.sqrt(igl.point_mesh_squared_distance(ref_pts, ov, of)[0])
        d2 = np.sqrt(igl.point_mesh_squared_distance(out_pts, rv, rf)[0])
        print(json.dumps({
            "mesh": path,
            "faces": int(len(of)),
            "hausdorff": 100.0 * float(max(d1.max(), d2.max())) / diag,
            "mean": 100.0 * float(np.concatenate([d1, d2]).mean()) / diag,
        }), flush=True)


if __name__ == "__main__":
    main()

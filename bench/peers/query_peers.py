#!/usr/bin/env python3
"""Point-query peers for `gregvox bench` (suite `query`), timed in the same run as gregvox.

Usage: query_peers.py MESH.obj POINTS.npy REPEATS [--exact]

On the points of POINTS.npy ((N, 3) float64), with libigl's own threading (all cores):
- fwn: igl.fast_winding_number(V, F, P) (Barnes & Jacobson: approximate, no error bound per query);
- sdf: igl.signed_distance(P, V, F, sign_type=SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER) (the distance
  and its sign from the fast winding number);
- udf: igl.point_mesh_squared_distance(P, V, F);
- exact (with --exact): igl.winding_number(V, F, P), the exact sum (slow: 0.02 M points/s).
Prints one JSON object of median seconds of REPEATS runs (after one warm-up) and the answers' agreement
figures: {"fwn_s", "sdf_s", "udf_s", "exact_s", "fwn", "udf"} with the values as lists when asked.
"""
import json
import sys

import numpy as np

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from voxel_peers import read_obj  # noqa: E402
from voxel_peers import timed as voxel_timed  # noqa: E402


def timed(fn, repeat):
    fn()  # warm-up: libigl's first call pays for loading and allocation
    return voxel_timed(fn, repeat)


def main():
    import igl

    a = [x for x in sys.argv[1:] if not x.startswith("--")]
    flags = {x for x in sys.argv[1:] if x.startswith("--")}
    V, F = read_obj(a[0])
    P = np.ascontiguousarray(np.load(a[1]), dtype=np.float64)
    repeat = max(1, int(a[2]))
    out = {}
    out["fwn_s"], w = timed(lambda: igl.fast_winding_number(V, F, P), repeat)
    out["fwn_inside"] = int((w >= 0.5).sum())
    st = igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER
    out["sdf_s"], s = timed(lambda: igl.signed_distance(P, V, F, sign_type=st), repeat)
    out["sdf_negative"] = int((s[0] < 0).sum())
    out["udf_s"], d = timed(lambda: igl.point_mesh_squared_distance(P, V, F), repeat)
    out["udf_max"] = float(np.sqrt(d[0]).max())
    if "--exact" in flags:
        out["exact_s"], e = timed(lambda: igl.winding_number(V, F, P), 1)
        out["exact_inside"] = int((np.abs(e) >= 0.5).sum())
    print(json.dumps(out))


if __name__ == "__main__":
    main()

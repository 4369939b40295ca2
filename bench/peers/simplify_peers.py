#!/usr/bin/env python3
"""The Python peers of `gregvox bench --suite simplify`: fast-simplification (Fast Quadric Mesh
Simplification, as PyVista users call it) and pyfqmr (the same algorithm, as its users call it), each
reducing the mesh to every ratio; prints one JSON line per peer and ratio (seconds: the best of --repeat
runs of the reducing call alone; the output written to OUT_DIR/<peer>_<ratio>.obj for the quality
measurement). A peer that is not installed prints {"peer": ..., "missing": "..."}.

    python3 bench/peers/simplify_peers.py MESH.obj 0.5,0.1,0.01 OUT_DIR [--repeat N]
"""
import argparse
import json
import os
import time

import numpy as np
import trimesh


def write_obj(path, v, f):
    with open(path, "w") as out:
        out.write("".join(f"v {a} {b} {c}\n" for a, b, c in v))
        out.write("".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in f))


def best(repeat, fn):
    t_best, result = float("inf"), None
    for _ in range(max(1, repeat)):
        t = time.perf_counter()
        result = fn()
        t_best = min(t_best, time.perf_counter() - t)
    return t_best, result


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("ratios")
    ap.add_argument("out_dir")
    ap.add_argument("--repeat", type=int, default=1)
    a = ap.parse_args()
    m = trimesh.load(a.mesh, force="mesh", process=False)
    V = np.ascontiguousarray(m.vertices, dtype=np.float64)
    F = np.ascontiguousarray(m.faces, dtype=np.int64)
    ratios = [float(r) for r in a.ratios.split(",")]
    try:
        import fast_simplification

        for r in ratios:
            s, (v, f) = best(a.repeat, lambda: fast_simplification.simplify(V, F, target_reduction=1.0 - r))
            out = os.path.join(a.out_dir, f"fast-simplification_{r}.obj")
            write_obj(out, v, f)
            print(json.dumps({"peer": "fast-simplification", "ratio": r, "faces": int(len(f)), "seconds": s, "out": out}), flush=True)
    except ModuleNotFoundError as e:
        print(json.dumps({"peer": "fast-simplification", "missing": str(e)}), flush=True)
    try:
        import pyfqmr

        for r in ratios:
            def run():
                s = pyfqmr.Simplify()
                s.setMesh(V, F.astype(np.int32))
                s.simplify_mesh(target_count=int(len(F) * r), aggressiveness=7, preserve_border=True, verbose=False)
                return s.getMesh()[:2]

            s, (v, f) = best(a.repeat, run)
            out = os.path.join(a.out_dir, f"pyfqmr_{r}.obj")
            write_obj(out, v, f)
            print(json.dumps({"peer": "pyfqmr", "ratio": r, "faces": int(len(f)), "seconds": s, "out": out}), flush=True)
    except ModuleNotFoundError as e:
        print(json.dumps({"peer": "pyfqmr", "missing": str(e)}), flush=True)


if __name__ == "__main__":
    main()

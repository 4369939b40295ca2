#!/usr/bin/env python3
"""Generate the million-point query fixtures in tests/fixtures/query/ (libigl's exact winding_number).

Run from the repository root:
    cargo run --release --example gwn_stress -- target/gwn-stress
    python3 -m pip install -r tests/oracle/requirements-voxel.txt
    python3 tests/oracle/gen_query.py target/gwn-stress

Per mesh (the Stanford bunny with its five holes, the bunny with 5 % of its triangles removed, the unwelded
noisy soup: gregvox's stress cases, checked by their FNV-1a hashes), 10^6 points uniform in the box of the
vertices the faces use, padded by 10 % per side, and 10^6 near the surface, drawn exactly as
tests/query_points.rs draws them (SplitMix64, seed 2026; the same float64 operations in the same order, so the
same bits: the index records an FNV-1a of the first and last 10,000 points and the Rust test checks it first):
- uniform point: lo - 0.1*size + 1.2*size*unit() per axis;
- near point: a triangle below(T), (u, v) = (unit(), unit()) folded into the triangle (u + v > 1: 1 - u,
  1 - v), then per axis c0 + u*(c1 - c0) + v*(c2 - c0) + (unit() + unit() + unit() - 1.5)*0.01*size.

w is the EXACT generalized winding number of the cleaned triangles (gregvox's hygiene, gen_gwn_stress.clean):
igl.fast_winding_number everywhere, replaced by igl.winding_number (the plain sum of solid angles) wherever
|fast -+ 1/2| < TAU or the point lies within NEAR (a fraction of the box diagonal) of a triangle: there the
fast value is not to be trusted (on the soup, a point 1.4e-9 from a triangle got -0.006 for an exact 0.994,
below float32's resolution of the coordinates). Elsewhere the decision is the exact one because the fast
value is within TAU of the exact one, which the script checks on 20,000 random points per mesh (max error
< TAU/4 asserted).

Files (zlib): the occupancy |w| >= 1/2 of the 2*10^6 points (uniform first) as np.packbits(bitorder='little'),
then the exact w (float64 little-endian) at every STRIDE-th point. The index lists the points whose exact
|w| lies within 1e-6 of 1/2 (where occupancy is not compared). The Rust tests never run Python.
"""
import importlib.metadata
import json
import os
import sys
import time
import zlib

import igl
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen_gwn import exact_w, read_obj  # noqa: E402
from gen_gwn_stress import clean, fnv1a  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "tests", "fixtures", "query")
BUNNY = os.path.join(ROOT, "assets", "models", "stanford-bunny.obj")
N = 1_000_000
SEED = 2026
STRIDE = 500
TAU = 0.2
NEAR = 1e-5
CASES = ["bunny_holes_5pct", "bunny_soup"]
M64 = (1 << 64) - 1


def splitmix_units(seed, count, start):
    """unit() values number start+1 … start+count of SplitMix64(seed) (each next_u64 adds gamma first)."""
    k = np.arange(start + 1, start + count + 1, dtype=np.uint64)
    with np.errstate(over="ignore"):
        z = np.uint64(seed) + k * np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return (z >> np.uint64(11)).astype(np.float64) / float(1 << 53)


def points(V, F, n, seed):
    used = V[np.unique(F)]
    lo, hi = used.min(axis=0), used.max(axis=0)
    size = hi - lo
    u = splitmix_units(seed, 3 * n, 0).reshape(n, 3)
    uniform = (lo - 0.1 * size) + (1.2 * size) * u
    r = splitmix_units(seed, 12 * n, 3 * n).reshape(n, 12)
    tri = (r[:, 0] * len(F)).astype(np.int64) % len(F)
    a, b = r[:, 1].copy(), r[:, 2].copy()
    fold = a + b > 1.0
    a[fold], b[fold] = 1.0 - a[fold], 1.0 - b[fold]
    c0, c1, c2 = V[F[tri, 0]], V[F[tri, 1]], V[F[tri, 2]]
    near = np.empty((n, 3))
    for axis in range(3):
        s = (r[:, 3 + 3 * axis] + r[:, 4 + 3 * axis] + r[:, 5 + 3 * axis] - 1.5) * 0.01 * size[axis]
        near[:, axis] = c0[:, axis] + a * (c1[:, axis] - c0[:, axis]) + b * (c2[:, axis] - c0[:, axis]) + s
    return np.concatenate([uniform, near])


def digest(P):
    ends = np.concatenate([P[:10000], P[-10000:]])
    return "%016x" % fnv1a(np.ascontiguousarray(ends, dtype="<f8").tobytes())


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: gen_query.py DIR (DIR: what `cargo run --example gwn_stress -- DIR` wrote)")
    listing = {c["name"]: c for c in json.load(open(os.path.join(sys.argv[1], "index.json")))["cases"]}
    os.makedirs(OUT, exist_ok=True)
    index = {
        "generator": "tests/oracle/gen_query.py (meshes: cargo run --example gwn_stress)",
        "versions": {p: importlib.metadata.version(p) for p in ("libigl", "numpy")},
        "points": N, "seed": SEED, "stride": STRIDE, "tau": TAU, "near": NEAR,
        "layout": "zlib( packbits(|w| >= 1/2 of uniform then near points, bitorder=little) || exact w float64 LE "
                  "at every stride-th point )",
        "cases": [],
    }
    cases = [("stanford-bunny", BUNNY, None)]
    for name in CASES:
        cases.append((name, os.path.join(sys.argv[1], listing[name]["file"]), listing[name]["fnv1a"]))
    for name, path, expected in cases:
        t0 = time.time()
        mesh_hash = "%016x" % fnv1a(open(path, "rb").read())
        if expected is not None:
            assert mesh_hash == expected, (name, mesh_hash, expected)
        V, F = read_obj(path)
        P = points(V, F, N, SEED)
        F = clean(V, F)
        w = igl.fast_winding_number(V, F, P)
        rng = np.random.default_rng(fnv1a(name.encode()) & 0xFFFFFFFF)
        sample = rng.choice(len(P), 20000, replace=False)
        fast_err = float(np.abs(exact_w(V, F, P[sample]) - w[sample]).max())
        assert fast_err < TAU / 4, (name, fast_err)
        used = V[np.unique(F)]
        diagonal = float(np.linalg.norm(used.max(axis=0) - used.min(axis=0)))
        d2 = igl.point_mesh_squared_distance(P, V, F)[0]
        close = d2 < (NEAR * diagonal) ** 2
        idx = np.nonzero((np.abs(w - 0.5) < TAU) | (np.abs(w + 0.5) < TAU) | close)[0]
        w[idx] = exact_w(V, F, P[idx])
        strided = np.arange(0, len(P), STRIDE)
        w_strided = w[strided].copy()
        missing = np.setdiff1d(strided, idx)
        # The strided values must be exact, not fast.
        w_strided[np.searchsorted(strided, missing)] = exact_w(V, F, P[missing])
        occupancy = np.abs(w) >= 0.5
        near_half = np.nonzero(np.abs(np.abs(w) - 0.5) <= 1e-6)[0]
        blob = np.packbits(occupancy, bitorder="little").tobytes() + w_strided.astype("<f8").tobytes()
        file = f"{name}.bin.z"
        with open(os.path.join(OUT, file), "wb") as fh:
            fh.write(zlib.compress(blob, 9))
        index["cases"].append({
            "model": name,
            "source": os.path.relpath(path, ROOT) if expected is None else f"stress:{name}",
            "fnv1a": mesh_hash,
            "points_fnv1a": digest(P),
            "triangles": int(len(F)),
            "inside_uniform": int(occupancy[:N].sum()),
            "inside_near": int(occupancy[N:].sum()),
            "exact_points": int(len(idx) + len(missing)),
            "close_points": int(close.sum()),
            "max_fast_error": fast_err,
            "near_half": [int(i) for i in near_half],
            "file": file,
        })
        print(f"{name}: {len(idx)} exact ({int(close.sum())} close), fast error {fast_err:.2e}, {int(occupancy.sum())} inside, "
              f"{time.time() - t0:.1f} s", flush=True)
    with open(os.path.join(OUT, "index.json"), "w") as fh:
        json.dump(index, fh, indent=1)
        fh.write("\n")


if __name__ == "__main__":
    main()

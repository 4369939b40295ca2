#!/usr/bin/env python3
"""Generate the stress-suite fixtures in tests/fixtures/gwn_stress/ (libigl's exact winding_number).

Run from the repository root:
    cargo run --release --example gwn_stress -- target/gwn-stress
    python3 -m pip install -r tests/oracle/requirements-voxel.txt
    python3 tests/oracle/gen_gwn_stress.py target/gwn-stress

The meshes are gregvox's own stress suite (src/voxel/stress.rs), written as OBJ by the example; their FNV-1a
hashes go into index.json, and the Rust tests regenerate each mesh and check the hash before trusting a
mask. The bunny itself (assets/models/stanford-bunny.obj) is the baseline case. `--only NAME[,NAME…]`
regenerates those cases and keeps the others of an existing index.json.

The winding number is that of the triangles after gregvox's documented hygiene (voxel::mesh::TriMesh::clean),
which changes no winding number off the surface except where a face is duplicated: triangles over the same
three positions (float32 bits) are netted by orientation (equal ones kept once, opposite ones cancelled in
pairs) and triangles whose float64 cross product is exactly zero are dropped.

Per mesh, at R = 128, on the grid of `gregvox voxelize --res R` (origin = box minimum of the float32
positions the faces use, side = the longest extent, centre(i,j,k) = origin + (i+1/2, j+1/2, k+1/2)*side/R):
- `magnitude`: |w(centre)| >= 1/2 and `positive`: w(centre) >= 1/2, w the EXACT generalized winding number
  (igl.winding_number: the plain sum of solid angles, in float64 on the float32 positions);
- exactness: w_fast = igl.fast_winding_number everywhere, and the exact w at every centre where
  |w_fast - 1/2| < TAU or |w_fast + 1/2| < TAU. Elsewhere the decision is the exact one because the fast
  value is within TAU of it, which the script checks on 20,000 random centres per mesh
  (max |w_fast - w| < TAU / 4 asserted).
Masks are bool [i, j, k] (x, y, z), C order, np.packbits(bitorder='little'), then (value, run) byte pairs
(tests/common::unrle). The Rust tests never run Python.
"""
import importlib.metadata
import json
import os
import sys
import time

import igl
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from gen_gwn import centres, exact_w, read_obj, rle  # noqa: E402  (reader, encoding, exact sums: shared)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "tests", "fixtures", "gwn_stress")
BUNNY = os.path.join(ROOT, "assets", "models", "stanford-bunny.obj")
RES = 128
TAU = 0.2


def fnv1a(data):
    h = 0xCBF29CE484222325
    for b in data:
        h ^= b
        h = (h * 0x100000001B3) & 0xFFFFFFFFFFFFFFFF
    return h


def clean(V, F):
    """gregvox's hygiene: duplicate triangles kept once, opposite pairs cancelled, zero-area ones dropped."""
    E1, E2 = V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]
    F = F[np.any(np.cross(E1, E2) != 0.0, axis=1)]
    bits = V.astype(np.float32).view(np.uint32)
    groups = {}
    order = []
    for i, t in enumerate(F):
        p = [tuple(int(b) for b in bits[v]) for v in t]
        r = min(range(3), key=lambda k: p[k])
        a, b, c = p[r], p[(r + 1) % 3], p[(r + 2) % 3]
        key, forward = ((a, b, c), True) if b < c else ((a, c, b), False)
        if key not in groups:
            groups[key] = ([], [])
            order.append(key)
        groups[key][0 if forward else 1].append(i)
    keep = []
    for key in order:
        f, b = groups[key]
        net = len(f) - len(b)
        if net > 0:
            keep.append(f[0])
        elif net < 0:
            keep.append(b[0])
    return F[np.sort(np.array(keep, dtype=np.int64))]


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--only")]
    only = [a.split("=", 1)[1].split(",") for a in sys.argv[1:] if a.startswith("--only=")]
    only = set(only[0]) if only else None
    if len(args) != 1:
        sys.exit("usage: gen_gwn_stress.py DIR [--only=NAME,…] (DIR: what `cargo run --example gwn_stress -- DIR` wrote)")
    src = args[0]
    listing = json.load(open(os.path.join(src, "index.json")))["cases"]
    os.makedirs(OUT, exist_ok=True)
    index = {
        "generator": "tests/oracle/gen_gwn_stress.py (meshes: cargo run --example gwn_stress)",
        "versions": {p: importlib.metadata.version(p) for p in ("libigl", "numpy")},
        "layout": "bool[i][j][k] (x, y, z), C order, np.packbits bitorder=little, then (value, run) byte pairs",
        "magnitude": "exact igl.winding_number |w| >= 0.5 (see the script: exact wherever |fast -+ 0.5| < %g)" % TAU,
        "positive": "exact igl.winding_number w >= 0.5",
        "cases": [],
    }
    cases = [("stanford-bunny", BUNNY, None)]
    for c in listing:
        cases.append((c["name"], os.path.join(src, c["file"]), c["fnv1a"]))
    previous = {}
    if only is not None:
        with open(os.path.join(OUT, "index.json")) as fh:
            previous = {c["model"]: c for c in json.load(fh)["cases"]}
    for name, path, expected_hash in cases:
        rng = np.random.default_rng(fnv1a(name.encode()) & 0xFFFFFFFF)
        if only is not None and name not in only:
            index["cases"].append(previous[name])
            continue
        t0 = time.time()
        data = open(path, "rb").read()
        digest = "%016x" % fnv1a(data)
        if expected_hash is not None:
            assert digest == expected_hash, (name, digest, expected_hash)
        V, F = read_obj(path)
        used = V[np.unique(F)]
        F = clean(V, F)
        lo = used.min(axis=0)
        side = float((used.max(axis=0) - lo).max())
        P = centres(lo, side, RES)
        w = igl.fast_winding_number(V, F, P)
        sample = rng.choice(len(P), 20000, replace=False)
        fast_err = float(np.abs(exact_w(V, F, P[sample]) - w[sample]).max())
        assert fast_err < TAU / 4, (name, fast_err)
        idx = np.nonzero((np.abs(w - 0.5) < TAU) | (np.abs(w + 0.5) < TAU))[0]
        w[idx] = exact_w(V, F, P[idx])
        magnitude = (np.abs(w) >= 0.5).reshape(RES, RES, RES)
        positive = (w >= 0.5).reshape(RES, RES, RES)
        stem = f"{name}_{RES}"
        files = {}
        for kind, m in (("magnitude", magnitude), ("positive", positive)):
            files[kind] = f"{stem}.{kind}.rle"
            with open(os.path.join(OUT, files[kind]), "wb") as fh:
                fh.write(rle(np.packbits(m.ravel(), bitorder="little").tobytes()))
        case = {
            "model": name, "res": RES, "triangles": int(len(F)),
            "source": os.path.relpath(path, ROOT) if name == "stanford-bunny" else f"stress:{name}",
            "fnv1a": digest,
            "origin_text": [repr(float(x)) for x in lo], "side_text": repr(side),
            "magnitude": int(magnitude.sum()), "positive": int(positive.sum()),
            "exact_centres": int(len(idx)), "max_fast_error": fast_err,
            "files": files,
        }
        index["cases"].append(case)
        print(f"{stem}: {len(F)} triangles, |w|>=1/2 {case['magnitude']}, w>=1/2 {case['positive']}, "
              f"exact at {len(idx)} centres, max |fast - exact| {fast_err:.2e}, {time.time() - t0:.0f} s",
              flush=True)
    with open(os.path.join(OUT, "index.json"), "w") as fh:
        json.dump(index, fh, indent=1)
        fh.write("\n")
    total = sum(os.path.getsize(os.path.join(OUT, f)) for f in os.listdir(OUT))
    print(f"fixtures: {total} bytes")
    assert total < 4_000_000


if __name__ == "__main__":
    sys.exit(main())

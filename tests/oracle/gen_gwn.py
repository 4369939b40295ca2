#!/usr/bin/env python3
"""Generate the generalized-winding-number fixtures in tests/fixtures/gwn/ (libigl's exact winding_number).

Run from the repository root:
    python3 -m pip install -r tests/oracle/requirements-voxel.txt
    python3 tests/oracle/gen_gwn.py

The open and broken meshes are generated here (seeded, positions float32, written as OBJ with shortest
round-trip text) and committed beside the fixtures; the bunny is assets/models/stanford-bunny.obj. Per mesh
and resolution R (64, 128), on the grid of `gregvox voxelize --res R` (origin = box minimum of the float32
positions, side = the longest extent, centre(i,j,k) = origin + (i+1/2, j+1/2, k+1/2)·side/R):
- `inside`: w(centre) >= 1/2, w the EXACT generalized winding number (igl.winding_number: the plain sum of
  solid angles). The exact sum at all 2 M centres of the 128³ bunny takes hours on two cores, so it runs
  where it can decide: every centre with |w_fast - 1/2| < 0.1 (w_fast: igl.fast_winding_number) gets the
  exact w; elsewhere the decision is the exact one because the fast value is within 0.1 of it, which the
  script checks on 20,000 random centres per case (max |w_fast - w| printed and asserted < 0.01) and, on the
  generated meshes at 64³, on every centre (the exact sum everywhere). Every case asserts w > -1/2
  everywhere checked, so w >= 1/2 and gregvox's |w| >= 1/2 are the same test;
- `band`: the centre lies within one voxel edge (side/R) of the mesh (igl.point_mesh_squared_distance).
Masks are bool [i, j, k] (x, y, z), C order, np.packbits(bitorder='little'), then (value, run) byte pairs
(tests/voxel_oracle.rs::unrle). The Rust tests never run Python.
"""
import importlib.metadata
import json
import os
import sys

import igl
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
OUT = os.path.join(ROOT, "tests", "fixtures", "gwn")
BUNNY = os.path.join(ROOT, "assets", "models", "stanford-bunny.obj")
RES = [64, 128]
BAND_TAU = 0.1


def grid_uv(rings, segs, theta0, theta1, radius=1.0, centre=(0.0, 0.0, 0.0), close_poles=True):
    """A sphere zone theta in [theta0, theta1] (theta from +z), outward, CCW seen from outside."""
    V, F = [], []
    ring_idx = []
    for r in range(rings + 1):
        th = theta0 + (theta1 - theta0) * r / rings
        if close_poles and (abs(th) < 1e-12 or abs(th - np.pi) < 1e-12):
            ring_idx.append([len(V)] * segs)
            V.append([0.0, 0.0, radius * np.cos(th)])
            continue
        row = []
        for s in range(segs):
            ph = 2 * np.pi * s / segs
            row.append(len(V))
            V.append([radius * np.sin(th) * np.cos(ph), radius * np.sin(th) * np.sin(ph), radius * np.cos(th)])
        ring_idx.append(row)
    for r in range(rings):
        for s in range(segs):
            a, b = ring_idx[r][s], ring_idx[r][(s + 1) % segs]
            c, d = ring_idx[r + 1][s], ring_idx[r + 1][(s + 1) % segs]
            # theta grows downwards: (a, c, d, b) is CCW seen from outside.
            if a != b:
                F.append([a, c, b])
            if c != d:
                F.append([b, c, d])
    V = np.array(V) + np.array(centre)
    return V, np.array(F, dtype=np.int64)


def tube(segs=64, rings=16, radius=1.0, height=2.0):
    V, F = [], []
    for r in range(rings + 1):
        z = -height / 2 + height * r / rings
        for s in range(segs):
            ph = 2 * np.pi * s / segs
            V.append([radius * np.cos(ph), radius * np.sin(ph), z])
    for r in range(rings):
        for s in range(segs):
            a, b = r * segs + s, r * segs + (s + 1) % segs
            c, d = a + segs, b + segs
            F.append([a, b, d])
            F.append([a, d, c])
    return np.array(V), np.array(F, dtype=np.int64)


def disk(segs, radius, z, up):
    """A fan disk at height z; normal +z if up."""
    V = [[0.0, 0.0, z]] + [[radius * np.cos(2 * np.pi * s / segs), radius * np.sin(2 * np.pi * s / segs), z]
                           for s in range(segs)]
    F = []
    for s in range(segs):
        a, b = 1 + s, 1 + (s + 1) % segs
        F.append([0, a, b] if up else [0, b, a])
    return np.array(V), np.array(F, dtype=np.int64)


def concat(parts):
    V, F, n = [], [], 0
    for v, f in parts:
        V.append(v)
        F.append(f + n)
        n += len(v)
    return np.vstack(V), np.vstack(F)


def soup(V, F):
    """Every triangle its own three vertices (unwelded)."""
    return V[F.reshape(-1)], np.arange(3 * len(F), dtype=np.int64).reshape(-1, 3)


def meshes():
    rng = np.random.default_rng(20261202)
    out = {}
    out["tube"] = tube()
    out["hemisphere"] = grid_uv(16, 48, 0.0, np.pi / 2)
    sv, sf = grid_uv(24, 48, 0.0, np.pi)
    keep = rng.permutation(len(sf))[len(sf) // 4:]
    out["sphere_quarter_removed"] = (sv, sf[np.sort(keep)])
    # A cup (tube + bottom disk, open at the top) as an unwelded soup.
    tv, tf = tube(48, 8, 1.0, 1.5)
    dv, df = disk(48, 1.0, -0.75, up=False)
    cv, cf = concat([(tv, tf), (dv, df)])
    out["cup_soup"] = soup(cv, cf)
    # Two overlapping open shells: hemispheres shifted along x and z.
    h1 = grid_uv(12, 36, 0.0, np.pi / 2)
    h2 = grid_uv(12, 36, 0.0, np.pi / 2, centre=(0.6, 0.0, -0.3))
    out["two_shells"] = concat([h1, h2])
    out["closed_sphere"] = grid_uv(16, 32, 0.0, np.pi)
    return out


def read_obj(path):
    V, T = [], []
    with open(path) as fh:
        for line in fh:
            t = line.split("#")[0].split()
            if not t:
                continue
            if t[0] == "v":
                V.append([float(x) for x in t[1:4]])
            elif t[0] == "f":
                face = [int(tok.split("/")[0]) - 1 for tok in t[1:]]
                for k in range(1, len(face) - 1):
                    T.append([face[0], face[k], face[k + 1]])
    V = np.array(V, dtype=np.float64).astype(np.float32).astype(np.float64)
    return V, np.array(T, dtype=np.int64)


def write_obj(path, V, F):
    V32 = V.astype(np.float32)
    with open(path, "w") as fh:
        fh.write("# generated by tests/oracle/gen_gwn.py\n")
        for v in V32:
            fh.write("v " + " ".join(repr(float(np.float32(x))) for x in v) + "\n")
        for f in F:
            fh.write("f " + " ".join(str(i + 1) for i in f) + "\n")


def rle(data):
    out = bytearray()
    i, n = 0, len(data)
    while i < n:
        v, j = data[i], i + 1
        while j < n and j - i < 255 and data[j] == v:
            j += 1
        out += bytes([v, j - i])
        i = j
    return bytes(out)


def centres(lo, side, R):
    p = side / R
    c = (np.arange(R, dtype=np.float64) + 0.5) * p
    X, Y, Z = np.meshgrid(c + lo[0], c + lo[1], c + lo[2], indexing="ij")
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)


def exact_w(V, F, P):
    out = np.empty(len(P))
    step = max(1, 4_000_000 // max(1, len(F)))
    for s in range(0, len(P), step):
        out[s:s + step] = igl.winding_number(V, F, P[s:s + step])
    return out


def main():
    os.makedirs(OUT, exist_ok=True)
    index = {
        "generator": "tests/oracle/gen_gwn.py",
        "versions": {p: importlib.metadata.version(p) for p in ("libigl", "numpy")},
        "layout": "bool[i][j][k] (x, y, z), C order, np.packbits bitorder=little, then (value, run) byte pairs",
        "inside": "exact igl.winding_number >= 0.5 (see the script: exact wherever |fast - 0.5| < 0.1)",
        "band": "centre within one voxel edge of the mesh",
        "cases": [],
    }
    cases = []
    for name, (V, F) in meshes().items():
        path = os.path.join(OUT, name + ".obj")
        write_obj(path, V, F)
        cases.append((name, os.path.relpath(path, ROOT), name != "closed_sphere"))
    cases.append(("stanford-bunny", os.path.relpath(BUNNY, ROOT), True))
    rng = np.random.default_rng(7)
    for name, rel, is_open in cases:
        V, F = read_obj(os.path.join(ROOT, rel))
        lo = V[np.unique(F)].min(axis=0)
        side = float((V[np.unique(F)].max(axis=0) - lo).max())
        for R in RES:
            P = centres(lo, side, R)
            w = igl.fast_winding_number(V, F, P)
            near_half = np.abs(w - 0.5) < BAND_TAU
            generated = name != "stanford-bunny"
            if generated and R == 64:
                we = exact_w(V, F, P)
                fast_err = float(np.abs(we - w).max())
                w = we
                how = "exact at every centre"
            else:
                sample = rng.choice(len(P), 20000, replace=False)
                fast_err = float(np.abs(exact_w(V, F, P[sample]) - w[sample]).max())
                idx = np.nonzero(near_half)[0]
                w[idx] = exact_w(V, F, P[idx])
                how = f"exact at the {len(idx)} centres with |fast - 0.5| < {BAND_TAU}"
            assert fast_err < 0.01, (name, R, fast_err)
            assert w.min() > -0.5, (name, R, w.min())
            inside = (w >= 0.5).reshape(R, R, R)
            d2, _, _ = igl.point_mesh_squared_distance(P, V, F)
            band = (d2 <= (side / R) ** 2).reshape(R, R, R)
            stem = f"{name}_{R}"
            for kind, m in (("inside", inside), ("band", band)):
                with open(os.path.join(OUT, f"{stem}.{kind}.rle"), "wb") as fh:
                    fh.write(rle(np.packbits(m.ravel(), bitorder="little").tobytes()))
            frac = int((np.abs(w - np.round(w)) > 0.25).sum())
            case = {
                "model": name, "obj": rel, "res": R, "open": is_open, "triangles": int(len(F)),
                "origin_text": [repr(float(x)) for x in lo], "side_text": repr(side),
                "inside": int(inside.sum()), "band": int(band.sum()), "fractional": frac,
                "exact": how, "max_fast_error": fast_err,
                "files": {"inside": f"{stem}.inside.rle", "band": f"{stem}.band.rle"},
            }
            index["cases"].append(case)
            print(f"{stem}: {len(F)} triangles, inside {case['inside']}, band {case['band']}, "
                  f"fractional {frac}, {how}, max |fast - exact| {fast_err:.2e}", flush=True)
    with open(os.path.join(OUT, "index.json"), "w") as fh:
        json.dump(index, fh, indent=1)
        fh.write("\n")
    total = sum(os.path.getsize(os.path.join(OUT, f)) for f in os.listdir(OUT))
    print(f"fixtures: {total} bytes")
    assert total < 3_000_000


if __name__ == "__main__":
    sys.exit(main())

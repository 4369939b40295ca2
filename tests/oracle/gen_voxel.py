#!/usr/bin/env python3
"""Generate the solid-voxel oracle fixtures in tests/fixtures/voxel/ (generalized winding number, libigl).

Run from the repository root (models in assets/models, `cargo build` done first):
    python3 -m pip install -r tests/oracle/requirements-voxel.txt
    python3 tests/oracle/gen_voxel.py

What is stored, per model and resolution R (grid contract of docs/ARCHITECTURE.md):
- the mesh exactly as `gregvox voxelize` sees it: OBJ positions parsed as float64, rounded to float32
  (`src/cli/voxelize.rs::triangles_of`), polygons fan-triangulated (v0, vk, vk+1); no welding, no cleaning;
- origin = bbox min, side = longest extent (both from the float32 positions, in float64),
  centre(i,j,k) = origin + (i+½, j+½, k+½)·side/R;
- `inside`: igl.fast_winding_number(V, F, centres) > ½;
- `band`: the centre lies within √3/2·pitch of the mesh (igl.point_mesh_squared_distance);
- `fractional`: the number of centres with |w − round(w)| > 0.25 (open-mesh indicator), and the histogram
  of round(w).
Masks are bool arrays indexed [i, j, k] (x, y, z), C order (z fastest), packed with
np.packbits(bitorder='little') and then run-length coded as (byte value, run length 1..255) pairs: the
Rust test decodes them with a ten-line reader (tests/voxel_oracle.rs::unrle).

At generation time the script also checks the binvox convention of our writer: it runs
`target/debug/gregvox voxelize --method cpu` to write the same grid as .binvox and as .npy, loads the binvox
with trimesh (`trimesh.exchange.binvox.load_binvox(..., axis_order='xzy')`) and compares *indices* with the
unpacked .npy (trimesh's own world transform uses scale/(shape−1) and is not compared). The Rust tests never
run Python.
"""
import importlib.metadata
import json
import os
import subprocess
import sys
import tempfile

import igl
import numpy as np
import trimesh

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODELS = os.path.join(ROOT, "assets", "models")
OUT = os.path.join(ROOT, "tests", "fixtures", "voxel")
GREGVOX = os.path.join(ROOT, "target", "debug", "gregvox")

# (model, resolutions, closed?)
CASES = [
    ("spot", [64, 128], True),
    ("cow", [64, 128], True),
    ("teapot", [64, 128], True),  # overlapping shells (w = 2), open rims
    ("stanford-bunny", [64, 128], False),
    ("suzanne", [64, 128], False),
]


def read_obj(path):
    """Positions in file order and fan triangles, like gregvox::mesh::load_obj + triangles_of."""
    V, T = [], []
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
                for k in range(1, len(face) - 1):
                    T.append([face[0], face[k], face[k + 1]])
    # f64 → f32 → f64: the voxelizer's positions are f32.
    V = np.array(V, dtype=np.float64).astype(np.float32).astype(np.float64)
    return V, np.array(T, dtype=np.int64)


def frame(V, R):
    lo = V.min(axis=0)
    side = float((V.max(axis=0) - lo).max())
    return lo, side


def centres(lo, side, R):
    p = side / R
    c = (np.arange(R, dtype=np.float64) + 0.5) * p
    X, Y, Z = np.meshgrid(c + lo[0], c + lo[1], c + lo[2], indexing="ij")
    return np.stack([X.ravel(), Y.ravel(), Z.ravel()], axis=1)


def rle(data):
    """(value, count ≤ 255) byte pairs."""
    out = bytearray()
    n = len(data)
    i = 0
    while i < n:
        v = data[i]
        j = i + 1
        while j < n and j - i < 255 and data[j] == v:
            j += 1
        out += bytes([v, j - i])
        i = j
    return bytes(out)


def unrle(b):
    out = bytearray()
    for k in range(0, len(b), 2):
        out += bytes([b[k]]) * b[k + 1]
    return bytes(out)


def pack(mask):
    return rle(np.packbits(mask.ravel(), bitorder="little").tobytes())


def check_binvox_convention(obj, V, F, R, inside, band):
    """gregvox's .binvox loads in trimesh (axis_order='xzy') with the same indices as its .npy."""
    with tempfile.TemporaryDirectory() as d:
        bv, npy = os.path.join(d, "g.binvox"), os.path.join(d, "g.npy")
        for out in (bv, npy):
            subprocess.run(
                [GREGVOX, "voxelize", obj, "--res", str(R), "--method", "cpu", "--axes", "1",
                 "--axis", "z", "--out", out],
                check=True, stdout=subprocess.DEVNULL,
            )
        with open(bv, "rb") as fh:
            vg = trimesh.exchange.binvox.load_binvox(fh, axis_order="xzy")
        m_bv = np.asarray(vg.matrix, dtype=bool)
        packed = np.load(npy)
        m_npy = np.unpackbits(packed, axis=2, bitorder="little")[:, :, :R].astype(bool)
        assert m_bv.shape == (R, R, R), m_bv.shape
        assert np.array_equal(m_bv, m_npy), "binvox indices differ from npy (x, y, z)"
        # And both are the winding oracle outside the band (a transposed reader would fail this).
        wrong = int(((m_bv != inside) & ~band).sum())
        assert wrong == 0, f"binvox grid differs from the oracle outside the band: {wrong}"
        # Header: translate = origin, scale = side.
        with open(bv, "rb") as fh:
            head = fh.read(200).split(b"data\n")[0].decode()
        tr = [float(x) for x in head.split("translate")[1].split("\n")[0].split()]
        sc = float(head.split("scale")[1].split("\n")[0])
        lo, side = frame(V, R)
        assert np.allclose(tr, lo, rtol=0, atol=1e-12) and abs(sc - side) < 1e-12, (tr, sc)
        return int(m_bv.sum())


def main():
    os.makedirs(OUT, exist_ok=True)
    index = {
        "generator": "tests/oracle/gen_voxel.py",
        "versions": {p: importlib.metadata.version(p) for p in ("libigl", "trimesh", "numpy", "scipy")},
        "layout": "bool[i][j][k] (x, y, z), C order, np.packbits bitorder=little, then (value, run) byte pairs",
        "band": "centre within sqrt(3)/2 * pitch of the mesh",
        "inside": "fast_winding_number > 0.5",
        "cases": [],
    }
    binvox_checked = False
    for name, resolutions, closed in CASES:
        obj = os.path.join(MODELS, name + ".obj")
        V, F = read_obj(obj)
        for R in resolutions:
            lo, side = frame(V, R)
            pitch = side / R
            P = centres(lo, side, R)
            w = igl.fast_winding_number(V, F, P)
            d2, _, _ = igl.point_mesh_squared_distance(P, V, F)
            inside = (w > 0.5).reshape(R, R, R)
            band = (d2 <= (np.sqrt(3) / 2 * pitch) ** 2).reshape(R, R, R)
            frac = int((np.abs(w - np.round(w)) > 0.25).sum())
            hist = {str(int(k)): int(v) for k, v in zip(*np.unique(np.round(w).astype(int), return_counts=True))}
            stem = f"{name}_{R}"
            for kind, m in (("inside", inside), ("band", band)):
                b = pack(m)
                assert np.array_equal(
                    np.unpackbits(np.frombuffer(unrle(b), np.uint8), bitorder="little")[: R**3].astype(bool),
                    m.ravel()), "rle round trip"
                with open(os.path.join(OUT, f"{stem}.{kind}.rle"), "wb") as fh:
                    fh.write(b)
            case = {
                "model": name, "res": R, "closed": closed,
                "triangles": int(len(F)), "origin": [float(x) for x in lo], "side": side,
                # Shortest round-trip text: JSON number parsers need not be correctly rounded.
                "origin_text": [repr(float(x)) for x in lo], "side_text": repr(side),
                "inside": int(inside.sum()), "band": int(band.sum()),
                "fractional": frac, "rounded_w_histogram": hist,
                "files": {"inside": f"{stem}.inside.rle", "band": f"{stem}.band.rle"},
            }
            if not binvox_checked and name == "spot" and R == 64:
                case["binvox_trimesh_check_solid"] = check_binvox_convention(obj, V, F, R, inside, band)
                binvox_checked = True
                print("binvox convention checked through trimesh (axis_order='xzy'): identical indices")
            index["cases"].append(case)
            print(f"{stem}: inside {case['inside']}, band {case['band']}, fractional {frac}, w histogram {hist}")
    with open(os.path.join(OUT, "index.json"), "w") as fh:
        json.dump(index, fh, indent=1)
        fh.write("\n")
    total = sum(os.path.getsize(os.path.join(OUT, f)) for f in os.listdir(OUT))
    print(f"fixtures: {total} bytes")
    assert total < 2_000_000


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Oracle fixtures for gregvox's geometry core (`src/geom/`).

Writes small JSON files under tests/fixtures/geom/ that the Rust tests (tests/geom_*.rs) read; the Rust
tests never run Python. Deterministic: a fixed seed, pinned versions (tests/oracle/requirements-geom.txt).

    python3 -m venv /tmp/geomvenv
    /tmp/geomvenv/bin/pip install -r tests/oracle/requirements-geom.txt
    /tmp/geomvenv/bin/python tests/oracle/gen_geom.py

Oracles:
- geomdl: B-spline / NURBS / rational Bezier curves and surfaces (points and derivatives), knot insertion,
  curve split, Bezier degree elevation.
- numpy: Bezier curves of any degree by direct Bernstein sums, hodographs, signed plane curvature.
- skimage.draw.line: Bresenham lines. skimage's line depends on the end-point difference only (its
  Cython `_line` uses r1-r0, c1-c0 and their signs), so we store the line for every offset in [-16,16]^2
  and assert, here, for *every* pair of end points in [-8,8]^2, that line(p0, p1) == p0 + line(0, p1-p0).
  A random sample of 2000 absolute pairs is stored too, so the Rust side re-checks that claim.
"""
import json
import math
import os
import sys

import numpy as np
import geomdl
from geomdl import BSpline, NURBS, helpers, operations
import skimage
from skimage.draw import line as sk_line

SEED = 20260322
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.normpath(os.path.join(HERE, "..", "fixtures", "geom"))


def uni(rng, lo, hi, size=None):
    """Uniform draws rounded to 15 significant digits *before* any oracle sees them, so the inputs stored in
    the fixtures are exactly the inputs the oracle used."""
    x = rng.uniform(lo, hi, size=size)
    if size is None:
        return float(f"{x:.15g}")
    return np.vectorize(lambda y: float(f"{y:.15g}"), otypes=[np.float64])(x)


def round15(x):
    """15 significant digits: error <= 5e-15 relative, far below the tests' 1e-12, and ~25 % smaller files."""
    if isinstance(x, float):
        return float(f"{x:.15g}")
    if isinstance(x, list):
        return [round15(y) for y in x]
    if isinstance(x, dict):
        return {k: round15(v) for k, v in x.items()}
    return x


def dump(name, obj):
    obj = round15(obj)
    os.makedirs(OUT, exist_ok=True)
    path = os.path.join(OUT, name)
    with open(path, "w") as f:
        json.dump(obj, f, separators=(",", ":"))
    print(f"wrote {path} ({os.path.getsize(path)} bytes)")


def versions():
    return {"geomdl": geomdl.__version__, "numpy": np.__version__, "scikit-image": skimage.__version__,
            "python": sys.version.split()[0], "seed": SEED}


def random_clamped_knots(rng, n, p, repeat_interior=False):
    """Clamped knot vector on [0,1] for n control points of degree p (n + p + 1 knots)."""
    m_int = n - p - 1
    interior = sorted(uni(rng, 0.05, 0.95, size=m_int).tolist())
    if repeat_interior and m_int >= 2:
        # one interior knot of multiplicity 2 (still <= p for p >= 2): exercises repeated knots
        interior[1] = interior[0]
    return [0.0] * (p + 1) + interior + [1.0] * (p + 1)


def open_uniform_knots(n, p):
    m_int = n - p - 1
    return [0.0] * (p + 1) + [(i + 1) / (m_int + 1) for i in range(m_int)] + [1.0] * (p + 1)


def params_101(rng):
    """101 parameters: the 2 end points, the interior knots' neighbourhood is hit by random draws."""
    u = np.concatenate([[0.0, 1.0], uni(rng, 0.0, 1.0, size=99)])
    return sorted(u.tolist())


# ---------------------------------------------------------------- curves
def curve_case(rng, kind, p, n, knots_kind):
    ctrl = uni(rng, -2.0, 2.0, size=(n, 3)).tolist()
    if knots_kind == "bezier":
        kv = [0.0] * (p + 1) + [1.0] * (p + 1)
    elif knots_kind == "open_uniform":
        kv = open_uniform_knots(n, p)
    else:
        kv = random_clamped_knots(rng, n, p, repeat_interior=(knots_kind == "random_repeated"))
    if kind == "bspline":
        c = BSpline.Curve()
        c.degree = p
        c.ctrlpts = ctrl
        weights = None
    else:
        c = NURBS.Curve()
        c.degree = p
        weights = uni(rng, 0.5, 2.0, size=n).tolist()
        # geomdl NURBS takes the weighted (homogeneous) points ctrlptsw = [x*w, y*w, z*w, w]
        c.ctrlptsw = [[x * w, y * w, z * w, w] for (x, y, z), w in zip(ctrl, weights)]
    c.knotvector = kv
    us = params_101(rng)
    pts, d1, d2 = [], [], []
    for u in us:
        d = c.derivatives(u, order=2)
        pts.append(list(d[0]))
        d1.append(list(d[1]))
        d2.append(list(d[2]))
    return {"kind": kind, "knots_kind": knots_kind, "degree": p, "ctrl": ctrl, "weights": weights,
            "knots": list(c.knotvector), "params": us, "points": pts, "d1": d1, "d2": d2}


def gen_curves(rng):
    cases = []
    for p in range(1, 6):
        for kind in ("bspline", "nurbs"):
            for knots_kind in ("random", "open_uniform", "bezier"):
                n = p + 1 if knots_kind == "bezier" else p + 1 + int(rng.integers(1, 6))
                cases.append(curve_case(rng, kind, p, n, knots_kind))
        if p >= 2:
            cases.append(curve_case(rng, "nurbs", p, p + 4, "random_repeated"))
    dump("curves.json", {"versions": versions(), "cases": cases})


# ---------------------------------------------------------------- surfaces
def surface_case(rng, kind, pu, pv, nu, nv, knots_kind):
    ctrl = uni(rng, -2.0, 2.0, size=(nu * nv, 3)).tolist()  # index i*nv + j (v fastest)
    if knots_kind == "bezier":
        ku = [0.0] * (pu + 1) + [1.0] * (pu + 1)
        kvv = [0.0] * (pv + 1) + [1.0] * (pv + 1)
    else:
        ku = random_clamped_knots(rng, nu, pu)
        kvv = random_clamped_knots(rng, nv, pv)
    if kind == "bspline":
        s = BSpline.Surface()
        weights = None
    else:
        s = NURBS.Surface()
        weights = uni(rng, 0.5, 2.0, size=nu * nv).tolist()
    s.degree_u = pu
    s.degree_v = pv
    s.ctrlpts_size_u = nu
    s.ctrlpts_size_v = nv
    if weights is None:
        s.ctrlpts = ctrl
    else:
        s.ctrlptsw = [[x * w, y * w, z * w, w] for (x, y, z), w in zip(ctrl, weights)]
    s.knotvector_u = ku
    s.knotvector_v = kvv
    corners = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]
    uv = corners + uni(rng, 0.0, 1.0, size=(97, 2)).tolist()
    out = {"p": [], "su": [], "sv": [], "suu": [], "suv": [], "svv": []}
    for u, v in uv:
        d = s.derivatives(u, v, order=2)
        out["p"].append(list(d[0][0]))
        out["su"].append(list(d[1][0]))
        out["sv"].append(list(d[0][1]))
        out["suu"].append(list(d[2][0]))
        out["suv"].append(list(d[1][1]))
        out["svv"].append(list(d[0][2]))
    case = {"kind": kind, "knots_kind": knots_kind, "degree_u": pu, "degree_v": pv, "size_u": nu,
            "size_v": nv, "ctrl": ctrl, "weights": weights, "knots_u": list(s.knotvector_u),
            "knots_v": list(s.knotvector_v), "params": uv}
    case.update(out)
    return case


def gen_surfaces(rng):
    cases = []
    for pu, pv in [(1, 1), (2, 3), (3, 3), (4, 2), (5, 5), (1, 4)]:
        for kind in ("bspline", "nurbs"):
            nu = pu + 1 + int(rng.integers(0, 3))
            nv = pv + 1 + int(rng.integers(0, 3))
            cases.append(surface_case(rng, kind, pu, pv, nu, nv, "random"))
    for pu, pv in [(3, 3), (2, 4)]:
        for kind in ("bspline", "nurbs"):
            cases.append(surface_case(rng, kind, pu, pv, pu + 1, pv + 1, "bezier"))
    dump("surfaces.json", {"versions": versions(), "cases": cases})


# ---------------------------------------------------------------- modelling operations
def gen_ops(rng):
    elev = []
    for p in range(1, 6):
        ctrl = uni(rng, -2.0, 2.0, size=(p + 1, 3)).tolist()
        elev.append({"ctrl": ctrl, "times": 1, "elevated": helpers.degree_elevation(p, ctrl, num=1)})
        elev.append({"ctrl": ctrl, "times": 2, "elevated": helpers.degree_elevation(p, ctrl, num=2)})
    # the notes' vectors
    for ctrl in ([[0.0, 0.0, 0.0], [1.0, 2.0, 0.0], [2.0, 0.0, 0.0]],
                 [[0.0, 0.0, 0.0], [1.0, 3.0, 0.0], [3.0, 3.0, 0.0], [4.0, 0.0, 0.0]]):
        elev.append({"ctrl": ctrl, "times": 1, "elevated": helpers.degree_elevation(len(ctrl) - 1, ctrl, num=1)})

    split = []
    for p in range(1, 6):
        for kind in ("bezier", "random"):
            n = p + 1 if kind == "bezier" else p + 1 + int(rng.integers(1, 5))
            c = BSpline.Curve()
            c.degree = p
            c.ctrlpts = uni(rng, -2.0, 2.0, size=(n, 3)).tolist()
            c.knotvector = ([0.0] * (p + 1) + [1.0] * (p + 1)) if kind == "bezier" else random_clamped_knots(rng, n, p)
            u = float(uni(rng, 0.1, 0.9)) if kind == "random" else 0.3
            a, b = operations.split_curve(c, u)
            split.append({"degree": p, "ctrl": c.ctrlpts, "knots": list(c.knotvector), "u": u,
                          "left_ctrl": a.ctrlpts, "left_knots": list(a.knotvector),
                          "right_ctrl": b.ctrlpts, "right_knots": list(b.knotvector)})

    insert = []
    for p in range(1, 6):
        for kind in ("bspline", "nurbs"):
            n = p + 1 + int(rng.integers(1, 5))
            ctrl = uni(rng, -2.0, 2.0, size=(n, 3)).tolist()
            kv = random_clamped_knots(rng, n, p)
            if kind == "bspline":
                c = BSpline.Curve()
                c.degree = p
                c.ctrlpts = ctrl
                weights = None
            else:
                c = NURBS.Curve()
                c.degree = p
                weights = uni(rng, 0.5, 2.0, size=n).tolist()
                c.ctrlptsw = [[x * w, y * w, z * w, w] for (x, y, z), w in zip(ctrl, weights)]
            c.knotvector = kv
            u = float(uni(rng, 0.05, 0.95))
            r = int(rng.integers(1, p + 1))
            operations.insert_knot(c, [u], [r])  # mutates c
            insert.append({"kind": kind, "degree": p, "ctrl": ctrl, "weights": weights, "knots": kv, "u": u,
                           "times": r, "new_ctrl": c.ctrlpts, "new_weights": (list(c.weights) if weights else None),
                           "new_knots": list(c.knotvector)})
    dump("ops.json", {"versions": versions(), "elevation": elev, "split": split, "insert": insert})


# ---------------------------------------------------------------- Bezier + curvature (numpy)
def bernstein(n, i, t):
    return math.comb(n, i) * t ** i * (1.0 - t) ** (n - i)


def gen_bezier(rng):
    cases = []
    for n in range(1, 8):
        ctrl = uni(rng, -2.0, 2.0, size=(n + 1, 2))
        ts = np.linspace(0.0, 1.0, 101)
        pts, d1, d2, kappa = [], [], [], []
        hod1 = n * (ctrl[1:] - ctrl[:-1])
        hod2 = (n - 1) * (hod1[1:] - hod1[:-1]) if n >= 2 else np.zeros((1, 2))
        for t in ts:
            p = sum(bernstein(n, i, t) * ctrl[i] for i in range(n + 1))
            a = sum(bernstein(n - 1, i, t) * hod1[i] for i in range(n))
            b = sum(bernstein(n - 2, i, t) * hod2[i] for i in range(n - 1)) if n >= 2 else np.zeros(2)
            pts.append(p.tolist())
            d1.append(a.tolist())
            d2.append(b.tolist())
            kappa.append(float((a[0] * b[1] - a[1] * b[0]) / np.hypot(a[0], a[1]) ** 3))
        cases.append({"degree": n, "ctrl": ctrl.tolist(), "params": ts.tolist(), "points": pts, "d1": d1,
                      "d2": d2, "signed_curvature": kappa})
    dump("bezier.json", {"versions": versions(), "cases": cases})


# ---------------------------------------------------------------- Bresenham (skimage)
def sk(p0, p1):
    """skimage.draw.line in (x, y) = (col, row) coordinates: line(r0=y0, c0=x0, r1=y1, c1=x1)."""
    rr, cc = sk_line(p0[1], p0[0], p1[1], p1[0])
    return [[int(c), int(r)] for r, c in zip(rr, cc)]


def gen_bresenham(rng):
    rel = {}
    for dx in range(-16, 17):
        for dy in range(-16, 17):
            rel[(dx, dy)] = sk((0, 0), (dx, dy))
    # translation invariance, checked for every pair of end points in [-8,8]^2 (83,521 pairs)
    checked = 0
    for x0 in range(-8, 9):
        for y0 in range(-8, 9):
            for x1 in range(-8, 9):
                for y1 in range(-8, 9):
                    got = sk((x0, y0), (x1, y1))
                    want = [[x0 + a, y0 + b] for a, b in rel[(x1 - x0, y1 - y0)]]
                    assert got == want, ((x0, y0), (x1, y1), got, want)
                    checked += 1
    assert checked == 17 ** 4
    offsets = [[dx, dy] for dx in range(-16, 17) for dy in range(-16, 17)]
    lines = [sum(rel[(dx, dy)], []) for dx, dy in offsets]  # flat [x0,y0,x1,y1,...]
    sample = []
    for _ in range(2000):
        a = rng.integers(-8, 9, size=2).tolist()
        b = rng.integers(-8, 9, size=2).tolist()
        sample.append({"p0": a, "p1": b, "line": sum(sk(a, b), [])})
    dump("bresenham.json", {"versions": versions(), "convention": "x = column, y = row; skimage.draw.line(y0, x0, y1, x1); both end points included",
                            "translation_invariance_checked_pairs": checked, "offsets": offsets, "lines": lines,
                            "absolute_sample": sample})


def main():
    rng = np.random.default_rng(SEED)
    gen_curves(rng)
    gen_surfaces(rng)
    gen_ops(rng)
    gen_bezier(rng)
    gen_bresenham(rng)


if __name__ == "__main__":
    main()

"""How much the Python call adds to the engine's own time: ``gregvox.voxelize`` on a mesh, called in a loop.

    python python/examples/binding_overhead.py [MESH] [--res 256] [--repeat 10] [--method auto]

Prints the median wall time of the Python call, the median of the engine's own ``Gpu::voxelize`` time over
the same calls (``Grid.library_seconds``) and their ratio. What the binding adds: the arrays checked and
copied into the engine's mesh, and the one copy of the grid into NumPy (a byte per voxel).
"""
import argparse
import statistics
import time
from pathlib import Path

import gregvox

REPO = Path(__file__).resolve().parents[2]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mesh", nargs="?", default=REPO / "assets" / "models" / "stanford-bunny.obj", type=Path)
    ap.add_argument("--res", type=int, default=256)
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--method", default="auto")
    args = ap.parse_args()
    V, F = gregvox.load_mesh(args.mesh)
    gregvox.voxelize(V, F, res=args.res, method=args.method)  # pipelines made, memory pools grown
    wall, engine = [], []
    for _ in range(args.repeat):
        start = time.perf_counter()
        grid = gregvox.voxelize(V, F, res=args.res, method=args.method)
        wall.append(time.perf_counter() - start)
        engine.append(grid.library_seconds)
    w, e = statistics.median(wall), statistics.median(engine)
    print(
        f"{args.mesh.name} res {args.res} ({grid.report['method']}, {gregvox.default_device().info['name']}): "
        f"Python call {w * 1e3:.1f} ms, engine {e * 1e3:.1f} ms (medians of {args.repeat}): "
        f"the call takes {w / e:.3f}x the engine's time"
    )


if __name__ == "__main__":
    main()

"""Shared fixtures: the validation layer is on for every test, the device is checked after each test (no
validation message) and closed at the end (no GPU allocation alive); ``cli`` runs the ``gregvox`` binary of
the same checkout, the oracle the bindings are compared with."""
import gc
import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

# Before the first device: every Device() made by the tests requires the Vulkan validation layer.
os.environ["GREGVOX_VALIDATION"] = "1"

import gregvox  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "assets" / "models"


@pytest.fixture(scope="session")
def device():
    dev = gregvox.default_device()
    assert dev.info["validation_enabled"], "the tests need the Vulkan validation layer"
    yield dev
    gc.collect()
    dev.finish()  # raises if a GPU allocation is still alive or the layer reported anything


@pytest.fixture(autouse=True)
def no_validation_messages(device):
    yield
    assert device.validation_messages == []


def _gregvox_binary() -> Path:
    """The CLI of this checkout: ``GREGVOX_BIN``, else ``target/debug/gregvox`` (built when missing)."""
    if os.environ.get("GREGVOX_BIN"):
        return Path(os.environ["GREGVOX_BIN"])
    binary = REPO / "target" / "debug" / "gregvox"
    if not binary.exists():
        subprocess.run(["cargo", "build", "--quiet", "--bin", "gregvox"], cwd=REPO, check=True)
    return binary


class Cli:
    def __init__(self, binary: Path):
        self.binary = binary

    def run(self, *args, check=True) -> subprocess.CompletedProcess:
        env = dict(os.environ, GREGVOX_VALIDATION="0")
        p = subprocess.run([str(self.binary), *map(str, args)], capture_output=True, text=True, env=env)
        if check and p.returncode != 0:
            raise AssertionError(f"gregvox {' '.join(map(str, args))} failed: {p.stderr}")
        return p

    def json(self, *args) -> dict:
        return json.loads(self.run(*args).stdout)


@pytest.fixture(scope="session")
def cli() -> Cli:
    return Cli(_gregvox_binary())


@pytest.fixture(scope="session")
def models() -> Path:
    return MODELS


def read_obj(path: Path):
    """Positions, normals (float32 as written) and faces of an OBJ the CLI wrote."""
    v, vn, f = [], [], []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            v.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vn":
            vn.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            f.append([int(c.split("/")[0]) - 1 for c in parts[1:]])
    return np.array(v), np.array(vn), f


def tetrahedron():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [2, 0, 3]], dtype=np.int64)
    return V, F


def cube():
    """A closed unit cube of 12 outward triangles."""
    V = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=np.float64)
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    F = np.array([t for a, b, c, d in quads for t in ([a, b, c], [a, c, d])], dtype=np.int64)
    return V, F

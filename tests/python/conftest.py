"""Shared scene builders and fixtures of the Python client tests.

The scene is Blender-like (Z up): a ground grid, a few boxes, a sun and a point light, seen by a
camera from above at an angle. Matrices are 4x4 numpy arrays indexed [row][column], as Blender's
``matrix_world``.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
import pytest

import antumbra

REPO = Path(__file__).resolve().parents[2]

WIDTH, HEIGHT = 96, 64


def translation(x: float, y: float, z: float) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def rotation_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    m = np.eye(4)
    m[:2, :2] = ((c, -s), (s, c))
    return m


def look_at(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """world_from_camera of a camera (or light) at ``eye`` whose local -Z points at
    ``target``, +Y up, as Blender's matrix_world."""
    eye, target, up = (np.asarray(v, dtype=np.float64) for v in (eye, target, up))
    forward = target - eye
    forward /= np.linalg.norm(forward)
    x = np.cross(forward, up)
    x /= np.linalg.norm(x)
    y = np.cross(x, forward)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, y, -forward, eye
    return m


def box(size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A cube of edge ``size`` standing on z = 0, centred on the z axis."""
    h = size / 2
    positions = np.array(
        [[x, y, z] for z in (0.0, size) for y in (-h, h) for x in (-h, h)], dtype=np.float32
    )
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    triangles = np.array(
        [t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=np.uint32
    )
    return positions, triangles


def grid(n: int = 16, size: float = 12.0) -> tuple[np.ndarray, np.ndarray]:
    """A square ground grid of n x n quads on z = 0, centred on the origin."""
    s = np.linspace(-size / 2, size / 2, n + 1)
    xs, ys = np.meshgrid(s, s, indexing="xy")
    positions = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1).astype(np.float32)
    i = np.arange(n)
    a = (i[None, :] + (n + 1) * i[:, None]).ravel()
    b, c, d = a + 1, a + n + 2, a + n + 1
    triangles = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return positions, triangles.astype(np.uint32)


def camera(frame: int = 1) -> dict:
    eye = (6.0 + 0.25 * frame, -6.0, 5.0)
    return {
        "matrix_world": look_at(eye, (0.0, 0.0, 0.5)),
        "lens": 35.0,
        "sensor_width": 36.0,
        "sensor_height": 24.0,
        "sensor_fit": "AUTO",
        "clip_start": 0.1,
        "clip_end": 100.0,
    }


def lights() -> list[dict]:
    return [
        {
            "name": "Sun",
            "type": "SUN",
            "matrix_world": look_at((3.0, 2.0, 10.0), (0.0, 0.0, 0.0)),
            "angle": 0.02,
        },
        {
            "name": "Lamp",
            "type": "POINT",
            "matrix_world": translation(-2.0, -3.0, 4.0),
            "shadow_soft_size": 0.3,
        },
    ]


RESOLUTION = {"x": WIDTH, "y": HEIGHT, "percentage": 100}


def meshes() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The scene's meshes by name: (positions, triangles)."""
    return {"Ground": grid(), "Box": box(1.0), "Tall": box(0.5)}


def upload_missing(session, missing: list[int]) -> None:
    """Uploads the meshes with these hashes, as an add-on would after frame_update."""
    by_hash = {antumbra.mesh_hash(*arrays): (name, arrays) for name, arrays in meshes().items()}
    for h in missing:
        name, arrays = by_hash[h]
        assert session.upload_mesh(name, *arrays) == h


def upload_scene(session) -> dict[str, int]:
    """Uploads the meshes the session lacks; returns the hashes by mesh name."""
    hashes = {name: antumbra.mesh_hash(*arrays) for name, arrays in meshes().items()}
    upload_missing(session, session.missing_meshes(list(hashes.values())))
    return hashes


def objects(hashes: dict[str, int], frame: int = 1) -> list[dict]:
    """The objects of a frame: the ground, two boxes, and a tall box that moves."""
    tall = translation(-1.5 + 0.5 * frame, 1.0, 0.0) @ np.diag([1.0, 1.0, 4.0, 1.0])
    return [
        {"name": "Ground", "mesh_hash": hashes["Ground"], "matrix_world": np.eye(4)},
        {"name": "Box.A", "mesh_hash": hashes["Box"], "matrix_world": translation(1.0, 0, 0)},
        {
            "name": "Box.B",
            "mesh_hash": hashes["Box"],
            "matrix_world": translation(-1.0, -2.0, 0.0) @ rotation_z(0.4),
        },
        {"name": "Tall", "mesh_hash": hashes["Tall"], "matrix_world": tall},
    ]


def send_frame(session, hashes: dict[str, int], frame: int) -> list[int]:
    return session.frame_update(frame, objects(hashes, frame), camera(frame), lights(), RESOLUTION)


# ---------------------------------------------------------------------------------------------
# The daemon binary


def _candidates() -> list[Path]:
    env = os.environ.get("ANTUMBRA_BIN")
    if env:
        return [Path(env)]
    found = [REPO / "target" / p / "antumbra" for p in ("release", "debug")]
    found = [p for p in found if p.is_file()]
    # The most recently built one: a stale release build may predate `serve`.
    return sorted(found, key=lambda p: p.stat().st_mtime, reverse=True)


@pytest.fixture(scope="session")
def antumbra_bin() -> Path:
    """The daemon binary: $ANTUMBRA_BIN, else the newest of target/{release,debug}/antumbra.
    Fails (does not skip) when there is none or it has no `serve` subcommand."""
    candidates = _candidates()
    if not candidates:
        pytest.fail(
            "no antumbra binary: build it (cargo build -p antumbra-cli) or set ANTUMBRA_BIN "
            "to its path"
        )
    binary = candidates[0]
    try:
        probe = subprocess.run(
            [str(binary), "serve", "--help"], capture_output=True, text=True, timeout=30
        )
    except OSError as e:
        pytest.fail(f"cannot run {binary}: {e}")
    if probe.returncode != 0:
        pytest.fail(
            f"{binary} has no working `serve` subcommand (`{binary} serve --help` exited with "
            f"{probe.returncode}: {probe.stderr.strip()[:500]}); build the daemon "
            f"(cargo build -p antumbra-cli) or set ANTUMBRA_BIN"
        )
    return binary


@pytest.fixture
def short_tmp():
    """A private directory under /tmp: Unix socket paths must stay short (~100 bytes)."""
    d = tempfile.mkdtemp(prefix="antpy-", dir="/tmp")
    yield Path(d)
    shutil.rmtree(d, ignore_errors=True)


@pytest.fixture
def daemon(antumbra_bin, short_tmp):
    """A client of a daemon spawned for the test; the daemon stops at the end."""
    client = antumbra.Client.spawn(antumbra_bin, socket_path=short_tmp / "d.sock", timeout=30)
    yield client
    client.close()

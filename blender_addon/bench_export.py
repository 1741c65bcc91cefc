"""Export time per frame of a ~1M-triangle scene, through the add-on's exporter.

    .venv/bin/python blender_addon/bench_export.py            # the bpy 5.0.1 module
    blender -b --factory-startup -P blender_addon/bench_export.py   # Debian's Blender 3.4

The mesh is a grid of triangles or of quads (~1M triangles either way). Timed (median): the
first frame (every mesh read from Blender and hashed), later frames where it only moves (read
once, cached), and later frames where a modifier deforms it (positions read and hashed every
frame; triangles reused while the topology stays).
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

if "bpy" not in sys.modules:
    os.environ.setdefault("HOME", tempfile.mkdtemp(prefix="antumbra-bench-home-"))

import bpy
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from antumbra import client_loader
from antumbra.export.exporter import Exporter

N = 708  # N x N vertices: 2 (N-1)^2 = 999,698 triangles


def grid_mesh(name: str, quads: bool):
    xs = np.linspace(-10, 10, N, dtype=np.float32)
    x, y = np.meshgrid(xs, xs)
    positions = np.stack([x.ravel(), y.ravel(), np.zeros(N * N, np.float32)], axis=1)
    i = np.arange(N - 1)
    a = (i[:, None] * N + i[None, :]).ravel()
    if quads:
        faces = np.stack([a, a + 1, a + N + 1, a + N], 1).astype(np.int32)
    else:
        faces = np.concatenate(
            [np.stack([a, a + 1, a + N + 1], 1), np.stack([a, a + N + 1, a + N], 1)]
        ).astype(np.int32)
    k = faces.shape[1]
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.ravel())
    mesh.loops.add(k * len(faces))
    mesh.loops.foreach_set("vertex_index", faces.ravel())
    mesh.polygons.add(len(faces))
    mesh.polygons.foreach_set("loop_start", np.arange(0, k * len(faces), k, dtype=np.int32))
    if bpy.app.version < (4, 0, 0):
        mesh.polygons.foreach_set("loop_total", np.full(len(faces), k, dtype=np.int32))
    mesh.update()
    return mesh


def scene_with(deforming: bool, quads: bool):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    obj = bpy.data.objects.new("Terrain", grid_mesh("Terrain", quads))
    scene.collection.objects.link(obj)
    for frame in range(1, 12):
        obj.location.x = 0.1 * frame
        obj.keyframe_insert("location", frame=frame)
    if deforming:
        wave = obj.modifiers.new("Wave", "WAVE")
        wave.height = 0.3
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.location = (0, -20, 10)
    scene.collection.objects.link(camera)
    scene.camera = camera
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    return scene


def time_frames(scene, exporter, frames):
    times, triangles = [], 0
    for f in frames:
        scene.frame_set(f)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        start = time.perf_counter()
        e = exporter.frame(depsgraph, scene, f, 100)
        times.append(time.perf_counter() - start)
        triangles = e.triangles
    return times, triangles


def main():
    client = client_loader.load()
    print(f"Blender {bpy.app.version_string}, numpy {np.__version__}")
    for deforming, quads in ((False, False), (True, False), (False, True), (True, True)):
        scene = scene_with(deforming, quads)
        firsts = []
        for _ in range(3):
            t, triangles = time_frames(scene, Exporter(client), [1])
            firsts += t
        exporter = Exporter(client)
        time_frames(scene, exporter, [1])
        later, _ = time_frames(scene, exporter, range(2, 12))
        kind = "deforming (modifier)" if deforming else "moving only"
        kind += ", quads" if quads else ", triangles"
        print(
            f"{kind:33} {triangles} triangles: first frame {statistics.median(firsts):.3f} s, "
            f"later frames median {statistics.median(later):.3f} s "
            f"(min {min(later):.3f}, max {max(later):.3f})"
        )


if __name__ == "__main__":
    main()

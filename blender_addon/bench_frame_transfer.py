"""Export and transfer of a frame of 100,000 geometry-node instances to a real daemon, before
and after instance arrays (issue 37): seconds per frame (export, then ``frame_update`` over the
socket) and bytes sent per frame.

    .venv/bin/python blender_addon/bench_frame_transfer.py -- --daemon target/release/antumbra

- ``objects`` (before): the exporter as it was before arrays (protocol 3's way: one object map
  per instance), loaded from git (``--before REV``, default the commit before arrays); its
  frame sent as objects.
- ``arrays`` (after): today's exporter; frame 1 sends the array, frame 2 (nothing moved) sends
  it as unchanged, frame 3 (the scatter moved) sends it again.

The scene is bench_instances.py's scatter of one mesh. docs/instances_export.md has the results.
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_instances  # noqa: E402  (after the path it lives on)


def load_addon():
    init = HERE / "antumbra" / "__init__.py"
    spec = importlib.util.spec_from_file_location(
        "antumbra_addon", init, submodule_search_locations=[str(init.parent)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules["antumbra_addon"] = module
    spec.loader.exec_module(module)
    return importlib.import_module("antumbra_addon.export.exporter")


def load_before(rev: str):
    """The exporter of REV (a module without relative imports then), from git."""
    source = subprocess.run(
        ["git", "show", f"{rev}:blender_addon/antumbra/export/exporter.py"],
        cwd=HERE.parent,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    path = Path(tempfile.mkdtemp()) / "exporter_before.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("exporter_before", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def send(client, e, arrays: bool) -> None:
    instances = e.instances if arrays else ()
    missing = client.frame_update(e.frame, e.objects, e.camera, e.lights, e.resolution, instances)
    for h in missing:
        m = e.meshes[h]
        client.upload_mesh(m.name, m.positions, m.triangles)


def frame_cost(client, exporter, scene, frame: int, arrays: bool) -> tuple[float, float, int]:
    scene.frame_set(frame)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    start = time.perf_counter()
    e = exporter.frame(depsgraph, scene, frame, 100)
    exported = time.perf_counter()
    before = client.bytes_sent
    send(client, e, arrays)
    return exported - start, time.perf_counter() - exported, client.bytes_sent - before


def main():
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    p = argparse.ArgumentParser()
    p.add_argument("--count", type=int, default=100_000)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--daemon", required=True, help="the antumbra binary")
    p.add_argument("--before", default="bac6229", help="git revision of the exporter before")
    a = p.parse_args(argv)

    after = load_addon()
    # The client as the add-on finds it (this folder's `antumbra` is the add-on itself).
    client_module = sys.modules["antumbra_addon"].client_loader.load()
    before = load_before(a.before)
    scene = bench_instances.scene_with(a.count, 1)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    scene.collection.objects.link(camera)
    scene.camera = camera
    scatter = scene.objects["Scatter"]
    scatter.keyframe_insert("location", frame=1)
    scatter.keyframe_insert("location", frame=2)
    scatter.location.x += 1.0
    scatter.keyframe_insert("location", frame=3)
    print(f"Blender {bpy.app.version_string}, {a.count} instances, median of {a.repeat}")
    runs = {
        "objects (before)": (before, False, [1, 2, 3]),
        "arrays (after)": (after, True, [1, 2, 3]),
    }
    for label, (module, arrays, frames) in runs.items():
        costs = {f: [] for f in frames}
        for _ in range(a.repeat):
            # A fresh session each time: frame 1 is then a first frame.
            with client_module.Client.spawn(a.daemon, timeout=120) as client:
                exporter = module.Exporter(client_module)
                for f in frames:
                    costs[f].append(frame_cost(client, exporter, scene, f, arrays))
        for f, runs_of_frame in costs.items():
            export = statistics.median(c[0] for c in runs_of_frame)
            transfer = statistics.median(c[1] for c in runs_of_frame)
            sent = statistics.median(c[2] for c in runs_of_frame)
            print(
                f"{label:18} frame {f}: export {export * 1e3:8.1f} ms, frame_update "
                f"{transfer * 1e3:8.1f} ms, {sent / 1e6:8.3f} MB sent"
            )


if __name__ == "__main__":
    main()

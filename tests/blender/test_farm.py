"""The farm job (``farm/``, docs/farm.md) run by ``openjd`` (openjd-cli from the package
registry, in ``.venv-openjd``) with Debian's Blender: the bundle passes ``openjd check``; 12
frames in 3 chunks, each Blender's ``-a`` with the antumbra engine, give the multilayer EXRs and
statistics rows of one sequential ``blender -b -E ANTUMBRA -s 1 -e 12 -a`` (the chunk borders lie
where one run reuses its trees, so a chunk that did not warm up on the frames before it would
differ); a chunk run again after two of its frames were deleted renders exactly those (Blender
skips the frames whose EXR exists); and a chunked comparison's merged report equals one run's."""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path

import pytest
from conftest import ADDON, REPO, blender_env, run_blender
from test_engine import blender_engine, engine_env, output_expr

import antumbra

FARM = REPO / "farm"
TEMPLATE = FARM / "template.yaml"
#: Blender's command line over the bpy module (the farm job in the module's Blender).
BPY_BLENDER = Path(__file__).parent / "bpy_blender.py"
FRAMES, CHUNK = 12, 4
#: The settings every run here uses: OSAH from the previous frame's visible set on the binary tree
#: front to back (as batch flags, and as the engine's settings). A fixed order: `auto`'s choices
#: on a chunk's frames follow from frames a warm-up does not trace, so its heat maps may differ.
SETTINGS = ["--build", "osah", "--width", "2", "--order", "fbto", "--spp", "2"]
METHOD = {"build": "osah", "width": "2", "order": "fbto", "spp": 2}
#: Columns that are times: they differ between runs.
TIMES = ("_ms", "_ms_min", "_ms_max", "mrays_per_s", "seconds")

#: A small animated scene: the camera moves over frames 1-3, holds still over 3-7 (one run
#: reuses its trees there: frame 5, a chunk's first, reads state two frames old) and moves on.
SCENE = """
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.mesh.primitive_plane_add(size=20)
bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, location=(0, 0, 1))
bpy.ops.mesh.primitive_cube_add(location=(2.5, 1, 1))
bpy.ops.mesh.primitive_ico_sphere_add(subdivisions=3, location=(-2, -1, 0.8))
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
scene.camera = camera
camera.rotation_euler = (1.1, 0, 0)
for frame, x in ((1, -3.0), (3, -1.0), (7, -1.0), (12, 3.0)):
    camera.location = (x, -9.0, 4.0)
    camera.keyframe_insert("location", frame=frame)
for curve in camera.animation_data.action.fcurves:
    for key in curve.keyframe_points:
        key.interpolation = "LINEAR"
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.rotation_euler = (0.6, 0.3, 0)
scene.collection.objects.link(sun)
lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
lamp.data.shadow_soft_size = 0.5
lamp.location = (1, -2, 4)
scene.collection.objects.link(lamp)
scene.render.resolution_x, scene.render.resolution_y = 64, 48
scene.render.resolution_percentage = 100
scene.frame_start, scene.frame_end = 1, 12
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])
"""


def openjd_bin() -> Path:
    path = Path(os.environ.get("OPENJD", REPO / ".venv-openjd" / "bin" / "openjd"))
    if not path.is_file():
        pytest.fail(f"no openjd at {path}: run scripts/setup.sh (it makes .venv-openjd)")
    return path


def openjd(env: dict, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(openjd_bin()), *args], env=env, capture_output=True, text=True, timeout=300
    )


def job_params(
    blend: Path, out: Path, antumbra_bin: Path, *extra: str, addon: Path = ADDON
) -> list[str]:
    params = {
        "BlendFile": blend,
        "OutputDir": out,
        "AddonDir": addon,
        "AntumbraBinary": antumbra_bin,
        "FrameStart": 1,
        "FrameEnd": FRAMES,
        "ChunkSize": CHUNK,
        "BatchArgs": " ".join(SETTINGS),
    }
    return [arg for k, v in params.items() for arg in ("-p", f"{k}={v}")] + list(extra)


def frame_lines(stdout: str) -> list[int]:
    """The frames a log says were rendered or compared (``antumbra: frame N 0.12 s ...``, after
    openjd's time stamp; not Blender's status lines ``antumbra: frame N: export``)."""
    return [int(f) for f in re.findall(r"antumbra: frame (\d+) (?:\(|[\d.]+ s)", stdout)]


def rows_without_times(path: Path) -> tuple[list[str], list[dict]]:
    with open(path) as f:
        reader = csv.DictReader(f)
        rows = [{k: v for k, v in r.items() if not k.endswith(TIMES)} for r in reader]
        return reader.fieldnames, rows


def differing_exrs(a: Path, b: Path, frames) -> list[str]:
    """The frames whose EXRs in folders a and b differ in a channel's name or bits (the files
    differ anyway: Blender stamps the render time into them)."""
    out = []
    for f in frames:
        x, y = (antumbra.read_exr(d / f"frame_{f:04d}.exr") for d in (a, b))
        if sorted(x) != sorted(y) or any(x[k].tobytes() != y[k].tobytes() for k in x):
            out.append(f"frame {f}")
    return out


class Farm:
    """A folder with the scene, a sequential batch run and the farm job's run of it."""

    def __init__(self, antumbra_bin: Path, addon_zips):
        self.tmp = Path(tempfile.mkdtemp(prefix="antfarm-", dir="/tmp"))
        self.antumbra_bin, self.addon_zips = antumbra_bin, addon_zips
        self.home = self.tmp / "home"
        self.env_bin = {"ANTUMBRA_BIN": str(antumbra_bin)}
        self.env = blender_env(self.home, **self.env_bin)
        script = self.tmp / "scene.py"
        script.write_text(SCENE)
        self.blend = self.tmp / "scene.blend"
        made = run_blender(["-P", str(script), "--", str(self.blend)], self.home)
        assert made.returncode == 0 and self.blend.is_file(), made.stdout + made.stderr

    def engine(self, out: Path) -> subprocess.CompletedProcess:
        """One sequential ``-a`` over every frame with the antumbra engine."""
        env = {**engine_env(self.tmp / "seq-engine", self.addon_zips), **self.env_bin}
        done = blender_engine(
            self.blend,
            self.tmp / "seq-engine",
            env,
            output_expr(out, **METHOD),
            "-s",
            "1",
            "-e",
            str(FRAMES),
            "-a",
        )
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
        return done

    def sequential(self) -> Path:
        """The engine's one sequential run over every frame (made once)."""
        seq = self.tmp / "seq"
        if not (seq / "stats.csv").is_file():
            self.engine(seq)
        return seq

    def batch(self, out: Path, *extra: str) -> subprocess.CompletedProcess:
        """One sequential batch run over every frame."""
        args = [str(self.blend), "-P", str(ADDON / "batch.py"), "--", "--out", str(out)]
        args += ["--frames", f"1-{FRAMES}", "--socket", str(self.tmp / "seq.sock"), *SETTINGS]
        done = run_blender([*args, *extra], self.home, env=self.env)
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
        return done

    def job(self, out: Path, *extra: str, addon: Path = ADDON) -> subprocess.CompletedProcess:
        params = job_params(self.blend, out, self.antumbra_bin, *extra, addon=addon)
        return openjd(self.env, "run", str(TEMPLATE), *params)


@pytest.fixture(scope="module")
def farm(antumbra_bin, addon_zips):
    f = Farm(antumbra_bin, addon_zips)
    yield f
    shutil.rmtree(f.tmp, ignore_errors=True)


def test_bundle_passes_openjd_check(antumbra_bin, tmp_path):
    done = openjd(dict(os.environ), "check", str(TEMPLATE))
    assert done.returncode == 0, done.stdout + done.stderr
    assert "passes validation checks" in done.stdout
    # 12 frames in chunks of 4: three render tasks, then the merge.
    summary = openjd(
        dict(os.environ),
        "summary",
        str(TEMPLATE),
        "--output",
        "json",
        *job_params(tmp_path / "s.blend", tmp_path / "out", antumbra_bin),
    )
    assert summary.returncode == 0, summary.stdout + summary.stderr
    steps = {s["name"]: s["total_tasks"] for s in json.loads(summary.stdout)["steps"]}
    assert steps == {"Render": 3, "Merge": 1}, summary.stdout
    # The bundle's other files are what Deadline Cloud reads (YAML with these keys).
    python = openjd_bin().parent / "python"
    check = (
        "import sys, yaml; v = yaml.safe_load(open(sys.argv[1])); r = yaml.safe_load(open("
        "sys.argv[2]))['assetReferences']; assert [p['name'] for p in v['parameterValues']];"
        "assert set(r) == {'inputs', 'outputs', 'referencedPaths'}, r"
    )
    loaded = subprocess.run(
        [str(python), "-c", check, FARM / "parameter_values.yaml", FARM / "asset_references.yaml"],
        capture_output=True,
        text=True,
    )
    assert loaded.returncode == 0, loaded.stderr


def test_chunks_equal_one_run_and_a_chunk_resumes(farm):
    seq, out = farm.sequential(), farm.tmp / "farm"
    # The test means something: one run reuses its trees at frame 5, the second chunk's first.
    _, seq_rows = rows_without_times(seq / "stats.csv")
    assert {r["rebuilt"] for r in seq_rows if r["frame"] == "5"} == {"false"}

    done = farm.job(out, "--step", "Merge", "--run-dependencies")
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-3000:]
    assert frame_lines(done.stdout) == list(range(1, FRAMES + 1)), done.stdout
    # Each later chunk warmed up on the two frames before it first (no files, no rows).
    assert "warmed up on (state only): 3, 4" in done.stdout
    assert "warmed up on (state only): 7, 8" in done.stdout
    assert "merged 12 frame(s)" in done.stdout
    # Blender's multilayer EXRs (every pass: masks, Combined, the heat maps of every pass's work
    # per pixel) and the statistics rows are those of the sequential run; the tables' columns
    # too, in the same order.
    assert sorted(p.name for p in out.glob("*.exr")) == [
        f"frame_{f:04d}.exr" for f in range(1, FRAMES + 1)
    ]
    assert "ViewLayer.shadow.N_B.X" in antumbra.read_exr(out / "frame_0005.exr")
    assert differing_exrs(seq, out, range(1, FRAMES + 1)) == []
    for table in ("stats.csv", "frames.csv"):
        assert rows_without_times(out / table) == rows_without_times(seq / table), table

    # Two frames of the second chunk lost: running that task again renders exactly those (Blender
    # skips the frames whose EXR exists), after warming up on the two frames before the first.
    for f in (6, 7):
        for p in out.glob(f"frame_{f:04d}*"):
            p.unlink()
    again = farm.job(out, "--step", "Render", "--task-param", "ChunkStart=5")
    assert again.returncode == 0, again.stdout[-5000:] + again.stderr[-3000:]
    assert frame_lines(again.stdout) == [6, 7], again.stdout
    assert "skipping existing frame" in again.stdout and "frame_0005.exr" in again.stdout
    assert "warmed up on (state only): 4, 5" in again.stdout
    assert differing_exrs(seq, out, range(1, FRAMES + 1)) == []
    merged = farm.job(out, "--step", "Merge", "--no-run-dependencies")
    assert merged.returncode == 0, merged.stdout[-3000:] + merged.stderr[-3000:]
    for table in ("stats.csv", "frames.csv"):
        assert rows_without_times(out / table) == rows_without_times(seq / table), table


def test_merge_fails_on_a_missing_frame(farm):
    out = farm.tmp / "half"
    done = farm.job(out, "--step", "Render", "--task-param", "ChunkStart=1")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    merged = farm.job(out, "--step", "Merge", "--no-run-dependencies")
    assert merged.returncode != 0
    assert "8 frame(s) missing: 5, 6, 7, 8, 9, 10, 11, 12" in merged.stdout + merged.stderr


def test_chunked_comparison_equals_one_run(farm):
    compare = [
        "--compare",
        "sah=build=sah,width=2,order=fbto",
        "osah=build=osah,width=2,order=fbto",
        "--repeat",
        "1",
    ]
    seq, out = farm.tmp / "seq-compare", farm.tmp / "farm-compare"
    farm.batch(seq, *compare)
    done = farm.job(
        out,
        "--step",
        "Merge",
        "--run-dependencies",
        "-p",
        "BatchArgs=" + " ".join(SETTINGS + compare),
    )
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-3000:]
    assert frame_lines(done.stdout) == list(range(1, FRAMES + 1)), done.stdout
    header, rows = rows_without_times(out / "compare" / "compare.csv")
    assert len(rows) == FRAMES * 2 * 3  # frames x methods x passes (primary, Sun, Lamp)
    assert (header, rows) == rows_without_times(seq / "compare" / "compare.csv")
    assert (out / "compare" / "report.html").is_file()


@pytest.mark.parametrize("kind", ["legacy", "extension"])
def test_a_chunk_runs_from_the_release_zip(farm, kind, tmp_path):
    """No checkout: the job bundle and the add-on unzipped from either release zip, each in a
    folder of its own (the extension's client wheel is unpacked by the task)."""
    bundle, addon, out = tmp_path / "farm", tmp_path / "addon", tmp_path / "out"
    shutil.copytree(FARM, bundle)
    with zipfile.ZipFile(farm.addon_zips[kind]) as z:
        z.extractall(addon)
    params = job_params(farm.blend, out, farm.antumbra_bin, addon=addon)
    done = openjd(
        farm.env,
        *("run", str(bundle / "template.yaml"), *params, "-p", f"FarmDir={bundle}"),
        *("--step", "Render", "--task-param", "ChunkStart=5"),
    )
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-3000:]
    assert frame_lines(done.stdout) == [5, 6, 7, 8], done.stdout
    assert "warmed up on (state only): 3, 4" in done.stdout
    assert differing_exrs(farm.sequential(), out, range(5, 9)) == []


@pytest.mark.bpy
def test_a_chunk_runs_in_the_bpy_module(farm, tmp_path):
    """The job in this Python's bpy module (4.2, 4.5, 5.x: each sets the output format its own
    way) through ``bpy_blender.py``, Blender's command line over the module, from the legacy
    zip alone: the chunk's frames equal Debian 3.4's sequential run, bit for bit."""
    import sys

    blender = tmp_path / "blender"
    blender.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{BPY_BLENDER}" "$@"\n')
    blender.chmod(0o755)
    addon, out = tmp_path / "addon", tmp_path / "out"
    with zipfile.ZipFile(farm.addon_zips["legacy"]) as z:
        z.extractall(addon)
    done = farm.job(
        out,
        *("-p", f"BlenderExecutable={blender}", "--step", "Render", "--task-param", "ChunkStart=5"),
        addon=addon,
    )
    assert done.returncode == 0, done.stdout[-5000:] + done.stderr[-3000:]
    assert frame_lines(done.stdout) == [5, 6, 7, 8], done.stdout
    assert differing_exrs(farm.sequential(), out, range(5, 9)) == []

"""Headless batches in Debian's ``blender -b``: ten frames with files and statistics, resuming a
half-done folder, surviving a daemon killed mid-run, and failing clearly (non-zero exit, the
object and frame named) on bad input or with no daemon to be had."""

from __future__ import annotations

import csv
import itertools
import json
import os
import signal
import subprocess
import time
import zipfile
from pathlib import Path

from conftest import ADDON, FRAMES, SIZE, blender_env, run_blender

import antumbra

BATCH = ADDON / "batch.py"
LIGHTS = ("Sun", "Window")


def batch(blend: Path, out: Path, home: Path, *extra: str, env=None):
    return run_blender(
        [str(blend), "-P", str(BATCH), "--", "--out", str(out), "--spp", "1", *extra],
        home,
        env=env,
    )


def frame_lines(stdout: str) -> list[str]:
    return [line for line in stdout.splitlines() if line.startswith("antumbra: frame ")]


def test_ten_frames_then_resume(scene_blend, antumbra_bin, short_tmp):
    out = short_tmp / "out"
    env = blender_env(short_tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    # A fixed method: a resumed run warms up its trees but not what auto measured, so with the
    # default only its masks would be the same again (docs/auto.md).
    sock = ["--socket", str(short_tmp / "d.sock"), "--build", "sah", "--order", "sorted"]
    done = batch(scene_blend, out, short_tmp / "home", "--frames", f"1-{FRAMES}", *sock, env=env)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert len(frame_lines(done.stdout)) == FRAMES, done.stdout
    assert f"summary: {FRAMES} rendered" in done.stdout
    for f in range(1, FRAMES + 1):
        planes = antumbra.read_exr(out / f"frame_{f:04d}.exr")
        assert {f"shadow.{light}" for light in LIGHTS} <= set(planes)
        assert planes["combined"].shape == (SIZE[1], SIZE[0])
        assert (out / f"frame_{f:04d}_shadow_Sun.png").is_file()
    with open(out / "frames.csv") as f:
        frames = list(csv.DictReader(f))
    assert [int(r["frame"]) for r in frames] == list(range(1, FRAMES + 1))
    with open(out / "stats.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == FRAMES * (1 + len(LIGHTS))
    # The add-on's stats.csv is the Rust writer's (the one `antumbra render` uses) for its rows.
    antumbra.write_stats_csv(short_tmp / "rust.csv", json.loads((out / "stats.json").read_text()))
    assert (out / "stats.csv").read_bytes() == (short_tmp / "rust.csv").read_bytes()

    # Half the work lost: the batch renders only what is missing, and the same pixels again.
    before = (out / "frame_0004.exr").read_bytes()
    for f in (4, 7):
        (out / f"frame_{f:04d}.stats.json").unlink()
    (out / "frame_0004.exr").unlink()
    again = batch(scene_blend, out, short_tmp / "home", "--frames", f"1-{FRAMES}", *sock, env=env)
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert f"resuming: {FRAMES - 2} frame(s) already done" in again.stdout
    assert [line.split()[2] for line in frame_lines(again.stdout)] == ["4", "7"]
    assert (out / "frame_0004.exr").read_bytes() == before
    with open(out / "frames.csv") as f:
        assert [int(r["frame"]) for r in csv.DictReader(f)] == list(range(1, FRAMES + 1))

    # Other settings: nothing in the folder is theirs, so every frame is rendered again.
    other = batch(
        scene_blend, out, short_tmp / "home", "--frames", "1-3", "--width", "4", *sock, env=env
    )
    assert other.returncode == 0, other.stdout[-3000:] + other.stderr[-3000:]
    assert "3 frame(s) in" in other.stdout and "other settings" in other.stdout, other.stdout
    assert len(frame_lines(other.stdout)) == 3


def test_daemon_killed_mid_animation(scene_blend, antumbra_bin, short_tmp):
    """The batch starts its own daemon; it is killed (SIGKILL) after the second frame. The
    batch restarts it and finishes every frame, none lost."""
    out = short_tmp / "out"
    home = short_tmp / "home"
    home.mkdir()
    env = blender_env(home, ANTUMBRA_BIN=str(antumbra_bin))
    command = ["blender", "-b", "--factory-startup", "-noaudio", str(scene_blend)]
    command += ["-P", str(BATCH), "--", "--out", str(out), "--spp", "1"]
    command += ["--frames", f"1-{FRAMES}", "--socket", str(short_tmp / "d.sock")]
    proc = subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    lines, pid, killed = [], None, False
    deadline = time.monotonic() + 300
    for line in proc.stdout:
        lines.append(line)
        if "started " in line and "(pid " in line:
            pid = int(line.split("(pid ")[1].split(")")[0])
        if not killed and line.startswith("antumbra: frame 2 "):
            assert pid is not None, "".join(lines)
            os.kill(pid, signal.SIGKILL)
            killed = True
        assert time.monotonic() < deadline, "".join(lines)
    code = proc.wait(timeout=60)
    stdout, stderr = "".join(lines), proc.stderr.read()
    assert killed, stdout
    assert code == 0, stdout[-3000:] + stderr[-3000:]
    assert "lost the daemon" in stdout and "reconnects 1" in stdout, stdout
    rendered = [int(line.split()[2]) for line in frame_lines(stdout)]
    assert rendered == list(range(1, FRAMES + 1)), stdout
    assert sorted(p.name for p in out.glob("frame_*.exr")) == [
        f"frame_{f:04d}.exr" for f in range(1, FRAMES + 1)
    ]


NAN_SCENE = """
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
mesh = bpy.data.meshes.new("BrokenMesh")
mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, float("nan"))], [], [(0, 1, 2)])
scene.collection.objects.link(bpy.data.objects.new("Broken", mesh))
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.location = (0.3, 0.3, 5.0)
scene.collection.objects.link(camera)
scene.camera = camera
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
scene.render.resolution_x, scene.render.resolution_y = 32, 24
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])
"""


def test_nan_mesh_fails_naming_object_and_frame(antumbra_bin, short_tmp):
    script = short_tmp / "nan_scene.py"
    script.write_text(NAN_SCENE)
    blend = short_tmp / "nan.blend"
    made = run_blender(["-P", str(script), "--", str(blend)], short_tmp / "home")
    assert made.returncode == 0 and blend.is_file(), made.stderr
    env = blender_env(short_tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    done = batch(
        blend,
        short_tmp / "out",
        short_tmp / "home",
        "--frames",
        "1",
        "--socket",
        str(short_tmp / "d.sock"),
        env=env,
    )
    assert done.returncode == 1, done.stdout + done.stderr
    assert "frame 1" in done.stderr and "object 'Broken'" in done.stderr, done.stderr
    assert "non-finite" in done.stderr, done.stderr


def test_no_daemon_and_no_binary_is_a_clear_failure(scene_blend, short_tmp):
    env = blender_env(short_tmp / "home", PATH="/usr/bin:/bin")
    env.pop("ANTUMBRA_BIN", None)
    done = batch(
        scene_blend,
        short_tmp / "out",
        short_tmp / "home",
        "--frames",
        "1-2",
        "--socket",
        str(short_tmp / "none.sock"),
        env=env,
    )
    assert done.returncode == 1, done.stdout + done.stderr
    assert "frame 1" in done.stderr and "antumbra binary was not found" in done.stderr
    assert "summary: 0 rendered" in done.stdout


def test_bad_arguments_exit_non_zero(scene_blend, short_tmp):
    done = batch(scene_blend, short_tmp / "out", short_tmp / "home", "--frames", "9-3")
    assert done.returncode == 2, done.stdout + done.stderr
    assert "--frames: the range 9-3 is empty" in done.stderr
    done = batch(scene_blend, short_tmp / "out", short_tmp / "home", "--min-leaf-size", "9")
    assert done.returncode == 2, done.stdout + done.stderr
    assert "min_leaf_size: must be at most leaf_size (8), got 9" in done.stderr
    done = batch(scene_blend, short_tmp / "out", short_tmp / "home", "--osah-w", "2")
    assert done.returncode == 2, done.stdout + done.stderr
    assert "osah_w: expected a number in (0, 1), got a number (2)" in done.stderr


def test_a_missing_binary_is_an_error_naming_it(scene_blend, antumbra_bin, short_tmp):
    """``--binary`` naming no executable is refused, even with another binary to be had
    (``$ANTUMBRA_BIN``); nothing is rendered."""
    env = blender_env(short_tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    text = short_tmp / "not-a-binary"
    text.write_text("")
    for path, why in ((short_tmp / "nonexistent", "does not exist"), (text, "is not executable")):
        done = batch(
            scene_blend,
            short_tmp / "out",
            short_tmp / "home",
            "--frames",
            "1",
            "--binary",
            str(path),
            "--socket",
            str(short_tmp / "d.sock"),
            env=env,
        )
        assert done.returncode == 2, done.stdout + done.stderr
        assert f"--binary: {path} {why}" in done.stderr, done.stderr
        assert not (short_tmp / "out" / "frame_0001.exr").exists()


def test_spool_batch_equals_socket_batch_and_resumes(scene_blend, antumbra_bin, short_tmp):
    """--spool: the frames go to the daemon as one spool job; the files collected equal, byte
    for byte, those of a batch over the socket with the same (non-default) method settings;
    running it again follows the same job."""
    env = blender_env(short_tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    frames = ["--frames", "2-4", "--build", "osah", "--width", "8", "--order", "sorted"]
    frames += ["--min-leaf-size", "4"]
    direct = batch(
        scene_blend,
        short_tmp / "direct",
        short_tmp / "home",
        *frames,
        "--socket",
        str(short_tmp / "d.sock"),
        env=env,
    )
    assert direct.returncode == 0, direct.stdout[-3000:] + direct.stderr[-3000:]
    spooled = batch(
        scene_blend,
        short_tmp / "spooled",
        short_tmp / "home",
        *frames,
        "--spool",
        str(short_tmp / "spool"),
        env=env,
    )
    assert spooled.returncode == 0, spooled.stdout[-3000:] + spooled.stderr[-3000:]
    assert "submitted job" in spooled.stdout
    assert len(frame_lines(spooled.stdout)) == 3
    for f in (2, 3, 4):
        name = f"frame_{f:04d}.exr"
        assert (short_tmp / "spooled" / name).read_bytes() == (
            short_tmp / "direct" / name
        ).read_bytes(), name
    again = batch(
        scene_blend,
        short_tmp / "spooled",
        short_tmp / "home",
        *frames,
        "--spool",
        str(short_tmp / "spool"),
        env=env,
    )
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert "following job" in again.stdout and "3 already done" in again.stdout
    for folder in ("direct", "spooled"):
        with open(short_tmp / folder / "stats.csv") as f:
            methods = {row["method"] for row in csv.DictReader(f)}
        assert methods == {"osah-previous:leaf4/bin8/sorted:logging=sato:p=1:budget=0.05"}, methods


def test_both_zips_ship_the_batch_and_it_runs(addon_zips, scene_blend, short_tmp):
    """``batch.py`` is in each zip, inside the add-on's folder, byte for byte the checkout's; the
    legacy zip's copy, unpacked as Blender installs it, lists its flags in ``blender -b``."""
    where = {"extension": "batch.py", "legacy": "antumbra/batch.py"}
    for kind, path in addon_zips.items():
        with zipfile.ZipFile(path) as z:
            assert z.read(where[kind]) == BATCH.read_bytes(), kind
            if kind == "legacy":
                z.extractall(short_tmp / "addons")
    shipped = short_tmp / "addons" / "antumbra" / "batch.py"
    done = run_blender([str(scene_blend), "-P", str(shipped), "--", "--help"], short_tmp / "home")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "--leaf-size" in done.stdout and "--frames" in done.stdout, done.stdout


def _methods(stats_csv: Path) -> set[str]:
    with open(stats_csv) as f:
        return {row["method"] for row in csv.DictReader(f)}


def test_the_batch_takes_what_antumbra_render_takes(
    scene_blend, recording, antumbra_bin, short_tmp
):
    """Every method-settings flag of ``antumbra render --help`` is a batch flag, and flags the
    command line takes in its short forms (``--build srdh``, ``--no-spatial-splits``,
    ``--timing`` alone) render in the batch with the method ``antumbra render`` reports."""
    cli_help = subprocess.run(
        [str(antumbra_bin), "render", "--help"], check=True, capture_output=True, text=True
    ).stdout
    # A method setting's help ends "[EXPECTED; default: D]" or says "The same as --NAME false".
    lines = cli_help[cli_help.index("Method settings:") :].splitlines()
    cli_flags = {
        flag.split()[0]
        for flag, text in itertools.pairwise(lines)
        if flag.startswith("      --") and ("; default: " in text or "The same as --" in text)
    }
    assert "--build" in cli_flags and "--no-spatial-splits" in cli_flags, cli_help
    shown = run_blender([str(scene_blend), "-P", str(BATCH), "--", "--help"], short_tmp / "home")
    assert shown.returncode == 0, shown.stdout[-3000:] + shown.stderr[-3000:]
    batch_flags = {w.strip("[],") for w in shown.stdout.split() if w.startswith(("--", "[--"))}
    assert cli_flags <= batch_flags, cli_flags - batch_flags

    flags = ["--spp", "1", "--build", "srdh", "--no-spatial-splits", "--timing"]
    subprocess.run(
        [
            *(str(antumbra_bin), "render", "--scene", str(recording), "--frames", "1-2"),
            *("--out", str(short_tmp / "cli"), *flags),
        ],
        check=True,
        capture_output=True,
    )
    env = blender_env(short_tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    done = batch(
        scene_blend,
        short_tmp / "out",
        short_tmp / "home",
        "--frames",
        "1-2",
        *flags,
        "--socket",
        str(short_tmp / "d.sock"),
        env=env,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert len(frame_lines(done.stdout)) == 2, done.stdout
    methods = _methods(short_tmp / "out" / "stats.csv")
    assert methods == _methods(short_tmp / "cli" / "stats.csv"), methods
    assert any("srdh" in m for m in methods), methods


UNICODE_LIGHTS_SCENE = """
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
mesh = bpy.data.meshes.new("Ground")
mesh.from_pydata([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], [], [(0, 1, 2, 3)])
scene.collection.objects.link(bpy.data.objects.new("Ground", mesh))
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.location = (0.0, 0.0, 6.0)
scene.collection.objects.link(camera)
scene.camera = camera
for name in ("Lamp \u00e4", "Lamp \u00f6"):
    scene.collection.objects.link(bpy.data.objects.new(name, bpy.data.lights.new(name, "SUN")))
scene.render.resolution_x, scene.render.resolution_y = 32, 24
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])
"""


def test_lights_differing_in_non_ascii_letters_get_their_own_files(antumbra_bin, short_tmp):
    """Two lights named "Lamp ä" and "Lamp ö": each its own PNG and its own EXR plane, under its
    own name (the naming of rust/core/src/output/names.rs, in the daemon and the client)."""
    script = short_tmp / "lights.py"
    script.write_text(UNICODE_LIGHTS_SCENE)
    blend = short_tmp / "lights.blend"
    made = run_blender(["-P", str(script), "--", str(blend)], short_tmp / "home")
    assert made.returncode == 0 and blend.is_file(), made.stderr
    env = blender_env(short_tmp / "home", ANTUMBRA_BIN=str(antumbra_bin))
    out = short_tmp / "out"
    done = batch(
        blend,
        out,
        short_tmp / "home",
        "--frames",
        "1",
        "--socket",
        str(short_tmp / "d.sock"),
        env=env,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    pngs = sorted(p.name for p in out.glob("frame_0001_shadow_*.png"))
    assert pngs == ["frame_0001_shadow_Lamp_\u00e4.png", "frame_0001_shadow_Lamp_\u00f6.png"]
    planes = antumbra.read_exr(out / "frame_0001.exr")
    assert {"shadow.Lamp \u00e4", "shadow.Lamp \u00f6"} <= set(planes), list(planes)

"""The render engine (``ANTUMBRA``) as Blender and farms run it: ``blender -b scene.blend -E
ANTUMBRA -f N`` and ``-a`` in Debian's 3.4 with the add-on enabled by ``--addons``, and Blender's
own render operator in the bpy module; multilayer EXRs written by Blender's output whose passes
equal ``antumbra render`` of what the engine sent (recorded by the daemon), one daemon session per
job, the statistics tables beside the output, the compositor's Render Layers node listing the
passes, F12 in a real window, and Ctrl-C (Blender's render break) cancelling the render in
flight."""

from __future__ import annotations

import csv
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import zipfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest
from conftest import blender_env, cli_render, run_blender
from test_batch import NAN_SCENE, batch

import antumbra

SCRIPT = Path(__file__).parent / "scripts" / "engine_render.py"
F12_SCRIPT = Path(__file__).parent / "scripts" / "engine_f12.py"
LIGHTS = ("Sun", "Window")
HEAT = (
    "primary.N_B",
    "primary.N_L",
    "primary.N_T",
    "shadow.N_B",
    "shadow.N_L",
    "shadow.N_T",
)
#: The passes of the test scene, as the compositor lists them (Combined is "Image" and "Alpha").
PASSES = tuple(f"shadow.{light}" for light in LIGHTS) + HEAT
SPP = 2


def engine_env(tmp: Path, addon_zips) -> dict[str, str]:
    """Debian's Blender with the legacy add-on where ``--addons antumbra`` finds it, and the
    daemon's default socket in a private runtime folder."""
    scripts = tmp / "scripts" / "addons"
    if not (scripts / "antumbra").is_dir():
        with zipfile.ZipFile(addon_zips["legacy"]) as z:
            z.extractall(scripts)
    xdg = tmp / "xdg"
    xdg.mkdir(mode=0o700, exist_ok=True)
    return blender_env(
        tmp / "home",
        BLENDER_USER_SCRIPTS=str(tmp / "scripts"),
        XDG_RUNTIME_DIR=str(xdg),
    )


def output_expr(out: Path, **method) -> str:
    """``--python-expr``: 32-bit multilayer EXR into OUT, the method settings given."""
    lines = [
        "import bpy",
        "s = bpy.context.scene",
        "s.render.image_settings.file_format = 'OPEN_EXR_MULTILAYER'",
        "s.render.image_settings.color_depth = '32'",
        f"s.render.filepath = {str(out / 'frame_####')!r}",
        *(f"s.antumbra.method.{k} = {v!r}" for k, v in {"spp": SPP, **method}.items()),
    ]
    return "; ".join(lines)


def blender_engine(blend: Path, tmp: Path, env, expr: str, *args: str):
    return run_blender(
        [
            "--addons",
            "antumbra",
            str(blend),
            "--python-expr",
            expr,
            "-E",
            "ANTUMBRA",
            *args,
        ],
        tmp / "home",
        env=env,
    )


@contextmanager
def recording_daemon(antumbra_bin: Path, socket: Path, record: Path):
    """A daemon at ``socket`` recording every session into ``record``."""
    socket.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    record.mkdir(parents=True, exist_ok=True)
    client = antumbra.Client.spawn(antumbra_bin, socket_path=socket, args=["--record", str(record)])
    try:
        yield client
    finally:
        client.close()


def sessions_with_frames(record: Path) -> list[tuple[Path, list[int]]]:
    out = []
    for path in sorted(record.glob("*.antrec")):
        frames = [f["frame"] for f in antumbra.read_recording(path)["frames"]]
        if frames:
            out.append((path, frames))
    return out


def assert_planes_equal(blender_exr: Path, cli_exr: Path, layer: str = "ViewLayer"):
    """Every pass of Blender's EXR equals the command line's plane of the same name."""
    ours, cli = antumbra.read_exr(blender_exr), antumbra.read_exr(cli_exr)
    for plane in PASSES:
        assert ours[f"{layer}.{plane}.X"].tobytes() == cli[plane].tobytes(), (
            blender_exr,
            plane,
        )
    assert ours[f"{layer}.Combined.R"].tobytes() == cli["combined"].tobytes(), blender_exr
    assert (ours[f"{layer}.Combined.A"] == 1.0).all()
    for light in LIGHTS:
        mask = ours[f"{layer}.shadow.{light}.X"]
        assert 0.0 < mask.mean() < 1.0, f"{light}: the frame should be partly shadowed"


def test_dash_f_writes_the_passes_of_antumbra_render(
    addon_zips, scene_blend, antumbra_bin, short_tmp
):
    env = engine_env(short_tmp, addon_zips)
    out, record = short_tmp / "out", short_tmp / "record"
    with recording_daemon(
        antumbra_bin, Path(env["XDG_RUNTIME_DIR"]) / "antumbra" / "daemon.sock", record
    ):
        done = blender_engine(scene_blend, short_tmp, env, output_expr(out), "-f", "3")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "antumbra: frame 3 " in done.stdout, done.stdout
    [(sent, frames)] = sessions_with_frames(record)
    assert frames == [3]
    assert_planes_equal(
        out / "frame_0003.exr",
        cli_render(antumbra_bin, sent, 3, short_tmp / "cli", SPP),
    )
    with open(out / "frames.csv") as f:
        assert [int(r["frame"]) for r in csv.DictReader(f)] == [3]
    with open(out / "stats.csv") as f:
        assert len(list(csv.DictReader(f))) == 1 + len(LIGHTS)


def test_dash_a_renders_six_frames_in_one_session(addon_zips, scene_blend, antumbra_bin, short_tmp):
    """OSAH from the previous frame's visible set: the six frames' work per pixel equals a
    sequential ``antumbra render`` of them only because the engine keeps one daemon session
    for the whole job (frame 4 rendered alone takes other work)."""
    env = engine_env(short_tmp, addon_zips)
    out, record = short_tmp / "out", short_tmp / "record"
    expr = output_expr(out, build="osah")
    with recording_daemon(
        antumbra_bin, Path(env["XDG_RUNTIME_DIR"]) / "antumbra" / "daemon.sock", record
    ):
        done = blender_engine(scene_blend, short_tmp, env, expr, "-s", "1", "-e", "6", "-a")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert sorted(p.name for p in out.glob("*.exr")) == [f"frame_{f:04d}.exr" for f in range(1, 7)]
    [(sent, frames)] = sessions_with_frames(record)
    assert frames == [1, 2, 3, 4, 5, 6]

    cli = short_tmp / "cli"
    subprocess.run(
        [
            *(str(antumbra_bin), "render", "--scene", str(sent), "--frames", "1-6"),
            *("--spp", str(SPP), "--build", "osah", "--out", str(cli)),
        ],
        check=True,
        capture_output=True,
    )
    for f in range(1, 7):
        assert_planes_equal(out / f"frame_{f:04d}.exr", cli / f"frame_{f:04d}.exr")
    subprocess.run(
        [
            *(str(antumbra_bin), "render", "--scene", str(sent), "--frames", "4"),
            *("--spp", str(SPP), "--build", "osah", "--out", str(short_tmp / "alone")),
        ],
        check=True,
        capture_output=True,
    )
    assert (
        antumbra.read_exr(short_tmp / "alone" / "frame_0004.exr")["shadow.N_B"].tobytes()
        != antumbra.read_exr(out / "frame_0004.exr")["ViewLayer.shadow.N_B.X"].tobytes()
    )

    # The statistics beside the output, as the batch writes them.
    with open(out / "frames.csv") as f:
        assert [int(r["frame"]) for r in csv.DictReader(f)] == list(range(1, 7))
    rows = json.loads((out / "stats.json").read_text())
    assert [r["frame"] for r in rows] == [f for f in range(1, 7) for _ in range(1 + len(LIGHTS))]
    antumbra.write_stats_csv(short_tmp / "rust.csv", rows)
    assert (out / "stats.csv").read_bytes() == (short_tmp / "rust.csv").read_bytes()
    columns = (
        "frame",
        "pass",
        "light",
        "rays",
        "nb_per_ray",
        "nl_per_ray",
        "nt_per_ray",
    )

    def work(path: Path) -> list[tuple[str, ...]]:
        with open(path) as f:
            return [tuple(r[c] for c in columns) for r in csv.DictReader(f)]

    assert work(out / "stats.csv") == work(cli / "stats.csv")


@pytest.mark.parametrize("kind", ["legacy", pytest.param("extension", marks=pytest.mark.bpy)])
def test_render_operator_and_compositor(kind, addon_zips, scene_blend, antumbra_bin, short_tmp):
    """Blender's render operator with the engine chosen in the scene (Render Animation), in
    Debian's 3.4 and in the bpy module; the compositor's Render Layers node lists the passes."""
    out, record = short_tmp / "out", short_tmp / "record"
    socket = short_tmp / "d.sock"
    args = [
        *("--zip", str(addon_zips[kind]), "--kind", kind, "--blend", str(scene_blend)),
        *("--frames", "2-3", "--out", str(out), "--binary", str(antumbra_bin)),
        *("--socket", str(socket), "--spp", str(SPP)),
    ]
    with recording_daemon(antumbra_bin, socket, record):
        if kind == "legacy":
            done = run_blender(["-P", str(SCRIPT), "--", *args], short_tmp / "home")
        else:
            home = short_tmp / "home"
            home.mkdir()
            done = subprocess.run(
                [sys.executable, str(SCRIPT), "--", *args],
                env=blender_env(home),
                capture_output=True,
                text=True,
                timeout=300,
            )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads((out / "report.json").read_text())
    assert report["engine"] == "ANTUMBRA" and report["render"] == ["FINISHED"], report
    assert report["outputs"] == ["Image", "Alpha", *PASSES], report
    [(sent, frames)] = sessions_with_frames(record)
    assert frames == [2, 3]
    cli = short_tmp / "cli"
    subprocess.run(
        [
            *(str(antumbra_bin), "render", "--scene", str(sent), "--frames", "2-3"),
            *("--spp", str(SPP), "--out", str(cli)),
        ],
        check=True,
        capture_output=True,
    )
    for f in (2, 3):
        assert_planes_equal(out / f"frame_{f:04d}.exr", cli / f"frame_{f:04d}.exr")


def test_ctrl_c_cancels_the_render_in_flight(addon_zips, scene_blend, antumbra_bin, short_tmp):
    """``blender -b -a`` gets SIGINT (Blender's render break) once the daemon renders frame 2:
    the engine sees it through ``test_break``, cancels the daemon's render, and Blender stops
    the animation; frame 1 alone is written, with its statistics."""
    env = engine_env(short_tmp, addon_zips)
    out, record = short_tmp / "out", short_tmp / "record"
    # Frames big enough that the render is still running when the signal arrives.
    expr = output_expr(out, spp=16) + "; s.render.resolution_percentage = 400"
    command = ["blender", "-b", "--factory-startup", "-noaudio", "--addons", "antumbra"]
    command += [
        str(scene_blend),
        "--python-expr",
        expr,
        "-E",
        "ANTUMBRA",
        "-s",
        "1",
        "-e",
        "6",
    ]
    sock = Path(env["XDG_RUNTIME_DIR"]) / "antumbra" / "daemon.sock"
    with recording_daemon(antumbra_bin, sock, record) as daemon:
        proc = subprocess.Popen(
            [*command, "-a"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        lines, sent = [], False
        for line in proc.stdout:
            lines.append(line)
            if not sent and "antumbra: frame 2: render" in line:
                proc.send_signal(signal.SIGINT)
                sent = True
        proc.wait(timeout=120)
        stats = daemon.stats()
    stdout = "".join(lines)
    assert sent, stdout[-3000:]
    assert "antumbra: frame 2: cancelled" in stdout, stdout[-3000:]
    assert stats["renders_cancelled"] == 1, stats
    assert sorted(p.name for p in out.glob("frame_*")) == [
        "frame_0001.exr",
        "frame_0001.stats.json",
    ]
    with open(out / "frames.csv") as f:
        assert [int(r["frame"]) for r in csv.DictReader(f)] == [1]
    assert os.path.getsize(out / "frame_0001.exr") > 0


def test_f12_in_a_window_renders_through_the_render_thread(
    addon_zips, scene_blend, antumbra_bin, short_tmp
):
    """F12 as a user presses it (Debian's 3.4 under Xvfb): Blender's render job runs the engine
    on its render thread; the Render Result, saved as a multilayer EXR, equals the command
    line's render of what the engine sent."""
    xvfb_run, blender = shutil.which("xvfb-run"), shutil.which("blender")
    if xvfb_run is None or blender is None:
        pytest.fail("needs xvfb-run and Debian's blender (scripts/setup.sh installs both)")
    out, record, socket = short_tmp / "out", short_tmp / "record", short_tmp / "d.sock"
    out.mkdir()
    (short_tmp / "home").mkdir()
    with recording_daemon(antumbra_bin, socket, record):
        done = subprocess.run(
            [
                *(
                    xvfb_run,
                    "-a",
                    "-s",
                    "-screen 0 1280x800x24",
                    blender,
                    "--factory-startup",
                ),
                *("-noaudio", str(scene_blend), "-P", str(F12_SCRIPT), "--"),
                *("--zip", str(addon_zips["legacy"]), "--binary", str(antumbra_bin)),
                *("--socket", str(socket), "--out", str(out)),
            ],
            env=blender_env(short_tmp / "home"),
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] == 1, report
    [(sent, frames)] = sessions_with_frames(record)
    assert frames == [report["frame"]]
    cli = cli_render(antumbra_bin, sent, report["frame"], short_tmp / "cli", SPP)
    assert_planes_equal(out / "f12.exr", cli)


def test_a_bad_scene_is_an_error_naming_object_and_frame(addon_zips, antumbra_bin, short_tmp):
    """A NaN vertex: Blender's render reports the engine's error (frame and object named), the
    job stops and no file is written."""
    script = short_tmp / "nan_scene.py"
    script.write_text(NAN_SCENE)
    blend = short_tmp / "nan.blend"
    made = run_blender(["-P", str(script), "--", str(blend)], short_tmp / "home")
    assert made.returncode == 0 and blend.is_file(), made.stderr
    env = {**engine_env(short_tmp, addon_zips), "ANTUMBRA_BIN": str(antumbra_bin)}
    out = short_tmp / "out"
    done = blender_engine(blend, short_tmp, env, output_expr(out), "-f", "1")
    text = done.stdout + done.stderr
    assert "antumbra: frame 1: object 'Broken' has a non-finite vertex" in text, text[-3000:]
    assert not out.exists() or not list(out.iterdir())


def test_dash_a_after_the_animation_start_warms_up_first(
    addon_zips, scene_blend, antumbra_bin, short_tmp
):
    """``-s 4 -e 6 -a`` of an animation that starts at 1 (``scene.antumbra.animation_start``,
    as a farm's chunk sets it): the engine warms its session up on frames 2 and 3 (trees and
    visible sets: no files, no rows), so frames 4-6 equal those of ``-s 1 -e 6 -a``, heat maps
    and statistics rows (times aside) included; without the warm-up frame 4's work differs."""
    env = {**engine_env(short_tmp, addon_zips), "ANTUMBRA_BIN": str(antumbra_bin)}
    runs = {}
    for name, first, start in (("one", "1", False), ("chunk", "4", True), ("cold", "4", False)):
        out = short_tmp / name
        # A fixed order: a warm-up makes trees and visible sets, not what auto measured.
        expr = output_expr(out, build="osah", width="2", order="fbto")
        expr += f"; s.antumbra.use_animation_start = {start}; s.antumbra.animation_start = 1"
        done = blender_engine(scene_blend, short_tmp, env, expr, "-s", first, "-e", "6", "-a")
        assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
        runs[name] = (out, done.stdout)
    assert "warmed up on (state only): 2, 3" in runs["chunk"][1]
    assert "warmed up on" not in runs["cold"][1]
    (one, _), (chunk, _), (cold, _) = runs["one"], runs["chunk"], runs["cold"]
    assert sorted(p.name for p in chunk.glob("*.exr")) == [f"frame_{f:04d}.exr" for f in (4, 5, 6)]
    for f in (4, 5, 6):
        a, b = (antumbra.read_exr(d / f"frame_{f:04d}.exr") for d in (one, chunk))
        assert sorted(a) == sorted(b)
        assert all(a[k].tobytes() == b[k].tobytes() for k in a), f"frame {f}"

    def rows(out: Path, frames) -> list[dict]:
        with open(out / "stats.csv") as f:
            keep = [r for r in csv.DictReader(f) if int(r["frame"]) in frames]
        return [
            {k: v for k, v in r.items() if not k.endswith("_ms") and k != "mrays_per_s"}
            for r in keep
        ]

    assert rows(chunk, (4, 5, 6)) == rows(one, (4, 5, 6))
    assert rows(cold, (4,)) != rows(one, (4,))


def test_the_engine_and_the_batch_drive_frames_alike(
    addon_zips, scene_blend, antumbra_bin, short_tmp
):
    """One frame driver: ``-E ANTUMBRA -s 3 -e 5 -a`` after an animation start at 1 and
    ``batch.py --frames 3-5 --first-frame 1`` both warm up on frames 1 and 2 and render frames
    3-5 alike: every pass (masks, Combined, the heat maps) and every statistics row, times
    aside."""
    env = {**engine_env(short_tmp, addon_zips), "ANTUMBRA_BIN": str(antumbra_bin)}
    engine_out, batch_out = short_tmp / "engine", short_tmp / "batch"
    expr = output_expr(engine_out, build="osah")
    expr += "; s.antumbra.use_animation_start = True; s.antumbra.animation_start = 1"
    engine = blender_engine(scene_blend, short_tmp, env, expr, "-s", "3", "-e", "5", "-a")
    assert engine.returncode == 0, engine.stdout[-3000:] + engine.stderr[-3000:]
    batched = batch(
        scene_blend,
        batch_out,
        short_tmp / "home",
        *("--frames", "3-5", "--first-frame", "1", "--build", "osah", "--spp", str(SPP)),
        *("--socket", str(short_tmp / "batch.sock")),
        env=env,
    )
    assert batched.returncode == 0, batched.stdout[-3000:] + batched.stderr[-3000:]
    for done in (engine, batched):
        assert "warmed up on (state only): 1, 2" in done.stdout, done.stdout[-3000:]
    for f in (3, 4, 5):
        assert_planes_equal(engine_out / f"frame_{f:04d}.exr", batch_out / f"frame_{f:04d}.exr")

    def rows(out: Path) -> list[dict]:
        # Times differ between runs; ``scene`` is the session's client name (engine or batch).
        skip = ("scene", "mrays_per_s")
        with open(out / "stats.csv") as f:
            return [
                {k: v for k, v in r.items() if not k.endswith("_ms") and k not in skip}
                for r in csv.DictReader(f)
            ]

    assert [r["frame"] for r in rows(engine_out)] == [
        str(f) for f in (3, 4, 5) for _ in range(1 + len(LIGHTS))
    ]
    assert rows(engine_out) == rows(batch_out)


#: Two lights whose names (61 bytes each, Blender's limit is 63) differ only at their end: their
#: passes (``shadow.`` + the name) are longer than Blender keeps.
#: A new empty scene with a ground plane of SIZE, a cube on it and a camera looking down at them.
GROUND_AND_CUBE = """
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.mesh.primitive_plane_add(size=SIZE)
bpy.ops.mesh.primitive_cube_add(location=(0, 0, 1))
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
camera.location = (0.0, -8.0, 6.0)
camera.rotation_euler = (0.9, 0, 0)
scene.collection.objects.link(camera)
scene.camera = camera
"""

LONG_NAMES_SCENE = (
    GROUND_AND_CUBE.replace("SIZE", "10")
    + """
for suffix, x in (("a", -3.0), ("b", 3.0)):
    name = "Lamp" + "x" * 56 + "ä" + suffix
    lamp = bpy.data.objects.new(name, bpy.data.lights.new(name, "POINT"))
    lamp.location = (x, -1.0, 4.0)
    scene.collection.objects.link(lamp)
scene.render.resolution_x, scene.render.resolution_y = 48, 32
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[-1])
"""
)


def test_pass_names_longer_than_blender_keeps_are_shortened_uniquely(
    addon_zips, antumbra_bin, short_tmp
):
    script = short_tmp / "long.py"
    script.write_text(LONG_NAMES_SCENE)
    blend = short_tmp / "long.blend"
    made = run_blender(["-P", str(script), "--", str(blend)], short_tmp / "home")
    assert made.returncode == 0 and blend.is_file(), made.stderr
    env = {**engine_env(short_tmp, addon_zips), "ANTUMBRA_BIN": str(antumbra_bin)}
    out = short_tmp / "out"
    done = blender_engine(blend, short_tmp, env, output_expr(out), "-f", "1")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    channels = antumbra.read_exr(out / "frame_0001.exr")
    masks = sorted(k for k in channels if k.startswith("ViewLayer.shadow.Lamp"))
    assert len(masks) == 2, sorted(channels)
    for k in masks:
        # The whole channel fits Blender's 63 bytes, the name's start kept, a hash after "~".
        name = k.removeprefix("ViewLayer.").removesuffix(".X")
        assert len(k.encode()) <= 63 and "~" in name, k
        assert name.startswith("shadow.Lamp" + "x" * 30)
        # The pass was filled: the light lights some pixels and the cube shadows others.
        assert 0.0 < channels[k].mean() < 1.0, k
    assert channels[masks[0]].tobytes() != channels[masks[1]].tobytes()


#: A new scene as Blender makes it (its default view transform: Filmic in 3.4), a sun lighting a
#: ground plane and a cube, output left a folder (as Blender's default ``/tmp/``) of PNGs.
VALUES_SCENE = (
    GROUND_AND_CUBE.replace("SIZE", "40")
    + """
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.rotation_euler = (0.5, 0.2, 0)
scene.collection.objects.link(sun)
scene.render.resolution_x, scene.render.resolution_y = 48, 32
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "PNG"
scene.render.filepath = sys.argv[-2]
scene.cycles.samples, scene.cycles.use_denoising = 1, False
assert scene.view_settings.view_transform != "Standard", scene.view_settings.view_transform
for path in sys.argv[-1].split(","):
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True)
"""
)
#: Prints the scene's view transform and what antumbra keeps of the user's.
VIEW_PROBE = (
    "import bpy; s = bpy.context.scene; "
    "print('VIEW', s.view_settings.view_transform, repr(s.antumbra.saved_view), flush=True)"
)


def test_values_reach_the_user_as_values_and_statistics_stay_with_their_job(
    addon_zips, antumbra_bin, short_tmp
):
    """A new scene's colour management: antumbra's PNG has 255 where a pixel is lit (Filmic
    would write 207); the user's view comes back with another engine in the same session. With
    Blender's output a bare folder (its default ``/tmp/``), each .blend's statistics go into a
    folder of its own, so a second scene's render does not overwrite the first's tables; the
    status line names a warm-up as one."""
    env = engine_env(short_tmp, addon_zips)
    out, cycles_out = short_tmp / "out", short_tmp / "cycles"
    script = short_tmp / "values.py"
    script.write_text(VALUES_SCENE)
    first, second = short_tmp / "first.blend", short_tmp / "second.blend"
    made = run_blender(
        ["-P", str(script), "--", f"{out}/", f"{first},{second}"], short_tmp / "home"
    )
    assert made.returncode == 0, made.stdout[-3000:] + made.stderr[-3000:]

    done = blender_engine(
        first,
        short_tmp,
        env,
        "import bpy; s = bpy.context.scene; s.antumbra.use_animation_start = True",
        "-f",
        "3",
        "--python-expr",
        VIEW_PROBE,
        "-E",
        "CYCLES",
        "--python-expr",
        f"import bpy; bpy.context.scene.render.filepath = {str(cycles_out) + '/'!r}",
        "-f",
        "1",
        "--python-expr",
        VIEW_PROBE,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    views = re.findall(r"^VIEW (\S+) '(.*)'$", done.stdout, re.M)
    assert [v for v, _ in views] == ["Standard", "Filmic"], views
    assert json.loads(views[0][1])["view_transform"] == "Filmic" and views[1][1] == "", views
    from PIL import Image  # the .venv's (Debian's Blender leg); the bpy legs skip no test here

    png = np.asarray(Image.open(out / "0003.png").convert("RGB"))
    # Lit ground is 255 (Filmic: 207), the cube's shadow 0.
    assert png.max() == 255 and png.min() == 0, (png.min(), png.max())
    # The warm-up (frames 1 and 2 before 3) is named as one on Blender's status line.
    assert "antumbra: warm-up on frame 1 for frame 3: export" in done.stdout
    assert not re.search(r"Fra:3 .*antumbra: frame 1:", done.stdout), done.stdout[-3000:]

    # The statistics: in first.antumbra/, none loose in the shared folder.
    tables = out / "first.antumbra"
    assert sorted(p.name for p in tables.iterdir()) == [
        "frame_0003.stats.json",
        "frames.csv",
        "stats.csv",
        "stats.json",
    ]
    assert not (out / "frames.csv").exists()
    before = {p.name: p.read_bytes() for p in tables.iterdir()}
    again = blender_engine(second, short_tmp, env, "", "-f", "4")
    assert again.returncode == 0, again.stdout[-3000:] + again.stderr[-3000:]
    assert {p.name: p.read_bytes() for p in tables.iterdir()} == before
    with open(out / "second.antumbra" / "frames.csv") as f:
        assert [int(r["frame"]) for r in csv.DictReader(f)] == [4]

"""A real add-on session recorded by the daemon replays: two batches in a row against one
``antumbra serve --record`` (the second finds every mesh already cached and uploads none), each
recording rendered again by ``antumbra render`` to the batch's own files, byte for byte; and
``compare`` and ``bench`` run on them."""

from __future__ import annotations

import csv
import subprocess
from pathlib import Path

from conftest import ADDON, blender_env, run_blender

FRAMES = (1, 2, 3)
#: Columns of compare.csv that depend on the frames and the trees, not on the clock or the name.
UNTIMED = (
    *("label", "frame", "method", "pass", "light", "rebuilt", "bvh_nodes", "triangles", "rays"),
    *("occluded_fraction", "nb_per_ray", "nl_per_ray", "nt_per_ray", "nbox_per_ray"),
    *("back_facing", "unreached", "references", "nts_per_ray"),
)


def recording_daemon(antumbra_bin: Path, socket: Path, record: Path, log: Path):
    """``antumbra serve --record``, returned once it listens."""
    process = subprocess.Popen(
        [str(antumbra_bin), "serve", "--socket", str(socket), "--record", str(record)],
        stdout=subprocess.PIPE,
        stderr=log.open("w"),
        text=True,
        env={"NO_COLOR": "1", "PATH": "/usr/bin:/bin"},
    )
    for line in process.stdout:
        if "listening on" in line:
            return process
    process.wait()
    raise AssertionError(f"the daemon did not start: {log.read_text()[-3000:]}")


def antumbra(antumbra_bin: Path, *args: str) -> subprocess.CompletedProcess:
    done = subprocess.run([str(antumbra_bin), *args], capture_output=True, text=True)
    assert done.returncode == 0, f"antumbra {' '.join(args)}:\n{done.stdout}\n{done.stderr}"
    return done


def untimed_rows(path: Path) -> list[tuple]:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    assert rows, path
    return [tuple(r[c] for c in UNTIMED) for r in rows]


def bench_work(stdout: str, name: str) -> list[tuple]:
    """(frame, threads, the work counters) of each row of ``bench``'s table."""
    rows = [line.split("|") for line in stdout.splitlines() if line.startswith(name)]
    assert rows, stdout
    return [(*r[0].split()[1:4:2], *r[1:]) for r in rows]


def test_two_recorded_batches_replay_to_the_batch_images(scene_blend, antumbra_bin, short_tmp):
    home, record = short_tmp / "home", short_tmp / "rec"
    socket = short_tmp / "d.sock"
    daemon = recording_daemon(antumbra_bin, socket, record, short_tmp / "daemon.log")
    try:
        for run in ("first", "second"):
            args = [str(scene_blend), "-P", str(ADDON / "batch.py"), "--", "--spp", "1"]
            args += ["--out", str(short_tmp / run), "--socket", str(socket)]
            args += ["--frames", f"{FRAMES[0]}-{FRAMES[-1]}"]
            done = run_blender(args, home, env=blender_env(home))
            assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    finally:
        daemon.terminate()
        daemon.wait(timeout=60)
    recordings = sorted(record.glob("session-*.antrec"))
    assert len(recordings) == 2, recordings

    for i, recording in enumerate(recordings):
        replay = short_tmp / f"replay{i}"
        antumbra(
            antumbra_bin, "render", "--scene", str(recording), "--spp", "1", "--out", str(replay)
        )
        for f in FRAMES:
            name = f"frame_{f:04d}.exr"
            exr = (replay / name).read_bytes()
            assert exr == (short_tmp / "first" / name).read_bytes(), (recording, name)
            assert exr == (short_tmp / "second" / name).read_bytes(), (recording, name)
        assert sorted(p.name for p in replay.glob("frame_*.exr")) == [
            f"frame_{f:04d}.exr" for f in FRAMES
        ]

    # compare (two methods, answers checked against each other) and bench read every frame.
    compared, benched = [], []
    for i, recording in enumerate(recordings):
        out = short_tmp / f"compare{i}"
        antumbra(
            antumbra_bin,
            *("compare", "--scene", str(recording), "--repeat", "1", "--out", str(out)),
            *("--method", "base=build=sah,width=2,order=fbto"),
            *("--method", "osah8=build=osah,visibility=previous,width=8,order=sorted"),
        )
        compared.append(untimed_rows(out / "compare.csv"))
        bench = antumbra(
            antumbra_bin,
            *("bench", "--scene", str(recording), "--size", "96x54", "--repeat", "1"),
        )
        benched.append(bench_work(bench.stdout, recording.stem))
    assert compared[0] == compared[1]
    assert {row[1] for row in compared[0]} == {str(f) for f in FRAMES}
    assert benched[0] == benched[1]
    assert {row[0] for row in benched[0]} == {str(f) for f in FRAMES}

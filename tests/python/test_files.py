"""Recordings and frame files: ``read_recording`` gives back what ``antumbra record`` wrote, a
render of its frames through a session equals the CLI's render of the same recording bit for
bit, and ``Result.save`` writes the CLI's bytes."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

import antumbra


@pytest.fixture(scope="module")
def recording(antumbra_bin, tmp_path_factory):
    out = tmp_path_factory.mktemp("rec") / "bedroom.antrec"
    subprocess.run(
        [
            str(antumbra_bin),
            "record",
            "--scene",
            "bedroom",
            "--triangles",
            "8000",
            "--frames",
            "1-2",
            "--size",
            "64x40",
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    return out


def test_read_recording_gives_meshes_and_frames(recording):
    rec = antumbra.read_recording(recording)
    assert [f["frame"] for f in rec["frames"]] == [1, 2]
    names = {m["name"] for m in rec["meshes"].values()}
    assert {"room", "slat", "fan"} <= names
    for h, m in rec["meshes"].items():
        assert m["positions"].dtype == np.float32 and m["positions"].shape[1] == 3
        assert m["triangles"].dtype == np.uint32 and m["triangles"].shape[1] == 3
        assert antumbra.mesh_hash(m["positions"], m["triangles"]) == h
    frame = rec["frames"][0]
    assert frame["resolution"]["x"] == 64 and frame["resolution"]["y"] == 40
    assert {light["type"] for light in frame["lights"]} == {"SUN", "AREA"}
    used = {o["mesh_hash"] for o in frame["objects"]}
    assert used <= set(rec["meshes"])


def test_read_recording_names_a_bad_file(tmp_path):
    bad = tmp_path / "bad.antrec"
    bad.write_bytes(b"not a recording at all")
    with pytest.raises(antumbra.InvalidInput, match=r"bad\.antrec"):
        antumbra.read_recording(bad)


def render_recording(session, rec, frame_index: int) -> antumbra.Result:
    frame = rec["frames"][frame_index]
    missing = session.frame_update(
        frame["frame"], frame["objects"], frame["camera"], frame["lights"], frame["resolution"]
    )
    for h in missing:
        m = rec["meshes"][h]
        session.upload_mesh(m["name"], m["positions"], m["triangles"])
    return session.render(frame["frame"], spp=2)


def test_session_render_and_save_equal_the_cli(antumbra_bin, recording, tmp_path):
    cli_out = tmp_path / "cli"
    subprocess.run(
        [
            str(antumbra_bin),
            "render",
            "--scene",
            str(recording),
            # Frames 1 and 2, as the session renders them: the default method, auto, chooses
            # frame 2's orders from what frame 1 measured.
            "--frames",
            "1-2",
            "--spp",
            "2",
            "--out",
            str(cli_out),
        ],
        check=True,
        capture_output=True,
    )
    rec = antumbra.read_recording(recording)
    with antumbra.LocalSession() as session:
        render_recording(session, rec, 0)
        result = render_recording(session, rec, 1)
    cli = antumbra.read_exr(cli_out / "frame_0002.exr")
    assert sorted(cli) == sorted(result.images)
    for name, array in result.planes:
        assert array.tobytes() == cli[name].tobytes(), name
    ours = tmp_path / "ours"
    files = result.save(ours)
    assert "frame_0002.exr" in files and "frame_0002_combined.png" in files
    for name in files:
        assert (ours / name).read_bytes() == (cli_out / name).read_bytes(), name


def test_save_refuses_planes_of_the_wrong_shape(tmp_path):
    with pytest.raises(antumbra.InvalidInput, match="plane 'combined'"):
        antumbra._native.save_frame(
            str(tmp_path), 1, 4, 3, [("combined", np.zeros((2, 2), np.float32))]
        )


def test_stats_files_of_the_client_are_the_clis(antumbra_bin, recording, tmp_path):
    """One writer of stats.csv/stats.json: the client writes the CLI's bytes for the CLI's rows,
    and a session's rows give the same file directly or read back from JSON (as the add-on
    keeps them)."""
    cli_out = tmp_path / "cli"
    subprocess.run(
        [
            str(antumbra_bin),
            "render",
            "--scene",
            str(recording),
            "--frames",
            "1-2",
            "--spp",
            "1",
            "--out",
            str(cli_out),
        ],
        check=True,
        capture_output=True,
    )
    rows = json.loads((cli_out / "stats.json").read_text())
    antumbra.write_stats_csv(tmp_path / "stats.csv", rows)
    antumbra.write_stats_json(tmp_path / "stats.json", rows)
    for name in ("stats.csv", "stats.json"):
        assert (tmp_path / name).read_bytes() == (cli_out / name).read_bytes(), name
    rec = antumbra.read_recording(recording)
    with antumbra.LocalSession() as session:
        result = render_recording(session, rec, 0)
    antumbra.write_stats_csv(tmp_path / "direct.csv", result.stats)
    antumbra.write_stats_csv(tmp_path / "via_json.csv", json.loads(json.dumps(result.stats)))
    direct = (tmp_path / "direct.csv").read_bytes()
    assert direct == (tmp_path / "via_json.csv").read_bytes()
    assert direct.splitlines()[0] == (cli_out / "stats.csv").read_bytes().splitlines()[0]
    with pytest.raises(antumbra.InvalidInput, match=r"rows\[0\]"):
        antumbra.write_stats_csv(tmp_path / "bad.csv", [{"rays": "many"}])


def test_write_file_atomic_leaves_only_the_file(tmp_path):
    target = tmp_path / "sub" / "a.json"
    antumbra.write_file_atomic(target, b"first")
    antumbra.write_file_atomic(target, b"second")
    assert target.read_bytes() == b"second"
    assert [p.name for p in target.parent.iterdir()] == ["a.json"]

"""``trade_frame``, ``trade`` and ``TradeReport`` on a built-in scene (a recording of the
bedroom), through a real daemon and in process: the folder equals the one ``antumbra trade``
writes for the same frames (every counter and error, row for row), frames recorded and
resumed, progress per pass, a cancelled frame leaves every knob as before it, and bad knobs
are refused naming the knob and the value."""

from __future__ import annotations

import csv
import subprocess
from pathlib import Path

import pytest

import antumbra

SIZE = (40, 30)
# A work knob, an image knob (spp) and the resolution scale, as `antumbra trade --knob` takes them.
KNOBS = ["min_leaf_size=1,4", "spp=1,4,16", "resolution=50"]
ARGS = ["--scene", "bedroom", "--triangles", "3000", "--size", f"{SIZE[0]}x{SIZE[1]}"]
# Columns that are times (they differ between runs).
TIMES = {"build_ms", "prepare_ms", "trace_ms", "frame_ms", "frame_ms_min", "frame_ms_max"}


@pytest.fixture(scope="module")
def recording(antumbra_bin, tmp_path_factory) -> dict:
    out = tmp_path_factory.mktemp("rec") / "bedroom.antrec"
    subprocess.run(
        [str(antumbra_bin), "record", *ARGS, "--frames", "1-3", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    return antumbra.read_recording(out)


@pytest.fixture(scope="module")
def cli_folder(antumbra_bin, tmp_path_factory) -> Path:
    """``antumbra trade`` of the recording's frames (1-3: the animation spans the range given)
    with KNOBS."""
    out = tmp_path_factory.mktemp("cli")
    knobs = [a for k in KNOBS for a in ("--knob", k)]
    command = [str(antumbra_bin), "trade", *ARGS, "--frames", "1-3", *knobs]
    run = subprocess.run(
        [*command, "--repeat", "1", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr
    return out


@pytest.fixture(params=["local", "daemon"])
def session(request, antumbra_bin, short_tmp):
    if request.param == "local":
        s = antumbra.LocalSession()
    else:
        s = antumbra.Client.spawn(antumbra_bin, socket_path=short_tmp / "d.sock", timeout=60)
    yield s
    s.close()


def send(session, rec: dict, index: int) -> int:
    """Sends frame ``index`` of the recording with the meshes the session lacks."""
    frame = rec["frames"][index]
    for h in session.frame_update(**frame):
        m = rec["meshes"][h]
        session.upload_mesh(m["name"], m["positions"], m["triangles"])
    return frame["frame"]


def without_times(rows: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in TIMES} for r in rows]


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def steps(repeat: int) -> int:
    """Passes of one frame of KNOBS: the reference, then one counted and ``repeat`` timed
    per value (min_leaf_size 2 values, spp 3, resolution 2 with its default added)."""
    return 1 + (2 + 3 + 2) * (1 + repeat)


def test_the_folder_equals_the_cli_s(session, recording, cli_folder, tmp_path):
    report = antumbra.TradeReport(tmp_path, scene="bedroom", knobs=KNOBS, repeat=1)
    for index in (0, 1, 2):
        frame = send(session, recording, index)
        tf = session.trade_frame(frame, KNOBS, repeat=1)
        assert tf.frame == frame and tf.knobs == KNOBS and tf.mismatches == []
        assert list(tf.rows[0]) == list(antumbra.TRADE_COLUMNS)
        assert {r["knob"] for r in tf.rows} == {"min_leaf_size", "spp", "resolution"}
        report.add(tf)
    md = report.write()
    assert md == str(tmp_path / "trade.md")
    # Knob after knob, each in frame order, every counter and error as the CLI's.
    mine, cli = read_csv(tmp_path / "trade.csv"), read_csv(cli_folder / "trade.csv")
    assert len(mine) == len(cli) == 3 * 7 * 3
    assert without_times(mine) == without_times(cli)
    for knob in ("min_leaf_size", "spp", "resolution"):
        for ext in ("svg", "png"):
            assert (tmp_path / "plots" / f"{knob}.{ext}").stat().st_size > 0
    text = Path(md).read_text()
    assert text.startswith("# Trade: bedroom") and "Frames 1-3, 40x30" in text
    recs = report.recommendations()
    assert [r["knob"] for r in recs] == ["min_leaf_size", "spp", "resolution"]
    assert {r["default"] for r in recs} == {"1", "4", "100"}


def test_resumed_and_refused_for_another_trade(recording, tmp_path):
    with antumbra.LocalSession() as s:
        report = antumbra.TradeReport(tmp_path, scene="bedroom", knobs={"spp": [1, 4]}, repeat=1)
        report.add(s.trade_frame(send(s, recording, 0), {"spp": [1, 4]}, repeat=1))
    again = antumbra.TradeReport(tmp_path, scene="bedroom", knobs=["spp=1,4"], repeat=1)
    assert again.frames() == [1]
    with pytest.raises(antumbra.InvalidInput, match="knobs: recorded spp=1,4, now spp=1,16"):
        antumbra.TradeReport(tmp_path, scene="bedroom", knobs=["spp=1,16"], repeat=1)
    with pytest.raises(antumbra.InvalidInput, match="repeat: recorded 1, now 2"):
        antumbra.TradeReport(tmp_path, scene="bedroom", knobs=["spp=1,4"], repeat=2)


def test_trade_sends_every_frame_and_writes_the_folder(recording, tmp_path):
    seen = []
    with antumbra.LocalSession() as s:
        for m in recording["meshes"].values():
            s.upload_mesh(m["name"], m["positions"], m["triangles"])
        report = s.trade(
            recording["frames"][:2],
            ["width=2,8"],
            out=tmp_path,
            scene="bedroom",
            repeat=1,
            progress=lambda *p: seen.append(p),
        )
    assert report.frames() == [1, 2] and report.mismatches == []
    rows = read_csv(tmp_path / "trade.csv")
    assert {(r["value"], r["frame"], r["answers"]) for r in rows} == {
        (w, f, "equal") for w in ("2", "8") for f in ("1", "2")
    }
    # No image knob, so no reference: one counted and one timed pass per value.
    assert seen[:5] == [("trade", i, 4) for i in range(5)]


def test_progress_and_a_cancelled_frame_leaves_every_knob_as_before(session, recording):
    first = send(session, recording, 0)
    seen = []
    one = session.trade_frame(first, KNOBS, repeat=1, progress=lambda *p: seen.append(p))
    assert [p for p in seen if p[0] != "queued"] == [
        ("trade", i, steps(1)) for i in range(steps(1) + 1)
    ]
    second = send(session, recording, 1)
    # Cancelled after the reference and a knob pass: every knob's state goes back. (At the
    # first report past them: the daemon's progress is polled, so a later threshold may only
    # be reported once the last of the frame's 15 quick passes is done, too late to cancel.)
    with pytest.raises(antumbra.RequestError) as e:
        session.trade_frame(second, KNOBS, repeat=1, progress=lambda *p: p[1] < 2)
    assert e.value.code == "Cancelled" and e.value.session_usable
    assert "Trade frame 2" in str(e.value)
    third = send(session, recording, 2)
    three = session.trade_frame(third, KNOBS, repeat=1)
    with antumbra.LocalSession() as alone:
        want = [alone.trade_frame(send(alone, recording, i), KNOBS, repeat=1) for i in (0, 2)]
    assert without_times(one.rows + three.rows) == without_times(want[0].rows + want[1].rows)


@pytest.mark.parametrize(
    "knobs, named",
    [
        (["osah_x"], "'osah_x' is not a knob (knobs: spp, resolution"),
        (["osah_w=2"], "knob 'osah_w': value '2': osah_w: expected a number"),
        (["resolution=0"], "resolution is a percentage in 1..=100, got '0'"),
        (["spp", "spp=1"], "'spp' is given twice"),
        ({"spp": "1,2"}, "knobs['spp']: expected a list of values"),
        ("spp", "got one string"),
    ],
)
def test_bad_knobs_are_refused_naming_them(recording, knobs, named):
    with antumbra.LocalSession() as s:
        frame = send(s, recording, 0)
        with pytest.raises(antumbra.InvalidInput) as e:
            s.trade_frame(frame, knobs, repeat=1)
        assert named in str(e.value)
        assert s.stats()["renders_done"] == 0


def test_knobs_are_the_core_s_table():
    names = [k["name"] for k in antumbra.KNOBS]
    assert names[:5] == ["spp", "resolution", "transparent_bounces", "alpha", "sort_budget"]
    assert len(set(names)) == len(names)
    for k in antumbra.KNOBS:
        assert k["kind"] in ("image", "work") and k["trades"] and k["base"], k
        assert all(isinstance(v, str) for v in k["values"]), k
    spp = antumbra.KNOBS[0]
    assert spp["default"] == "4" and spp["sets"] == "spp"


@pytest.mark.parametrize("repeat", [-1, 0, 101, 2**70])
@pytest.mark.parametrize("kind", ["compare", "trade"])
def test_a_repeat_out_of_range_is_refused_naming_repeat(recording, repeat, kind):
    # Issue 33: ``compare_frame(repeat=-1)`` raised a bare OverflowError.
    with antumbra.LocalSession() as s:
        frame = send(s, recording, 0)
        with pytest.raises(antumbra.InvalidInput) as e:
            if kind == "compare":
                s.compare_frame(frame, ["base=width=2"], repeat=repeat)
            else:
                s.trade_frame(frame, ["spp=1"], repeat=repeat)
        assert isinstance(e.value, ValueError)
        message = str(e.value)
        assert message.startswith(f"repeat: {repeat} is out of range"), message
        assert "1 to 100" in message, message
        assert s.stats()["renders_done"] == 0


@pytest.mark.parametrize("repeat", [-1, 0, 10**30])
@pytest.mark.parametrize("kind", ["compare", "trade"])
def test_a_report_folders_repeat_out_of_range_is_refused_naming_repeat(tmp_path, repeat, kind):
    # The report folders took ``repeat`` unsigned: -1 was a bare OverflowError.
    with pytest.raises(antumbra.InvalidInput) as e:
        if kind == "compare":
            antumbra.CompareReport(
                tmp_path / "cmp", scene="s", methods=["base=width=2"], repeat=repeat
            )
        else:
            antumbra.TradeReport(tmp_path / "trade", scene="s", knobs=["spp=1"], repeat=repeat)
    message = str(e.value)
    assert message.startswith(f"repeat: {repeat} is out of range"), message
    assert not (tmp_path / "cmp").exists() and not (tmp_path / "trade").exists()


@pytest.mark.parametrize("kind", ["compare", "trade"])
def test_the_in_process_session_admits_as_the_daemon_does(recording, kind):
    # LocalSession measured without the daemon's admission: 8192 x 8192 with five methods
    # would have grown to gigabytes before failing.
    frame = dict(recording["frames"][0], resolution={"x": 8192, "y": 8192, "percentage": 100})
    with antumbra.LocalSession() as s:
        for h in s.frame_update(**frame):
            m = recording["meshes"][h]
            s.upload_mesh(m["name"], m["positions"], m["triangles"])
        with pytest.raises(antumbra.AntumbraError) as e:
            if kind == "compare":
                s.compare_frame(frame["frame"])
            else:
                s.trade_frame(frame["frame"], ["spp=1"])
        message = str(e.value)
        verb = "comparing" if kind == "compare" else "trading"
        assert f"frame {frame['frame']}: {verb} " in message, message
        assert "max_render_bytes" in message, message
        assert s.stats()["renders_done"] == 0

"""A trade of speed against accuracy over frames (``docs/trade.md``): a :class:`CompareJob`
whose request is ``trade_frame`` over the chosen knobs (each knob's values compared on a session
of the job's own, warmed up on the frame before a resumed range as a comparison is), each frame
recorded in the trade folder, which is written after every frame."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from .compare_job import CompareJob
from .jobs import FrameDone

#: The trade folder's name under the output folder (panel and batch).
TRADE_DIR = "trade"


def trade_dir(out_dir: Path) -> Path:
    return out_dir / TRADE_DIR


def frame_lines(rows: list[dict]) -> list[str]:
    """One line per knob: each value's frame time (ms, the default marked with *), and its
    RMSE against the reference for image knobs."""
    values: dict[str, dict[str, str]] = {}
    for r in rows:
        if r["pass"] != "primary":
            continue
        mark = "*" if r["default"] else ""
        values.setdefault(r["knob"], {})[r["value"]] = f"{r['value']}{mark} {r['frame_ms']:.1f}"
    errors: dict[tuple[str, str], list[float]] = {}
    for r in rows:
        if r["rmse"] is not None:
            errors.setdefault((r["knob"], r["value"]), []).append(r["rmse"])
    lines = []
    for knob, by_value in values.items():
        parts = []
        for value, text in by_value.items():
            e = errors.get((knob, value))
            parts.append(text + (f" rmse {sum(e) / len(e):.4f}" if e else ""))
        lines.append(f"{knob}: " + ", ".join(parts) + " ms")
    return lines


@dataclass
class TradeJob(CompareJob):
    #: Each knob as ``NAME`` or ``NAME=V1,V2,...`` (none: every knob).
    knobs: list[str] = field(default_factory=list)

    def _request(self, session, frame: int):
        return session.trade_frame(
            frame,
            self.knobs,
            repeat=self.repeat,
            progress=self._progress,
            **self.options.settings_kwargs(),
        )

    def _record(self, work):
        traded = work.result
        if self.report is not None:
            self.report.add(traded)
            self.report.write()
        self.rows.extend(traded.rows)
        self.mismatches.extend(traded.mismatches)
        done = FrameDone(
            frame=work.frame,
            result=traded.rows,
            seconds=time.perf_counter() - work.started + work.export.seconds,
            export_seconds=work.export.seconds,
            stats_lines=frame_lines(traded.rows),
            images={},
            files=[],
            objects=len(work.export.objects),
            triangles=work.export.triangles,
        )
        self.done.append(done)
        if self.on_frame is not None:
            self.on_frame(self, done)

"""A trade of speed against accuracy over frames (``docs/trade.md``): a :class:`CompareJob`
whose request is ``trade_frame`` over the chosen knobs (each knob's values compared on a session
of the job's own, warmed up on the frame before a resumed range as a comparison is), each frame
recorded in the trade folder, which is written after every frame."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .compare import CompareJob

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

    def _images(self, traded) -> dict:
        """A trade's frames bring no images back."""
        return {}

    def _frame_lines(self, traded) -> list[str]:
        return frame_lines(traded.rows)

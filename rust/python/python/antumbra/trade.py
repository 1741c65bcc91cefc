"""Trades of speed against accuracy frame by frame, as ``antumbra trade`` measures them:
:data:`KNOBS` (the knob table), :class:`TradeFrame` (what :meth:`Client.trade_frame` returns)
and :class:`TradeReport`, the folder ``antumbra trade`` writes (the same Rust writer:
``trade.csv``, ``plots/KNOB.svg``/``.png``, ``trade.md``), recorded one frame at a time and
resumable."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from . import _native
from .errors import InvalidInput

__all__ = ["KNOBS", "TRADE_COLUMNS", "Knobs", "TradeFrame", "TradeReport", "knob_texts"]

#: Every knob of ``antumbra trade``, in order (antumbra-core's ``KNOBS``): dicts ``name``,
#: ``kind`` ('image' or 'work'), ``trades``, ``base`` (the method it varies from), ``sets``,
#: ``values`` (swept when none are given) and ``default``.
KNOBS: tuple[dict[str, Any], ...] = tuple(_native.knobs())

#: The columns of a trade's rows, in order: those of ``trade.csv``.
TRADE_COLUMNS: tuple[str, ...] = tuple(_native.trade_columns())

#: Knobs as ``trade_frame`` takes them: None (every knob), ``NAME`` or ``NAME=V1,V2,...``
#: strings, or a dict {name: None | [values]}.
Knobs = Mapping[str, "Iterable[Any] | None"] | Iterable[str] | None


def knob_texts(knobs: Knobs) -> list[str]:
    """``knobs`` as ``NAME`` or ``NAME=V1,V2,...`` strings (None: [], every knob)."""
    if knobs is None:
        return []
    if isinstance(knobs, str):
        raise InvalidInput(
            "knobs: expected a list of 'NAME' or 'NAME=V1,V2,...' strings or a dict "
            "{name: values}, got one string"
        )
    if isinstance(knobs, Mapping):
        texts = []
        for name, values in knobs.items():
            if isinstance(values, str):
                raise InvalidInput(f"knobs[{name!r}]: expected a list of values, got one string")
            texts.append(name if values is None else f"{name}=" + ",".join(map(_value, values)))
        return texts
    return list(knobs)


def _value(v: Any) -> str:
    """A knob value as ``--knob`` spells it (``true``, not ``True``)."""
    return str(v).lower() if isinstance(v, bool) else str(v)


@dataclass(frozen=True, eq=False)
class TradeFrame:
    """One frame swept over every knob of a trade.

    Attributes:
        frame: the frame number.
        knobs: each knob as ``NAME`` or ``NAME=V1,V2,...``, in order.
        rows: one dict per knob x value x pass x light with the columns of ``trade.csv``
            (:data:`TRADE_COLUMNS`; None where the CSV cell is empty).
        mismatches: dicts ``knob``, ``frame``, ``label``, ``what``, ``pixels``, ``message``:
            the work knobs' values whose masks or primary ids differ from the default value's.
    """

    frame: int
    knobs: list[str]
    rows: list[dict[str, Any]]
    mismatches: list[dict[str, Any]]
    # The frame as the trade folder records it (TradeReport.add).
    _record: Any = field(default=None, repr=False)

    @classmethod
    def _from_native(cls, raw: dict[str, Any]) -> TradeFrame:
        return cls(
            frame=raw["frame"],
            knobs=list(raw["knobs"]),
            rows=list(raw["rows"]),
            mismatches=list(raw["mismatches"]),
            _record=raw["record"],
        )

    def __repr__(self) -> str:
        names = ", ".join(k.split("=", 1)[0] for k in self.knobs) or "every knob"
        return (
            f"<antumbra.TradeFrame frame={self.frame} knobs=[{names}] rows={len(self.rows)} "
            f"mismatches={len(self.mismatches)}>"
        )


class TradeReport:
    """The folder of a trade, as ``antumbra trade`` writes it (``trade.csv``, ``plots/``,
    ``trade.md``), recorded frame by frame in ``frames/`` so that a batch stopped half-way
    resumes.

    Args:
        out_dir: the folder (made if missing).
        scene: the scene's name, for trade.md's heading.
        knobs: as given to ``trade_frame`` (None: every knob).
        repeat: timed passes per value and frame, as given to ``trade_frame``.

    Raises:
        InvalidInput: an unknown knob, or ``out_dir`` recorded for another scene, other knobs
            or repeat (the message names what differs).
    """

    def __init__(
        self,
        out_dir: str | os.PathLike[str],
        *,
        scene: str,
        knobs: Knobs = None,
        repeat: int = 3,
    ) -> None:
        self._native = _native.TradeReport(os.fspath(out_dir), scene, knob_texts(knobs), repeat)

    @property
    def out_dir(self) -> str:
        return self._native.out_dir

    def frames(self) -> list[int]:
        """The frames recorded in the folder so far, in order."""
        return self._native.frames()

    def add(self, tf: TradeFrame) -> None:
        """Records one frame (replacing an earlier record of it) in ``frames/frame_NNNN.json``,
        atomically. Mismatches are recorded, not raised. A frame of other knobs or repeat, or
        of other shared settings than the frames recorded before, raises :class:`InvalidInput`.
        """
        if not isinstance(tf, TradeFrame) or tf._record is None:
            raise InvalidInput(
                f"add: expected a TradeFrame from trade_frame(), got {type(tf).__name__}"
            )
        self._native.add(tf._record)

    def write(self) -> str:
        """Writes ``trade.csv``, ``plots/`` and ``trade.md`` from every recorded frame, knob
        after knob; returns trade.md's path."""
        return self._native.write()

    def recommendations(self) -> list[dict[str, str]]:
        """trade.md's first table: per knob ``knob``, ``default``, ``recommended``, ``why``."""
        return self._native.recommendations()

    @property
    def mismatches(self) -> list[str]:
        """The message of every recorded mismatch, knob after knob."""
        return self._native.mismatches

    def __repr__(self) -> str:
        return f"<antumbra.TradeReport {self.out_dir} frames={len(self.frames())}>"

"""Comparisons frame by frame: :class:`CompareFrame` (what :meth:`Client.compare_frame`
returns) and :class:`CompareReport`, the report folder ``antumbra compare`` writes (the same
Rust writer), recorded one frame at a time and resumable."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _native
from .errors import InvalidInput

__all__ = ["CompareFrame", "CompareReport"]


@dataclass(frozen=True, eq=False)
class CompareFrame:
    """One frame rendered with every method of a comparison.

    Attributes:
        frame: the frame number.
        methods: each method as ``LABEL=NAME=VALUE,...``, in order.
        baseline: the baseline's label.
        rows: one dict per method x pass x light with the columns of ``compare.csv``
            (:data:`COMPARE_COLUMNS`), as :meth:`Client.compare` returns them.
        mismatches: dicts ``frame``, ``label``, ``what``, ``pixels``, ``message``: the methods
            whose masks or primary ids differ from the baseline's.
        heat: per label, the method's shadow-ray node visits per pixel (N_B summed over lights
            and samples), float32 (height, width), rows top to bottom; {} unless asked for
            with ``images=True``.
        difference: per label but the baseline's, ``heat[label] - heat[baseline]`` (float32,
            the images of the report's ``diff/`` folder).
    """

    frame: int
    methods: list[str]
    baseline: str
    rows: list[dict[str, Any]]
    mismatches: list[dict[str, Any]]
    heat: dict[str, np.ndarray] = field(default_factory=dict)
    difference: dict[str, np.ndarray] = field(default_factory=dict)
    # The frame as the report folder records it (CompareReport.add).
    _record: Any = field(default=None, repr=False)

    @classmethod
    def _from_native(cls, raw: dict[str, Any]) -> CompareFrame:
        return cls(
            frame=raw["frame"],
            methods=list(raw["methods"]),
            baseline=raw["baseline"],
            rows=list(raw["rows"]),
            mismatches=list(raw["mismatches"]),
            heat=dict(raw["heat"]),
            difference=dict(raw["difference"]),
            _record=raw["record"],
        )

    def __repr__(self) -> str:
        labels = ", ".join(m.split("=", 1)[0] for m in self.methods)
        return (
            f"<antumbra.CompareFrame frame={self.frame} methods=[{labels}] "
            f"baseline={self.baseline!r} rows={len(self.rows)} "
            f"mismatches={len(self.mismatches)}>"
        )


class CompareReport:
    """The report folder of a comparison, as ``antumbra compare`` writes it (``compare.csv``,
    ``compare.json``, ``summary.md``, ``plots/``, ``report.html``, ``diff/LABEL/frame_NNNN.png``),
    recorded frame by frame in ``frames/`` so that a batch stopped half-way resumes.

    Args:
        out_dir: the report folder (made if missing).
        scene: the scene's name, for the report's heading.
        methods: each method as ``LABEL=NAME=VALUE,...``, in order (``CompareFrame.methods``).
        baseline: the baseline's label (None: the first method).
        repeat: timed passes per method and frame, as given to ``compare_frame``.

    Raises:
        InvalidInput: a bad method or baseline, or ``out_dir`` recorded for another scene,
            other methods, baseline or repeat (the message names what differs).
    """

    def __init__(
        self,
        out_dir: str | os.PathLike[str],
        *,
        scene: str,
        methods: list[str],
        baseline: str | None = None,
        repeat: int = 3,
    ) -> None:
        self._native = _native.CompareReport(
            os.fspath(out_dir), scene, list(methods), baseline, repeat
        )

    @property
    def out_dir(self) -> str:
        return self._native.out_dir

    def frames(self) -> list[int]:
        """The frames recorded in the folder so far, in order (skip them when resuming)."""
        return self._native.frames()

    def add(self, cf: CompareFrame) -> None:
        """Records one frame (replacing an earlier record of it): its difference images
        (when ``cf`` has heat planes) and ``frames/frame_NNNN.json``, each written atomically.
        Mismatches are recorded, not raised. A frame of other methods, baseline or repeat, or
        of other shared settings than the frames recorded before, raises :class:`InvalidInput`.
        """
        if isinstance(cf, CompareFrame) and cf._record is None:
            raise InvalidInput(
                f"add: frame {cf.frame} is a warm-up (compare_frame(warm_up=True)): it has no "
                "rows to record"
            )
        if not isinstance(cf, CompareFrame):
            raise InvalidInput(
                f"add: expected a CompareFrame from compare_frame(), got {type(cf).__name__}"
            )
        self._native.add(cf._record)

    def write(self) -> str:
        """Writes ``compare.csv``, ``compare.json``, ``summary.md``, ``plots/`` and
        ``report.html`` from every recorded frame, in frame order; returns report.html's
        path."""
        return self._native.write()

    @property
    def mismatches(self) -> list[str]:
        """The message of every recorded mismatch, in frame order."""
        return self._native.mismatches

    def __repr__(self) -> str:
        return f"<antumbra.CompareReport {self.out_dir} frames={len(self.frames())}>"

"""The render settings as the core defines them once: the schema, and checked settings by name."""

from __future__ import annotations

import json
from typing import Any

from . import _native

__all__ = [
    "render_settings",
    "settings_schema",
]


def settings_schema() -> list[dict[str, Any]]:
    """Every render setting, as the core defines them once: one dict per setting with ``name``,
    ``type`` ('bool', 'int', 'float', 'choice' or 'text'), ``default``, ``group`` and
    ``group_title`` (the panel's sections), ``help``, ``expected`` (what it takes, in words)
    and, by type, ``min``/``max`` (``open``: bounds excluded), ``choices`` or ``syntax``.
    :meth:`Client.render` and :func:`render_settings` take these names as keywords."""
    return _native.settings_schema()


def render_settings(**settings: Any) -> dict[str, Any]:
    """Every render setting by name, with the given ones (named as :func:`settings_schema`
    names them) checked as the daemon checks them and the rest at their defaults: the
    ``settings`` of a render request and of a spool job's ``job.json``. A setting left as None
    takes its default; an unknown name or a bad value raises :class:`InvalidInput` naming it."""
    return json.loads(_native.RenderSettings(**settings).json())

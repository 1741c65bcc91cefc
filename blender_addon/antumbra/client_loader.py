"""Finds the ``antumbra`` client package (the Rust wheel) without mistaking this add-on for it.

A legacy add-on is imported as the top-level module ``antumbra``, the client's own name, so the
client cannot simply be imported. It is loaded, in this order, from:

1. ``_vendor/antumbra`` inside the add-on (the legacy zip, or a source checkout after
   ``blender_addon/build.py``), under the module name ``antumbra_client``;
2. an installed package named ``antumbra`` that is not this add-on (the extension's wheel, which
   Blender installs into its site-packages, or a pip install).
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import sys
from pathlib import Path

ALIAS = "antumbra_client"
HERE = Path(__file__).resolve().parent
VENDOR = HERE / "_vendor"


class ClientMissing(ImportError):
    pass


def _load_from(init: Path):
    spec = importlib.util.spec_from_file_location(
        ALIAS, init, submodule_search_locations=[str(init.parent)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[ALIAS] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[ALIAS]
        raise
    return module


def load():
    """The client module; raises :class:`ClientMissing` with what to do when there is none."""
    if ALIAS in sys.modules:
        return sys.modules[ALIAS]
    vendored = VENDOR / "antumbra" / "__init__.py"
    if vendored.exists():
        return _load_from(vendored)
    existing = sys.modules.get("antumbra")
    if existing is not None and hasattr(existing, "LocalSession"):
        sys.modules[ALIAS] = existing
        return existing
    # Search the path without the folder holding this add-on, where `antumbra` is the add-on.
    paths = [p for p in sys.path if Path(p or ".").resolve() != HERE.parent]
    spec = importlib.machinery.PathFinder.find_spec("antumbra", paths)
    if spec is not None and spec.origin and Path(spec.origin).resolve().parent != HERE:
        return _load_from(Path(spec.origin))
    raise ClientMissing(
        "the antumbra client package is missing: install the add-on from the zip that "
        "blender_addon/build.py makes (it bundles the client), or pip-install the antumbra "
        "wheel into Blender's Python"
    )

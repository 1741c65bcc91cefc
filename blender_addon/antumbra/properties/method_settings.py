"""The method settings of the panel and the batch, made from the client's settings schema
(``antumbra.settings_schema()``, defined once in the Rust core): one Blender property and one
batch flag per setting, with its help, range and default, drawn in the schema's groups."""

from __future__ import annotations

import argparse
import functools

import bpy

from .. import client_loader

#: Groups shown folded by default (the settings most users leave alone).
FOLDED = ("osah", "spatial_splits", "wide_bvh")
#: Blender's int properties are 32-bit.
INT_MAX = 2**31 - 1
#: The settings the panel drew last time (a real-window test reads it).
LAST_DRAWN: list[str] = []


@functools.cache
def schema() -> tuple[dict, ...]:
    """The settings schema of the bundled client."""
    return tuple(client_loader.load().settings_schema())


def defaults() -> dict:
    return {s["name"]: s["default"] for s in schema()}


def groups() -> list[tuple[str, str, list[dict]]]:
    """(group, title, settings) in schema order: what the panel draws."""
    out: dict[str, tuple[str, list[dict]]] = {}
    for s in schema():
        out.setdefault(s["group"], (s["group_title"], []))[1].append(s)
    return [(g, title, items) for g, (title, items) in out.items()]


#: Words the panel's labels spell as people write them.
_WORDS = {"spp": "Samples per pixel", "osah": "OSAH", "min": "smallest", "refs": "references"}


def _label(name: str) -> str:
    words = [_WORDS.get(w, w) for w in name.split("_")]
    text = " ".join(words)
    return text[0].upper() + text[1:]


def _property(s: dict):
    """The Blender property of one setting."""
    common = {"name": _label(s["name"]), "description": s["help"]}
    kind = s["type"]
    if kind == "bool":
        return bpy.props.BoolProperty(default=s["default"], **common)
    if kind == "int":
        # Blender's int properties are 32-bit; wider ranges (seeds, reference counts) are
        # clamped there and checked in full by the client.
        lo, hi = max(s["min"], -INT_MAX - 1), min(s["max"], INT_MAX)
        return bpy.props.IntProperty(default=min(s["default"], hi), min=lo, max=hi, **common)
    if kind == "float":
        return bpy.props.FloatProperty(
            default=s["default"], min=s["min"], max=s["max"], precision=4, **common
        )
    if kind == "choice":
        items = [(str(c), str(c), "") for c in s["choices"]]
        return bpy.props.EnumProperty(items=items, default=str(s["default"]), **common)
    common["description"] = f"{s['help']} Syntax: {s['syntax']}"
    return bpy.props.StringProperty(default=s["default"], **common)


def property_group() -> type:
    """A PropertyGroup class with one property per setting, and a fold flag per group."""
    annotations = {s["name"]: _property(s) for s in schema()}
    for group, title, _ in groups():
        annotations[f"show_{group}"] = bpy.props.BoolProperty(
            name=title, default=group not in FOLDED
        )
    return type(
        "AntumbraMethodSettings", (bpy.types.PropertyGroup,), {"__annotations__": annotations}
    )


def values(props) -> dict:
    """The settings of a property group, typed as the schema types them."""
    out = {}
    for s in schema():
        v = getattr(props, s["name"])
        if s["type"] == "choice" and isinstance(s["default"], int):
            v = int(v)
        if s["type"] == "int" and v == INT_MAX < s["default"]:
            v = s["default"]  # a default past Blender's int range, kept as the client has it
        out[s["name"]] = v
    return out


def assign(props, settings: dict) -> None:
    """Sets a property group's settings from values as :func:`values` gives them (a farm task
    configuring the engine from batch flags)."""
    kinds = {s["name"]: s["type"] for s in schema()}
    for name, v in settings.items():
        setattr(props, name, str(v) if kinds[name] == "choice" else v)


def check(settings: dict) -> str | None:
    """Why the client refuses these settings, or None."""
    client = client_loader.load()
    try:
        client.render_settings(**settings)
    except client.InvalidInput as e:
        return str(e)
    return None


def draw(layout, props) -> list[str]:
    """Draws every setting in its group (folded groups as a toggle); returns the names drawn."""
    drawn = []
    for group, title, items in groups():
        box = layout.box()
        shown = getattr(props, f"show_{group}")
        box.prop(
            props,
            f"show_{group}",
            text=title,
            icon="TRIA_DOWN" if shown else "TRIA_RIGHT",
            emboss=False,
        )
        col = box.column(align=True)
        for s in items if shown else ():
            col.prop(props, s["name"])
            drawn.append(s["name"])
    problem = check(values(props))
    if problem:
        layout.label(text=problem[:120], icon="ERROR")
    LAST_DRAWN[:] = drawn
    return drawn


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """One batch flag per setting (``--leaf-size 4``), taking what ``antumbra render`` takes
    (rust/cli/src/method_args.rs): a bool's flag alone is true and ``--no-NAME`` false, a choice
    with ``on`` alone is ``on``; a flag left out keeps the default."""
    group = parser.add_argument_group("method settings (antumbra render --help says the same)")
    types = {"bool": _parse_bool, "int": int, "float": float}
    for s in schema():
        kind, flag, dest = s["type"], "--" + s["name"].replace("_", "-"), f"setting_{s['name']}"
        alone = {"bool": True, "choice": "on"}.get(kind)
        if alone not in (s.get("choices") or [True]):
            alone = None
        owner = group.add_mutually_exclusive_group() if kind == "bool" else group
        owner.add_argument(
            flag,
            dest=dest,
            type=types.get(
                kind, int if kind == "choice" and isinstance(s["default"], int) else str
            ),
            choices=s.get("choices") if kind == "choice" else None,
            default=None,
            nargs=None if alone is None else "?",
            const=alone,
            metavar=None if kind == "choice" else s["type"].upper(),
            help=f"{s['help']} ({s['expected']}; default {s['default']})",
        )
        if kind == "bool":
            owner.add_argument(
                "--no-" + flag[2:],
                dest=dest,
                action="store_const",
                const=False,
                help=f"the same as {flag} false",
            )


def _parse_bool(text: str) -> bool:
    if text.lower() in ("1", "true", "on", "yes"):
        return True
    if text.lower() in ("0", "false", "off", "no"):
        return False
    raise argparse.ArgumentTypeError(f"expected true or false, got '{text}'")


def from_arguments(args: argparse.Namespace) -> dict:
    """The settings given on the batch's command line."""
    return {
        s["name"]: getattr(args, f"setting_{s['name']}")
        for s in schema()
        if getattr(args, f"setting_{s['name']}") is not None
    }

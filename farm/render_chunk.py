"""One task of the farm job (``farm/template.yaml``, docs/farm.md), run inside Blender: render a
chunk of an animation's frames with the antumbra render engine, or merge the chunks' statistics.
The one place that says how a chunk is rendered.

    blender -b scene.blend --python-exit-code 1 -P farm/render_chunk.py -E ANTUMBRA -a
        -P farm/render_chunk.py -- chunk --first S --last E --chunk-start A --chunk-size K
        --out DIR --addon DIR [--binary PATH] [--batch-args "--build osah --spp 4 ..."]
    blender -b scene.blend --python-exit-code 1 -P farm/render_chunk.py -- merge
        --first S --last E --out DIR --addon DIR [--batch-args "..."]

A chunk is Blender's own ``-a`` of frames A..min(A+K-1, E) (what ``-s A -e B`` would set) with
the antumbra engine: the first ``-P`` enables the add-on from ``--addon`` (a release zip, the
folder it unzips to, or a checkout's ``blender_addon/``) and sets up the scene
(frame range, multilayer EXR into DIR/frame_####.exr without overwriting, the method settings of
the batch flags, the animation's start S for the engine's warm-up, a daemon of the task's own),
Blender renders, and the second ``-P`` fails the task unless every frame of the chunk has its
EXR and statistics. The engine warms its session up on the two frames before its first (a
primary pass only), so every frame equals one run's over S..E; run again, Blender renders only
the frames whose EXR DIR lacks. With ``--compare`` in the batch flags a chunk runs
``blender_addon/batch.py --compare`` instead (the engine renders, it does not compare). The merge
rebuilds DIR's frames.csv and stats.csv (or the compare report) from every frame, and fails if
one of S..E is missing.
"""

from __future__ import annotations

import argparse
import atexit
import os
import shlex
import shutil
import sys
import tempfile
import zipfile
from pathlib import Path

import bpy

#: Blender's output of a frame in the output folder (``#`` is the frame number).
OUTPUT = "frame_####"
#: Where the add-on was set out, per ``--addon``, for this Blender's later ``-P`` scripts.
PLACED = "antumbra_render_chunk_addon"


def chunk_frames(first: int, last: int, start: int, size: int) -> tuple[int, int]:
    """The frames of the chunk that starts at ``start``: up to ``size`` of them, cut at
    ``last``."""
    if size < 1:
        raise SystemExit("--chunk-size must be at least 1")
    if not first <= start <= last:
        raise SystemExit(f"--chunk-start {start} is outside the frames {first}-{last}")
    return start, min(start + size - 1, last)


def batch_arguments(args: argparse.Namespace, socket: Path | None) -> list[str]:
    """batch.py's arguments for a merge or a compared chunk."""
    if args.command == "merge":
        frames = f"{args.first}-{args.last}"
    else:
        frames = "-".join(
            map(str, chunk_frames(args.first, args.last, args.chunk_start, args.chunk_size))
        )
    argv = ["--frames", frames, "--first-frame", str(args.first), "--out", args.out]
    if socket is not None:
        argv += ["--socket", str(socket)]
    if args.binary:
        argv += ["--binary", args.binary]
    if args.command == "merge":
        argv.append("--merge")
    return argv + shlex.split(args.batch_args)


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="render_chunk.py", description=__doc__.splitlines()[0])
    parser.add_argument("command", choices=["chunk", "merge"])
    parser.add_argument("--first", type=int, required=True, help="the animation's first frame")
    parser.add_argument("--last", type=int, required=True, help="the animation's last frame")
    parser.add_argument("--chunk-start", type=int, help="chunk: its first frame")
    parser.add_argument("--chunk-size", type=int, help="chunk: frames per chunk")
    parser.add_argument("--out", required=True, help="the output folder (shared by the chunks)")
    parser.add_argument(
        "--addon",
        required=True,
        help="the add-on: a release zip, the folder it unzips to, or a checkout's blender_addon/",
    )
    parser.add_argument("--binary", default="", help="the antumbra executable (daemon)")
    parser.add_argument("--batch-args", default="", help="more batch.py flags: settings, --compare")
    args = parser.parse_args(argv)
    if args.last < args.first:
        parser.error(f"the frames {args.first}-{args.last} are empty")
    if args.command == "chunk" and (args.chunk_start is None or args.chunk_size is None):
        parser.error("chunk needs --chunk-start and --chunk-size")
    return args


def add_on_path(addon: str) -> None:
    """Puts the add-on (the ``antumbra`` package) and its batch driver on the module path,
    once per Blender: a chunk's second ``-P`` finds them where its first set them out."""
    placed = bpy.app.driver_namespace.setdefault(PLACED, {})
    if addon not in placed:
        root = add_on_root(Path(addon)).resolve()
        batch_dir = root if (root / "batch.py").is_file() else root / "antumbra"
        placed[addon] = [str(batch_dir), str(root)]
    for folder in reversed(placed[addon]):
        if folder not in sys.path:
            sys.path.insert(0, folder)


def add_on_root(addon: Path) -> Path:
    """The folder holding the ``antumbra`` package, from what ``--addon`` names: a checkout's
    ``blender_addon/`` (after ``build.py``), either release zip, or the folder it unzips to (the
    folder holding ``antumbra/``, or the add-on's own folder). An extension (its wheel not
    unpacked) or a zip is first set out as the legacy add-on in a folder of the task's own."""
    if addon.is_dir():
        if _is_legacy_package(addon / "antumbra"):
            return addon
        if addon.name == "antumbra" and _is_legacy_package(addon):
            return addon.parent
        if (addon / "__init__.py").is_file() and (addon / "batch.py").is_file():
            return _set_out(addon)
    elif zipfile.is_zipfile(addon):
        unzipped = _task_folder("antumbra-zip-")
        with zipfile.ZipFile(addon) as z:
            z.extractall(unzipped)
        return add_on_root(unzipped)
    raise SystemExit(
        f"--addon {addon}: not the antumbra add-on: give the release zip, the folder it unzips "
        "to, or a checkout's blender_addon/ after blender_addon/build.py"
    )


def _is_legacy_package(folder: Path) -> bool:
    """The add-on with its client unpacked under ``_vendor`` and ``batch.py`` (the legacy zip's
    folder; a checkout's package after build.py has its batch.py beside it)."""
    vendored = folder / "_vendor" / "antumbra" / "__init__.py"
    batch = (folder / "batch.py").is_file() or (folder.parent / "batch.py").is_file()
    return (folder / "__init__.py").is_file() and vendored.is_file() and batch


def _set_out(extension: Path) -> Path:
    """An extension's folder as the legacy add-on: a copy named ``antumbra`` with its bundled
    wheel's client unpacked under ``_vendor`` (as build.py makes the legacy zip)."""
    wheels = sorted((extension / "wheels").glob("antumbra-*.whl"))
    if not wheels:
        raise SystemExit(f"--addon {extension}: no client wheel under wheels/")
    root = _task_folder("antumbra-addon-")
    package = root / "antumbra"
    shutil.copytree(extension, package)
    with zipfile.ZipFile(wheels[-1]) as z:
        z.extractall(package / "_vendor", [m for m in z.namelist() if m.startswith("antumbra/")])
    bundled = package / "bin" / "antumbra"
    if bundled.is_file():  # zip members lose their mode bits
        bundled.chmod(0o755)
    return root


def _task_folder(prefix: str) -> Path:
    """A folder of this task's own, removed when Blender exits."""
    folder = Path(tempfile.mkdtemp(prefix=prefix, dir="/tmp"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def private_socket() -> Path:
    """A socket of the task's own (short: Unix socket paths are limited), so the task starts a
    daemon for itself alone."""
    return _task_folder("antumbra-chunk-") / "d.sock"


def set_up_engine(args: argparse.Namespace) -> None:
    """Before Blender's ``-E ANTUMBRA -a``: the add-on, the daemon, the scene's frames, output
    and method settings."""
    import addon_utils

    addon_utils.enable("antumbra", default_set=True, handle_error=None)
    import batch

    from antumbra import client_loader
    from antumbra.engine import output_format
    from antumbra.properties import method_settings

    knobs = list(client_loader.load().KNOBS)
    flags = batch.parse_args(["--out", args.out, *shlex.split(args.batch_args)], knobs)

    prefs = bpy.context.preferences.addons["antumbra"].preferences
    prefs.binary_path, prefs.socket_path = args.binary, str(private_socket())
    prefs.start_automatically = True
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = chunk_frames(
        args.first, args.last, args.chunk_start, args.chunk_size
    )
    r = scene.render
    r.filepath = str(Path(args.out).resolve() / OUTPUT)
    output_format.set_multilayer_exr(r.image_settings)
    # A frame whose EXR exists is skipped (a task run again renders what is missing); no
    # placeholders, so a task that dies mid-frame leaves no empty file that counts as done.
    r.use_overwrite, r.use_placeholder = False, False
    r.resolution_percentage = max(1, round(r.resolution_percentage * flags.scale))
    settings = scene.antumbra
    method_settings.assign(settings.method, method_settings.from_arguments(flags))
    settings.heat_maps = not flags.no_heat_maps
    settings.use_animation_start, settings.animation_start = True, args.first


def check_chunk(args: argparse.Namespace) -> int:
    """After Blender's ``-a``: every frame of the chunk has its EXR and its statistics."""
    first, last = chunk_frames(args.first, args.last, args.chunk_start, args.chunk_size)
    out = Path(args.out)
    missing = [
        f
        for f in range(first, last + 1)
        if not (out / f"frame_{f:04d}.exr").is_file()
        or not (out / f"frame_{f:04d}.stats.json").is_file()
    ]
    if missing:
        print(
            "render_chunk: error: frame(s) not rendered: " + ", ".join(map(str, missing)),
            file=sys.stderr,
        )
        return 1
    return 0


#: Set by the first ``-P`` of a chunk; the second one then checks what Blender rendered.
STARTED = "antumbra_render_chunk_started"


def run(argv: list[str]) -> int | None:
    """The task's exit status, or None when Blender goes on (to render the chunk)."""
    args = parse_args(argv)
    add_on_path(args.addon)
    compare = "--compare" in shlex.split(args.batch_args)
    if args.command == "chunk" and not compare:
        if bpy.app.driver_namespace.get(STARTED):
            return check_chunk(args)
        set_up_engine(args)
        bpy.app.driver_namespace[STARTED] = True
        scene = bpy.context.scene
        print(
            f"render_chunk: frames {scene.frame_start}-{scene.frame_end} with the antumbra "
            f"engine into {args.out}",
            flush=True,
        )
        return None
    import batch

    socket = None if args.command == "merge" else private_socket()
    batch_argv = batch_arguments(args, socket)
    print("render_chunk: batch.py " + shlex.join(batch_argv), flush=True)
    return batch.exit_status(batch_argv)


def main():
    try:
        code = run(sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else [])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 2
        if not isinstance(e.code, int):
            print(f"render_chunk: error: {e.code}", file=sys.stderr)
    sys.stdout.flush()
    sys.stderr.flush()
    if code is not None:
        # Blender exits 0 after a -P script whatever happened: an explicit exit sets the status.
        os._exit(code)


if __name__ == "__main__":
    main()

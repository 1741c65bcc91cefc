#!/usr/bin/env python3
"""Builds the installable add-on: the Python client wheel goes in with it.

    python3 blender_addon/build.py [--wheel WHEEL] [--binary PATH] [--out DIR]

Writes into DIR (default ``dist/``):

- ``antumbra-extension-VERSION.zip``: a Blender 4.2+ extension (``blender_manifest.toml`` at the
  root, the wheel under ``wheels/``; Blender installs the wheel);
- ``antumbra-addon-VERSION.zip``: a legacy add-on for Blender 3.4 to 4.1 (folder ``antumbra/``
  with the wheel unpacked under ``_vendor/``).

Both ship ``batch.py`` (headless batches) inside the add-on's folder, beside ``__init__.py``.

It also unpacks the wheel into ``blender_addon/antumbra/_vendor`` so the add-on runs from this
checkout (``batch.py``, tests). Without ``--wheel`` it builds one with maturin (release, stripped).
``--binary`` bundles the antumbra executable as ``bin/antumbra`` (the add-on starts it).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ADDON = HERE / "antumbra"
#: Scripts beside the add-on that the zips ship inside its folder.
SCRIPTS = (HERE / "batch.py",)
REPO = HERE.parent
GENERATED = ("_vendor", "wheels", "bin", "__pycache__")


def build_wheel(out: Path) -> Path:
    maturin = REPO / ".venv" / "bin" / "maturin"
    out.mkdir(parents=True, exist_ok=True)
    for old in out.glob("antumbra-*.whl"):
        old.unlink()
    subprocess.run(
        [
            str(maturin if maturin.exists() else "maturin"),
            *("build", "--release", "--strip", "-q"),
            *("-m", str(REPO / "rust/python/Cargo.toml"), "-o", str(out)),
        ],
        check=True,
    )
    return next(out.glob("antumbra-*.whl"))


def addon_sources() -> list[Path]:
    return sorted(
        p
        for p in ADDON.rglob("*")
        if p.is_file()
        and not any(part in GENERATED for part in p.relative_to(ADDON).parts)
        and p.suffix in {".py", ".toml"}
    )


def version() -> str:
    text = (ADDON / "blender_manifest.toml").read_text()
    return re.search(r'^version = "([^"]+)"', text, re.M).group(1)


def unpack_wheel(wheel: Path, into: Path):
    shutil.rmtree(into, ignore_errors=True)
    with zipfile.ZipFile(wheel) as z:
        members = [m for m in z.namelist() if m.startswith("antumbra/")]
        z.extractall(into, members)


def add_file(z: zipfile.ZipFile, source: Path, name: str, executable: bool = False):
    info = zipfile.ZipInfo.from_file(source, name)
    info.compress_type = zipfile.ZIP_DEFLATED
    if executable:
        info.external_attr = (0o100755 & 0xFFFF) << 16
    with open(source, "rb") as f:
        z.writestr(info, f.read())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wheel", type=Path, help="an antumbra wheel (default: build one)")
    parser.add_argument("--binary", type=Path, help="bundle this antumbra executable")
    parser.add_argument("--out", type=Path, default=REPO / "dist")
    args = parser.parse_args(argv)

    wheel = args.wheel or build_wheel(REPO / "target" / "addon-wheel")
    if not wheel.is_file():
        parser.error(f"--wheel: {wheel} does not exist")
    if args.binary and not args.binary.is_file():
        parser.error(f"--binary: {args.binary} does not exist")
    unpack_wheel(wheel, ADDON / "_vendor")
    vendor = sorted(p for p in (ADDON / "_vendor").rglob("*") if p.is_file())
    manifest = re.sub(
        r"^wheels = \[.*\]$",
        f'wheels = ["./wheels/{wheel.name}"]',
        (ADDON / "blender_manifest.toml").read_text(),
        flags=re.M,
    )
    args.out.mkdir(parents=True, exist_ok=True)
    v = version()
    extension = args.out / f"antumbra-extension-{v}.zip"
    legacy = args.out / f"antumbra-addon-{v}.zip"
    with zipfile.ZipFile(extension, "w") as z:
        for p in addon_sources():
            if p.name == "blender_manifest.toml":
                z.writestr("blender_manifest.toml", manifest)
            else:
                add_file(z, p, str(p.relative_to(ADDON)))
        for p in SCRIPTS:
            add_file(z, p, p.name)
        add_file(z, wheel, f"wheels/{wheel.name}")
        if args.binary:
            add_file(z, args.binary, "bin/antumbra", executable=True)
    with zipfile.ZipFile(legacy, "w") as z:
        for p in addon_sources() + vendor:
            add_file(z, p, f"antumbra/{p.relative_to(ADDON)}")
        for p in SCRIPTS:
            add_file(z, p, f"antumbra/{p.name}")
        if args.binary:
            add_file(z, args.binary, "antumbra/bin/antumbra", executable=True)
    print(f"wrote {extension}")
    print(f"wrote {legacy}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env bash
# Sets up and runs the main job on the built-in default: the animated bedroom scene (blinds, a
# sun and a window light) becomes a .blend, and a headless Blender batch renders its shadow
# passes through the add-on and the daemon: per-frame EXR/PNG images, heat maps and statistics
# in out/demo/frames (frames.csv, stats.csv). Arguments go to the batch (e.g. --frames 1-8).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --features embree -p antumbra-cli
.venv/bin/maturin build --release --strip -q -m rust/python/Cargo.toml -o target/wheels
.venv/bin/python blender_addon/build.py --wheel "$(ls -t target/wheels/antumbra-*.whl | head -1)" \
  --binary target/release/antumbra

out=out/demo
mkdir -p "$out"
./target/release/antumbra record --scene bedroom --triangles 100000 --frames 1-24 \
  --size 640x360 --out "$out/bedroom.antrec"
blender -b --factory-startup -noaudio -P blender_addon/make_blend.py -- \
  --recording "$out/bedroom.antrec" --out "$PWD/$out/bedroom.blend"
blender -b "$out/bedroom.blend" --factory-startup -noaudio -P blender_addon/batch.py -- \
  --out "$out/frames" --binary target/release/antumbra "$@"

#!/usr/bin/env bash
# Renders the demo scene through the add-on's modal operator in a real Blender window (Debian's
# 3.4 under Xvfb) and saves the panel and Image Editor as docs/blender-panel.png.
# Run scripts/demo.sh first (it builds the binary, the add-on and out/demo/bedroom.blend).
set -euo pipefail
cd "$(dirname "$0")/.."
command -v xvfb-run >/dev/null || apt-get install -y -qq --no-install-recommends xvfb xauth
home=$(mktemp -d)
HOME="$home" xvfb-run -a -s "-screen 0 1500x1400x24" blender --factory-startup -noaudio \
  out/demo/bedroom.blend -P blender_addon/screenshot.py -- \
  --zip "$(ls dist/antumbra-addon-*.zip | head -1)" --binary target/release/antumbra \
  --socket "$home/d.sock" --out docs/blender-panel.png
rm -rf "$home"

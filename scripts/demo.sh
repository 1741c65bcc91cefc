#!/usr/bin/env bash
# Sets up and runs the main job on the built-in default: `antumbra demo` renders the default
# animated scene and writes images, heat maps and per-frame statistics into out/demo.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo build --release --features embree -p antumbra-cli
./target/release/antumbra demo "$@"

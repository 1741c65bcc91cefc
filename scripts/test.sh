#!/usr/bin/env bash
# Sets up and runs every test: formatting and lints (Rust and Python), the whole workspace's
# tests with the Embree oracle enabled (core, scenes, protocol, daemon over real sockets, CLI),
# the Python client's tests against the real daemon binary, then the Blender add-on end to end
# in Debian's Blender 3.4 (`blender -b`) and in the bpy 5.0.1 module, with the farm job run by
# openjd (tests/blender/test_farm.py); then the version matrix's
# other legs (docs/blender.md): the client on Python 3.10 and the add-on in the bpy 4.2 LTS,
# 4.5 LTS and 5.3 modules, each script there ending through Python's own exit.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets --all-features -- -D warnings
echo "== cargo test"
mkdir -p target
cargo test --workspace --all-features 2>&1 | tee target/test.log

# A test that hangs fails after ten minutes, named, instead of stalling the run (pytest-timeout;
# the slowest test takes under a minute).
export PYTEST_TIMEOUT=600

echo "== python client: build, lint, test"
rm -rf target/wheels
.venv/bin/maturin build --release --strip -q -m rust/python/Cargo.toml -o target/wheels
.venv/bin/pip install -q --disable-pip-version-check --no-deps --force-reinstall target/wheels/antumbra-*.whl
.venv/bin/ruff format --check --config rust/python/pyproject.toml rust/python/python tests/python scripts
.venv/bin/ruff check --config rust/python/pyproject.toml rust/python/python tests/python scripts
.venv/bin/ruff format --check --config blender_addon/ruff.toml blender_addon farm tests/blender
.venv/bin/ruff check --config blender_addon/ruff.toml blender_addon farm tests/blender
# The daemon the Python tests talk to: the debug binary `cargo test` just built.
ANTUMBRA_BIN="$PWD/target/debug/antumbra" .venv/bin/pytest tests/python -q

echo "== blender add-on: build, test in Blender 3.4 and bpy 5.0.1 (and the farm job through openjd)"
.venv/bin/python blender_addon/build.py --wheel target/wheels/antumbra-*.whl
ANTUMBRA_BIN="$PWD/target/debug/antumbra" OPENJD="$PWD/.venv-openjd/bin/openjd" \
  .venv/bin/pytest tests/blender -q

# A leg of the version matrix: its venv gets the wheel and runs pytest ARGS. A venv that setup
# could not make (no such Python on this machine) is reported as not run, never as passed.
matrix_leg() { # TITLE VENV PYTEST_ARGS...
  local title=$1 venv=$2
  shift 2
  echo "== $title"
  if [ ! -x "$venv/bin/python" ]; then
    echo "NOT RUN: $title: no $venv (scripts/setup.sh found no Python for it)"
    return 0
  fi
  "$venv/bin/pip" install -q --disable-pip-version-check --no-deps --force-reinstall target/wheels/antumbra-*.whl
  ANTUMBRA_BIN="$PWD/target/debug/antumbra" "$venv/bin/pytest" -q "$@"
}
# No Blender on 3.10 (the registry has no bpy for it). test_compare_report.py is left out there: it
# drives the command line's report in Chromium through selenium and uses no client code. The ray
# query tests are too: their oracle (embreex) and host (trimesh) are the main leg's, not this one's
# (this leg keeps numpy 1.23); the queries themselves are the same compiled code on both.
matrix_leg "python client on Python 3.10 (numpy 1.23)" .venv-py310 \
  tests/python --ignore tests/python/test_compare_report.py \
  --ignore tests/python/test_rays.py --ignore tests/python/test_rays_trimesh.py
matrix_leg "blender add-on in the bpy 4.2 LTS module (Python 3.11)" .venv-bpy42 tests/blender -m bpy
matrix_leg "blender add-on in the bpy 4.5 LTS module (Python 3.11)" .venv-bpy45 tests/blender -m bpy
matrix_leg "blender add-on in the bpy 5.3 module (Python 3.13, numpy 2)" .venv-bpy53 tests/blender -m bpy

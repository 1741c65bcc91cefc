#!/usr/bin/env bash
# Installs what antumbra needs on a fresh Debian 12 machine: Embree (the oracle and the speed
# reference) and Blender 3.4 from Debian, the X/GL client libraries the bpy module needs even
# headless, Xvfb (a test drives Blender's UI), Chromium and its driver (a test opens the
# comparison report), the Rust toolchain's components, and a Python
# venv (.venv) with the tools that build and test the Python client and the bpy 5.0.1 module
# (and embreex and trimesh, the oracle and the host of antumbra.rays' tests),
# and the version matrix's venvs (docs/blender.md): .venv-bpy42 and .venv-bpy45 (pyenv's Python
# 3.11, the LTS bpy 4.2 and 4.5), .venv-bpy53 (pyenv's Python 3.13, bpy 5.3)
# and .venv-py310 (pyenv's Python 3.10, the client alone), and .venv-openjd (openjd-cli, which
# runs the farm job's tests). Safe to run again.
set -euo pipefail
cd "$(dirname "$0")/.."

need_apt=()
for pkg in libembree-dev blender python3-numpy \
  libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libsm6 libice6 libgl1 libxext6 libxt6 \
  libxcb1 libegl1 libegl-mesa0 libgl1-mesa-dri xvfb xauth chromium chromium-driver; do
  dpkg -s "$pkg" >/dev/null 2>&1 || need_apt+=("$pkg")
done
if [ ${#need_apt[@]} -gt 0 ]; then
  echo "setup: installing ${need_apt[*]}"
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need_apt[@]}" >/dev/null
fi
if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo not found: install Rust (rustup) first" >&2
  exit 1
fi
rustup component add rustfmt clippy >/dev/null 2>&1 || true

if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  python3 -m venv .venv
fi
.venv/bin/pip install -q --disable-pip-version-check \
  "maturin==1.16.0" "numpy==1.26.4" "pytest==9.2.0" "pytest-timeout==2.4.0" "ruff==0.17.5" "bpy==5.0.1" "selenium==4.38.0" \
  "pillow==11.3.0" "embreex==4.4.0.post1" "trimesh==4.12.2"

# The version matrix: each venv needs its Python from pyenv (or PATH); a machine without it gets
# no venv and scripts/test.sh says the leg was not run.
matrix_python() {
  local found
  found=$(ls -d "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"$1".*/bin/python"$1" 2>/dev/null | sort -V | tail -1 || true)
  [ -n "$found" ] || found=$(command -v "python$1" || true)
  echo "$found"
}
matrix_venv() { # DIR PYTHON_VERSION PACKAGES...
  local dir=$1 version=$2 python
  shift 2
  if [ ! -x "$dir/bin/python" ]; then
    python=$(matrix_python "$version")
    if [ -z "$python" ]; then
      echo "setup: no Python $version under pyenv or on PATH: $dir not made, its test leg will not run" >&2
      return 0
    fi
    echo "setup: creating $dir (Python $version)"
    "$python" -m venv "$dir"
  fi
  "$dir/bin/pip" install -q --disable-pip-version-check "$@"
}
matrix_venv .venv-bpy42 3.11 "bpy==4.2.23" "numpy==1.26.4" "pytest==9.2.0" "pytest-timeout==2.4.0"
matrix_venv .venv-bpy45 3.11 "bpy==4.5.15" "numpy==1.26.4" "pytest==9.2.0" "pytest-timeout==2.4.0"
matrix_venv .venv-bpy53 3.13 "bpy==5.3.0" "numpy==2.5.5" "pytest==9.2.0" "pytest-timeout==2.4.0"
matrix_venv .venv-py310 3.10 "numpy==1.23.5" "pytest==9.2.0" "pytest-timeout==2.4.0"

# The farm job's local runner (farm/, docs/farm.md): openjd-cli in a venv of its own, on the
# machine's python3, so its pydantic stays out of the test venvs.
if [ ! -x .venv-openjd/bin/python ]; then
  echo "setup: creating .venv-openjd"
  python3 -m venv .venv-openjd
fi
.venv-openjd/bin/pip install -q --disable-pip-version-check "openjd-cli==0.8.0"

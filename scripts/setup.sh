#!/usr/bin/env bash
# Installs what antumbra needs on a fresh Debian 12 machine: Embree (the oracle and the speed
# reference) from Debian, and the Rust toolchain's components. Safe to run again.
set -euo pipefail

need_apt=()
dpkg -s libembree-dev >/dev/null 2>&1 || need_apt+=(libembree-dev)
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

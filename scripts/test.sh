#!/usr/bin/env bash
# Sets up and runs every test: formatting, lints, and the whole workspace's tests with the
# Embree oracle enabled.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh

echo "== cargo fmt --check"
cargo fmt --all -- --check
echo "== cargo clippy"
cargo clippy --workspace --all-targets --all-features -- -D warnings
echo "== cargo test"
cargo test --workspace --all-features 2>&1 | tee target/test.log

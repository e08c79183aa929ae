#!/usr/bin/env bash
# Runs every test of the project on a fresh machine, installing what it needs first.
# Used as-is by CI (.ci/run). Exit status: 0 only if everything passed.
set -euo pipefail
cd "$(dirname "$0")/.."

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

echo "== toolchain: thumbv7em-none-eabihf target and clippy"
rustup target list --installed | grep -qx thumbv7em-none-eabihf || rustup target add thumbv7em-none-eabihf
rustup component list --installed | grep -q '^clippy' || rustup component add clippy

echo "== the controller crates build for the flight MCU (no_std, no alloc)"
cargo build --release --target thumbv7em-none-eabihf -p vt-tube -p vt-dissipative -p vt-cfo

echo "== clippy, host and MCU, warnings are errors"
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy --target thumbv7em-none-eabihf -p vt-tube -p vt-dissipative -p vt-cfo -- -D warnings

echo "== tests (unit, property, doc, closed-loop acceptance)"
cargo test --workspace --release

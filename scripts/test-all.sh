#!/usr/bin/env bash
# Runs every test of the project on a fresh machine, installing what it needs first.
# Used as-is by CI (.ci/run). Exit status: 0 only if everything passed.
set -euo pipefail
cd "$(dirname "$0")/.."

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

echo "== toolchain: thumbv7em-none-eabihf target and clippy"
rustup target list --installed | grep -qx thumbv7em-none-eabihf || rustup target add thumbv7em-none-eabihf
rustup component list --installed | grep -q '^clippy' || rustup component add clippy

echo "== aarch64 cross toolchain (the Linux companion for a Raspberry Pi, docs/deploy.md)"
rustup target list --installed | grep -qx aarch64-unknown-linux-gnu || rustup target add aarch64-unknown-linux-gnu
if ! command -v aarch64-linux-gnu-gcc >/dev/null 2>&1; then
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gcc-aarch64-linux-gnu libc6-dev-arm64-cross
fi

echo "== QEMU (processor-in-the-loop tests)"
if ! command -v qemu-system-arm >/dev/null 2>&1; then
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-system-arm
fi
qemu-system-arm --version | head -n 1

echo "== Chromium (the browser replay is tested headless, tests/replay_browser.rs)"
if ! command -v chromium >/dev/null 2>&1; then
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium
fi
chromium --version 2>/dev/null | head -n 1

echo "== RotorPy (the plant of host-sim sitl --plant rotorpy, tests/rotorpy.rs): a Python venv in target/"
venv=target/rotorpy-venv
if ! { [ -x "$venv/bin/python" ] && "$venv/bin/python" -c "import rotorpy, pymavlink" 2>/dev/null; }; then
  if ! command -v python3 >/dev/null 2>&1 || ! python3 -c "import venv, ensurepip" 2>/dev/null; then
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3 python3-venv
  fi
  rm -rf "$venv"
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q --disable-pip-version-check -r vt-sim/rotorpy/requirements.txt
fi
"$venv/bin/pip" show rotorpy pymavlink | grep -E '^(Name|Version)' | paste - - 

echo "== the controller crates build for the flight MCU (no_std, no alloc)"
cargo build --release --target thumbv7em-none-eabihf -p vt-fpu -p vt-tube -p vt-dissipative -p vt-cfo -p vt-plan

echo "== the Linux companion cross-builds for the Raspberry Pi (aarch64)"
cargo build --release -p vt-companion-linux --target aarch64-unknown-linux-gnu
# ELF e_machine (offset 18) must be EM_AARCH64 (0xb7).
[ "$(od -An -tx1 -j18 -N2 target/aarch64-unknown-linux-gnu/release/vt-companion | tr -d ' \n')" = "b700" ] \
  || { echo "vt-companion: not an aarch64 executable"; exit 1; }

echo "== firmware: both boards build; flash and static RAM within budget"
cargo run -q --release -p xtask -- firmware-size

echo "== clippy, host, MCU crates and both firmware boards; warnings are errors"
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy --target thumbv7em-none-eabihf -p vt-fpu -p vt-tube -p vt-dissipative -p vt-cfo -p vt-plan -p vt-map -- -D warnings
(cd firmware && cargo clippy --release --features qemu -- -D warnings && cargo clippy --release --features stm32f405 -- -D warnings \
  && cargo clippy --release --features perception-bench --bin vt-bench-perception -- -D warnings \
  && cargo clippy --release --features qemu,perception --bin vt-firmware-qemu-perception -- -D warnings)

echo "== firmware companion unit tests (host build of the firmware's logic)"
host_triple=$(rustc -vV | sed -n 's/^host: //p')
(cd firmware && cargo clippy -p vt-companion --features std,perception --target "$host_triple" --all-targets -- -D warnings \
  && cargo test --profile ci -p vt-companion --features std,perception --target "$host_triple")

echo "== tests (unit, property, doc, closed-loop acceptance, link fuzz, PIL in QEMU, replay in Chromium, MCAP)"
VT_REQUIRE_QEMU=1 VT_REQUIRE_CHROMIUM=1 VT_REQUIRE_ROTORPY=1 cargo test --workspace --profile ci

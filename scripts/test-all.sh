#!/usr/bin/env bash
# Runs every test of the project on a fresh machine, installing what it needs first.
# Used as-is by CI (.ci/run). Exit status: 0 only if everything passed.
set -euo pipefail
cd "$(dirname "$0")/.."

as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
# Each stage's heading carries the time since the start, so a CI log shows where the time goes.
stage() { echo "== $* [$((SECONDS / 60)) min $((SECONDS % 60)) s]"; }

stage "toolchain: thumbv7em-none-eabihf target and clippy"
rustup target list --installed | grep -qx thumbv7em-none-eabihf || rustup target add thumbv7em-none-eabihf
rustup component list --installed | grep -q '^clippy' || rustup component add clippy

stage "aarch64 cross toolchain (the Linux companion for a Raspberry Pi, docs/deploy.md)"
rustup target list --installed | grep -qx aarch64-unknown-linux-gnu || rustup target add aarch64-unknown-linux-gnu
if ! command -v aarch64-linux-gnu-gcc >/dev/null 2>&1; then
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gcc-aarch64-linux-gnu libc6-dev-arm64-cross
fi

stage "QEMU (processor-in-the-loop tests)"
if ! command -v qemu-system-arm >/dev/null 2>&1; then
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq qemu-system-arm
fi
qemu-system-arm --version | head -n 1

stage "Chromium (the browser replay is tested headless, tests/replay_browser.rs)"
if ! command -v chromium >/dev/null 2>&1; then
  as_root apt-get update -qq
  as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium
fi
chromium --version 2>/dev/null | head -n 1

stage "RotorPy (the plant of host-sim sitl --plant rotorpy, tests/rotorpy.rs): a Python venv in target/, made beside the builds"
venv=target/rotorpy-venv
mkdir -p target
# pip spends its time downloading and unpacking, not computing: it runs beside the builds below.
(
  set -euo pipefail
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
) > target/rotorpy-venv.log 2>&1 &
venv_job=$!

stage "the controller crates build for the flight MCU (no_std, no alloc)"
cargo build --release --target thumbv7em-none-eabihf -p vt-fpu -p vt-tube -p vt-dissipative -p vt-cfo -p vt-plan

stage "the Linux companion cross-builds for the Raspberry Pi (aarch64)"
cargo build --release -p vt-companion-linux --target aarch64-unknown-linux-gnu
# ELF e_machine (offset 18) must be EM_AARCH64 (0xb7).
[ "$(od -An -tx1 -j18 -N2 target/aarch64-unknown-linux-gnu/release/vt-companion | tr -d ' \n')" = "b700" ] \
  || { echo "vt-companion: not an aarch64 executable"; exit 1; }

stage "clippy, host, MCU crates and both firmware boards; warnings are errors"
cargo clippy --workspace --all-targets -- -D warnings
cargo clippy --target thumbv7em-none-eabihf -p vt-fpu -p vt-tube -p vt-dissipative -p vt-cfo -p vt-plan -p vt-map -- -D warnings
(cd firmware && cargo clippy --release --features qemu -- -D warnings && cargo clippy --release --features stm32f405 -- -D warnings \
  && cargo clippy --release --features perception-bench --bin vt-bench-perception -- -D warnings \
  && cargo clippy --release --features qemu,perception --bin vt-firmware-qemu-perception -- -D warnings)

stage "firmware companion unit tests (host build of the firmware's logic)"
host_triple=$(rustc -vV | sed -n 's/^host: //p')
(cd firmware && cargo clippy -p vt-companion --features std,perception --target "$host_triple" --all-targets -- -D warnings \
  && cargo test --profile ci -p vt-companion --features std,perception --target "$host_triple")

stage "build: every test and the host binaries, once, in the test profile"
cargo test --workspace --profile ci --no-run
# The same units plus the binaries no test target needs (xtask): nothing else is rebuilt.
cargo build --workspace --profile ci --bins --tests

stage "firmware: both boards build; flash and static RAM within budget"
# xtask from the build above: a release build of it would compile host-sim a second time.
target/ci/xtask firmware-size

stage "RotorPy's venv (made beside the builds)"
if ! wait "$venv_job"; then cat target/rotorpy-venv.log; echo "the RotorPy venv could not be made"; exit 1; fi
cat target/rotorpy-venv.log

stage "tests (unit, property, doc, closed-loop acceptance, link fuzz, PIL in QEMU, replay in Chromium, MCAP), RotorPy's flight beside them"
export VT_REQUIRE_QEMU=1 VT_REQUIRE_CHROMIUM=1 VT_REQUIRE_ROTORPY=1
# SITL and RotorPy fly the companion of this build (the SIL twin's features), not a second
# build of it with `-p vt-companion-linux`'s features.
export VT_COMPANION_BIN="$PWD/target/ci/vt-companion"
# RotorPy's flight spends about 4 minutes on one core in Python (tests/rotorpy.rs): it runs in a
# second process beside the rest, which skip it by its exact name.
rotorpy_flight=the_experiment_flies_in_rotorpy_with_its_floors_and_scores_the_same_from_the_file
cargo test --workspace --profile ci --test rotorpy -- --exact "$rotorpy_flight" > target/rotorpy-flight.log 2>&1 &
flight_job=$!
status=0
cargo test --workspace --profile ci -- --exact --skip "$rotorpy_flight" || status=$?
flight=0
wait "$flight_job" || flight=$?

stage "RotorPy's flight (run beside the tests above)"
cat target/rotorpy-flight.log
if ! grep -q "test result: ok. 1 passed" target/rotorpy-flight.log; then
  echo "RotorPy's flight did not run and pass as one test: is $rotorpy_flight still its name in tests/rotorpy.rs?"
  flight=1
fi
stage "done"
[ "$status" = 0 ] && [ "$flight" = 0 ]

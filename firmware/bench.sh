#!/bin/sh
# Firmware measurements for `cargo xtask bench` (issue 5's hook; run from the repository root):
# instruction counts per high-level and low-level step for 3, 10 and 30 UAVs and the stack
# high-water mark, measured on the `qemu` firmware under `qemu-system-arm -icount shift=0`
# (host-sim's PIL bench, docs/firmware.md), and issue 28's perception bench (map update and
# re-plan instructions, `vt-bench-perception`). Prints the JSON object last.
set -eu
cargo test --release -p host-sim --test pil -- --ignored pil_bench_instruction_counts --nocapture --test-threads 1 \
  | grep '^{' | tail -n 1

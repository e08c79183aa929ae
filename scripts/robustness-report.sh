#!/usr/bin/env bash
# Flies every campaign under scenarios/campaigns/ and prints the table of docs/robustness.md;
# per-run rows, sweep.json and plots go to out/robustness/<campaign>/.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p host-sim
for c in nominal nominal-point-mass cable-uncertainty cable-snap uav-silent own-feed-stall nominal-levels latency-levels; do
  echo "## $c"
  ./target/release/host-sim sweep "scenarios/campaigns/$c.toml" --out "out/robustness/$c" | sed -n '1,20p'
done

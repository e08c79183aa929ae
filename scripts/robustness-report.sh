#!/usr/bin/env bash
# Flies every campaign under scenarios/campaigns/ and prints the table of docs/robustness.md;
# per-run rows, sweep.json and plots go to out/robustness/<campaign>/, and the success-rate
# plots of the level campaigns (latency, intensity) are copied to docs/img/.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p host-sim
for c in nominal nominal-point-mass cable-uncertainty cable-snap uav-silent nominal-levels latency-levels latency-150ms; do
  echo "## $c"
  ./target/release/host-sim sweep "scenarios/campaigns/$c.toml" --out "out/robustness/$c" | sed -n '1,20p'
done
cp out/robustness/latency-levels/success_rate_vs_level.png docs/img/robustness_latency_rigid.png
cp out/robustness/nominal-levels/success_rate_vs_level.png docs/img/robustness_intensity_rigid.png

#!/usr/bin/env bash
# Flies every campaign under scenarios/campaigns/ and prints the table of docs/robustness.md;
# per-run rows, sweep.json and plots go to out/robustness/<campaign>/, and the success-rate
# plots of the level campaigns (latency, intensity) are copied to docs/img/.
# WORLD=scenario (the default here: the table and plots docs/robustness.md shows) flies each
# campaign's base as written; WORLD=real_aircraft flies the real-aircraft world (the campaigns'
# own default, docs/robustness.md "Every campaign in the real-aircraft world") into
# out/robustness-real_aircraft/ (its plots in img/ there) and leaves docs/img/ alone.
set -euo pipefail
cd "$(dirname "$0")/.."
WORLD="${WORLD:-scenario}"
OUT=out/robustness
[ "$WORLD" = scenario ] || OUT="out/robustness-$WORLD"
IMG=docs/img
[ "$WORLD" = scenario ] || IMG="$OUT/img"
mkdir -p "$IMG"
cargo build --release -q -p host-sim
for c in nominal nominal-point-mass cable-uncertainty cable-snap uav-silent own-feed-stall nominal-levels intensity-3x latency-levels latency-150ms; do
  echo "## $c"
  file="scenarios/campaigns/$c.toml"
  if [ "$c" = nominal-levels ] && [ "$WORLD" != scenario ]; then
    # Levels 4 and 5 times the real-aircraft world's light turbulence exceed the Dryden model's
    # severe (3), which the validation refuses: that world flies levels 0-3 (docs/robustness.md).
    mkdir -p "$OUT"
    file="$OUT/nominal-levels-0-3.toml"
    sed -e "s|^base = \"../paper-10uav.toml\"|base = \"$PWD/scenarios/paper-10uav.toml\"|" \
        -e 's|^values = \[0.0, 1.0, 2.0, 3.0, 4.0, 5.0\]|values = [0.0, 1.0, 2.0, 3.0]|' \
        scenarios/campaigns/nominal-levels.toml > "$file"
  fi
  ./target/release/host-sim sweep "$file" --world "$WORLD" --out "$OUT/$c" | sed -n '1,20p'
done
cp "$OUT/latency-levels/success_rate_vs_level.png" "$IMG/robustness_latency_rigid.png"
cp "$OUT/nominal-levels/success_rate_vs_level.png" "$IMG/robustness_intensity_rigid.png"
# Issue 15: payload near the physical limit (hard 20 N cap and the default elastic cable) and
# overload in flight (declared 18 kg, true 15-25 kg, both cables). Their success-rate-against-load
# plots are the ones docs/robustness.md shows.
for c in payload payload-elastic overload overload-clamp; do
  echo "## $c"
  ./target/release/host-sim sweep "scenarios/campaigns/$c.toml" --world "$WORLD" --out "$OUT/$c" | sed -n '1,20p'
done
cp "$OUT/payload/success_rate_vs_level.png" "$IMG/robustness_payload.png"
cp "$OUT/overload/success_rate_vs_level.png" "$IMG/robustness_overload.png"
cp "$OUT/overload-clamp/success_rate_vs_level.png" "$IMG/robustness_overload_clamp.png"
# The payload-elastic sweep: time above the rated 20 N per load, and the heaviest load under 5 %
# (columns from the end of sweep.csv: the failures column before them may hold anything).
awk -F, 'NR > 1 { above = $(NF - 1); printf "  %s kg: success %s, %.1f %% of cable-time above rated\n", $1, $3, 100 * above;
                  if ($3 == "true" && above < 0.05 && $1 + 0 > best) best = $1 + 0 }
         END { printf "  heaviest load under 5 %% above rated: %s kg\n", best }' "$OUT/payload-elastic/sweep.csv"

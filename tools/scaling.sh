#!/usr/bin/env bash
# CPU time, steps per CPU-second and peak memory of deconv-model as the world grows: one
# seed of 150,000 steps (ε 0.05, q0 10, Poisson 13, λ̂max 50, no undelayed baseline) on
# the four worlds of docs/performance.md, with the defaults, with the visit count, with
# the reweighted passes in the last round of a refit only (`last-round-passes`) and with
# that and half as many refits (`last-round-passes-refit_growth-4`), the least CPU time of
# RUNS runs each (peak RSS and what it earned from the same run).
# Writes CSV to stdout; `cargo run --release --example scaling_figure` draws it.
#
#   cargo build --release && bash tools/scaling.sh > docs/performance/scaling.csv
#
# Run it on an idle machine: the CPU time is the process's user time, which other load
# inflates. RUNS (default 2) and MMQ (default target/release/mmq) may be set.
set -euo pipefail
cd "$(dirname "$0")/.."
MMQ=${MMQ:-target/release/mmq}
RUNS=${RUNS:-2}
VISIT_COUNT="--set optimism_confidence=0 --set probe_steps=greedy --set refit_every=250 \
--set plan_exploration=false --set pmf_rounds=1 --set refit_on_surprise=0"
[ -x "$MMQ" ] || { echo "$MMQ not found: run cargo build --release first" >&2; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "world,pairs,construction,cpu_s,steps_per_cpu_s,peak_rss_mb,learns,greedy"
for world in paper-9x9:324 maze-15x15:900 open-30x30:3600 open-50x50:10000; do
  name=${world%%:*}
  pairs=${world#*:}
  for construction in defaults visit-count last-round-passes last-round-passes-refit_growth-4; do
    case $construction in
      defaults) flags="" ;;
      visit-count) flags=$VISIT_COUNT ;;
      last-round-passes) flags="--set pmf_weighted_rounds=last" ;;
      last-round-passes-refit_growth-4) flags="--set pmf_weighted_rounds=last --set refit_growth=4" ;;
    esac
    best=""
    for _ in $(seq "$RUNS"); do
      rm -rf "$out/run"
      # shellcheck disable=SC2086 # the flags are words
      /usr/bin/time -f "%U %M" -o "$out/time" "$MMQ" run --world "$name" --learner deconv-model \
        --epsilon 0.05 --q0 10 --steps 150000 --seeds 1 -q --no-baseline --no-tables \
        $flags --out "$out/run" > /dev/null
      read -r cpu rss < "$out/time"
      if [ -z "$best" ] || awk -v a="$cpu" -v b="${best%% *}" 'BEGIN { exit !(a < b) }'; then
        fractions=$(python3 - "$out/run/summary.json" <<'EOF'
import json, sys
seed = json.load(open(sys.argv[1]))["seeds"][0]
print(seed["perf/fraction_of_optimum"], seed["eval/greedy_fraction_of_optimum"])
EOF
)
        best="$cpu $rss $fractions"
      fi
    done
    read -r cpu rss learns greedy <<< "$best"
    awk -v w="$name" -v p="$pairs" -v c="$construction" -v cpu="$cpu" -v rss="$rss" \
      -v l="$learns" -v g="$greedy" \
      'BEGIN { printf "%s,%s,%s,%.2f,%.0f,%.0f,%.4f,%.4f\n", w, p, c, cpu, 150000 / cpu, rss / 1024, l, g }'
  done
done

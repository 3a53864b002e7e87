#!/bin/bash
# Overhead of `mmq run --live`: the same run without --live, with --live and no client,
# and with one client watching (unpaced, and paced); REPS rounds (default 5), the cases
# of a round run back to back so that the machine's load hits them alike; then the
# median wall-clock and CPU seconds (and, with perf, page faults and context switches) of
# each case, and its overhead against the plain run: of the medians, and paired (the median
# of each round's own ratio).
#
# From the repository root, after
#   cargo build --release --workspace
#   cargo build --release --workspace --examples     # the client: examples/live_client
# Usage: REPS=5 bash tools/live-overhead.sh   (MMQ=path/to/mmq measures another binary;
# ONLY=grid, ONLY=robot or ONLY=paced runs only those cases, e.g. for more rounds of them)
set -euo pipefail
REPS=${REPS:-5}
ONLY=${ONLY:-}
want() { [ -z "$ONLY" ] || [ "$ONLY" = "$1" ]; }
M=${MMQ:-target/release/mmq}
C=target/release/examples/live_client
O=$(mktemp -d "${TMPDIR:-/tmp}/mmq-live-overhead.XXXXXX")
trap 'rm -rf "$O"' EXIT
# One timed run: prints "wall cpu faults switches" (seconds; cpu = user + system of the
# process and its threads; page faults and context switches as `perf stat` counts them,
# "- -" without perf).
if command -v perf >/dev/null && perf stat -e task-clock true >/dev/null 2>&1; then
  t() {
    perf stat -x, -e page-faults,context-switches -o "$O/perf.txt" \
      /usr/bin/time -f "%e %U %S" -o "$O/time.txt" "$@" >/dev/null 2>&1
    awk '{printf "%s %s ", $1, $2 + $3}' "$O/time.txt"
    awk -F, '$3 == "page-faults" {f = $1} $3 == "context-switches" {c = $1} END {print f, c}' "$O/perf.txt"
  }
else
  t() { /usr/bin/time -f "%e %U %S" "$@" 2>&1 >/dev/null | tail -1 | awk '{print $1, $2 + $3, "-", "-"}'; }
fi
Q="--learner mmq --no-baseline --no-tables --eval-steps 0 -q"
GRID="run --env grid --steps 3000000 $Q"
ROBOT="run --env robot --steps 20000 $Q"
# Paced: 300 primitives at 50× real time (some 15 s of wall time); its cost is the extra
# CPU time as a share of that wall time (the run itself mostly waits for the clock).
PACED="run --env robot --steps 300 $Q"
port=18765
client() { port=$((port + 1)); ($C 127.0.0.1:$port > "$O/client-$1-$port.txt" 2>&1 &); }
echo "# rounds: $REPS; load at start: $(cut -d' ' -f1-3 /proc/loadavg)"
for i in $(seq "$REPS"); do
  echo "round $i load $(cut -d' ' -f1 /proc/loadavg)"
  if want grid; then
    echo "grid-plain $(t $M $GRID --out "$O/g")"
    echo "grid-live $(t $M $GRID --out "$O/g" --live 0)"
    client grid
    echo "grid-client $(t $M $GRID --out "$O/g" --live 127.0.0.1:$port --live-speed 0)"
  fi
  if want robot; then
    echo "robot-plain $(t $M $ROBOT --out "$O/r")"
    echo "robot-live $(t $M $ROBOT --out "$O/r" --live 0)"
    client robot
    echo "robot-client $(t $M $ROBOT --out "$O/r" --live 127.0.0.1:$port --live-speed 0)"
  fi
  if want paced; then
    echo "paced-plain $(t $M $PACED --out "$O/p")"
    client paced
    echo "paced-client $(t $M $PACED --out "$O/p" --live 127.0.0.1:$port --live-speed 50)"
  fi
done | tee "$O/raw.txt"
sleep 1
echo "# what the clients received (last round):"
for f in "$O"/client-*.txt; do echo "$(basename "$f"): $(tail -1 "$f")"; done | tail -3
python3 - "$O/raw.txt" <<'EOF'
import statistics, sys
runs, rounds, r = {}, [], None
for line in open(sys.argv[1]):
    p = line.split()
    if p[0] == "round":
        r = {}
        rounds.append(r)
    elif len(p) == 5:
        v = tuple(float(x) if x != "-" else float("nan") for x in p[1:])
        runs.setdefault(p[0], []).append(v)
        r[p[0]] = v
med = {k: [statistics.median(x[i] for x in v) for i in range(4)] for k, v in runs.items()}
def paired(k, base):
    # The median of each round's own CPU ratio (the cases of a round ran back to back).
    q = [r[k][1] / r[base][1] for r in rounds if k in r and base in r]
    return statistics.median(q) if q else float("nan")
print(f"{'case':<14} {'n':>2} {'wall s':>7} {'cpu s':>7} {'faults':>7} {'ctx sw':>7} {'wall vs plain':>14} {'cpu vs plain':>13} {'cpu paired':>11}")
for k, (w, c, f, cs) in med.items():
    b = k.split("-")[0] + "-plain"
    base = med.get(b)
    rel = "" if base is None or k.endswith("plain") else \
        f"{100 * (w / base[0] - 1):+13.1f}% {100 * (c / base[1] - 1):+12.1f}% {100 * (paired(k, b) - 1):+10.1f}%"
    print(f"{k:<14} {len(runs[k]):>2} {w:7.2f} {c:7.3f} {f:7.0f} {cs:7.0f} {rel}")
if "paced-client" in med and "paced-plain" in med:
    (w, c, _, _), c0 = med["paced-client"], med["paced-plain"][1]
    print(f"paced watching: {c - c0:.2f} s of extra CPU in {w:.2f} s of run time = {100 * (c - c0) / w:.1f} %")
EOF

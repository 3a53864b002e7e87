#!/bin/bash
# Run from the repository root after: cargo build --release -p mmq -p mmq-log --bins --example live_client
# Overhead of --live: the same run without --live, with --live and no client, with a client.
M=target/release/mmq
C=target/release/examples/live_client
O=${TMPDIR:-/tmp}/mmq-live-overhead; rm -rf $O; mkdir -p $O
t() { /usr/bin/time -f "%e s wall, %U+%S s cpu" "$@" 2>&1 >/dev/null | tail -1; }
for i in 1 2 3; do
  echo "grid plain:      $(t $M run --env grid --learner mmq --steps 3000000 --no-baseline --no-tables --eval-steps 0 -q --out $O/g)"
  echo "grid live:       $(t $M run --env grid --learner mmq --steps 3000000 --no-baseline --no-tables --eval-steps 0 -q --out $O/g --live 0)"
  echo "robot plain:     $(t $M run --env robot --learner mmq --steps 20000 --no-baseline --no-tables --eval-steps 0 -q --out $O/r)"
  echo "robot live:      $(t $M run --env robot --learner mmq --steps 20000 --no-baseline --no-tables --eval-steps 0 -q --out $O/r --live 0)"
  P=$((18765 + i))
  ($C 127.0.0.1:$P > $O/client$i.txt 2>&1 &)
  echo "robot live+client: $(t $M run --env robot --learner mmq --steps 20000 --no-baseline --no-tables --eval-steps 0 -q --out $O/r --live 127.0.0.1:$P --live-speed 0)"
  sleep 1; tail -1 $O/client$i.txt
done

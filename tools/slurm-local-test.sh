#!/usr/bin/env bash
# Proves the cluster path of `mmq sweep` on a real Slurm scheduler, on this machine only:
#   1. installs Debian's slurm-wlm and munge (apt-get; needs root),
#   2. starts a one-node cluster on the loopback address (127.0.0.1): munged, slurmctld
#      and slurmd with a minimal slurm.conf holding this node's real CPUs and memory,
#   3. runs a small sweep unsharded as the reference,
#   4. submits the same sweep with tools/slurm-sweep.sbatch (a 3-task job array and a
#      dependent merge), waits for both, and
#   5. checks that the merged results.csv equals the reference byte for byte, and
#   6. checks that a task Slurm signals before its time limit stops cleanly, keeping its
#      finished jobs for a resubmission.
# Every daemon it started is stopped at the end (by its process id). A manual tool, not
# run by CI: `sudo tools/slurm-local-test.sh` (env: WORK=dir to keep the files, SPEC,
# SHARDS, MMQ; SKIP_TIMELIMIT=1 skips the last check, which takes two minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
spec=${SPEC:-$root/worlds/sweeps/slurm-test.toml}
shards=${SHARDS:-3}
work=${WORK:-$(mktemp -d /tmp/mmq-slurm.XXXXXX)}
mkdir -p "$work"
work=$(realpath "$work")
say() { printf '\n==> %s\n' "$*"; }

if [ "$(id -u)" -ne 0 ]; then
    echo "run as root (installs packages and starts daemons)" >&2
    exit 1
fi

say "install slurm-wlm and munge"
export DEBIAN_FRONTEND=noninteractive
apt-get update -q >"$work/apt.log" 2>&1
apt-get install -y -q slurm-wlm munge >>"$work/apt.log" 2>&1
dpkg-query -W -f 'slurm-wlm ${Version}, munge ' slurm-wlm
dpkg-query -W -f '${Version}\n' munge

say "build mmq"
if [ -z "${MMQ:-}" ]; then
    cargo build --release -q
    MMQ=$root/target/release/mmq
fi
export MMQ
"$MMQ" --version

pids=()
cleanup() {
    for p in "${pids[@]}"; do
        kill "$p" 2>/dev/null || true
    done
    for p in "${pids[@]}"; do
        for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    done
}
trap cleanup EXIT

say "munge (key, then munged as user munge)"
if [ ! -s /etc/munge/munge.key ]; then
    mungekey --create --keyfile=/etc/munge/munge.key
fi
chown munge:munge /etc/munge/munge.key
chmod 0400 /etc/munge/munge.key
mkdir -p "$work/munge"
chown munge:munge "$work/munge"
chmod 0755 "$work/munge"
sock=$work/munge/munge.socket
runuser -u munge -- /usr/sbin/munged --foreground --socket="$sock" \
    --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" \
    --seed-file="$work/munge/munge.seed" >"$work/munge/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$sock" ] && break; sleep 0.1; done
munge --socket="$sock" -n | unmunge --socket="$sock" | grep STATUS

say "slurm.conf for one node on 127.0.0.1"
node=$(hostname -s)
# The node's real hardware, as slurmd sees it (CPUs=.. Boards=.. ... RealMemory=..).
hw=$(slurmd -C | head -1 | sed 's/^NodeName=[^ ]* //')
mkdir -p "$work/etc" "$work/state" "$work/spool" "$work/log"
cat >"$work/etc/slurm.conf" <<EOF
ClusterName=mmqlocal
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool/slurmd-%n
SlurmctldPidFile=$work/state/slurmctld.pid
SlurmdPidFile=$work/state/slurmd-%n.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MailProg=/bin/true
PlugStackConfig=$work/etc/plugstack.conf
NodeName=$node NodeAddr=127.0.0.1 NodeHostname=$node $hw State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
: >"$work/etc/plugstack.conf"
export SLURM_CONF=$work/etc/slurm.conf
grep -E '^(SlurmctldHost|NodeName)' "$SLURM_CONF"

say "start slurmctld and slurmd"
/usr/sbin/slurmctld -D -i -f "$SLURM_CONF" >"$work/log/slurmctld.out" 2>&1 &
pids+=($!)
sleep 1
/usr/sbin/slurmd -D -f "$SLURM_CONF" >"$work/log/slurmd.out" 2>&1 &
pids+=($!)
state=""
for _ in $(seq 120); do
    state=$(sinfo -h -N -o '%T' 2>/dev/null | head -1 || true)
    [ "$state" = idle ] && break
    sleep 0.5
done
if [ "$state" != idle ]; then
    echo "the node did not come up (state '$state'); logs in $work/log" >&2
    tail -20 "$work/log/slurmctld.log" "$work/log/slurmd.log" >&2 || true
    exit 1
fi
sinfo -N -o '%N %P %T %c %m'

say "reference: the sweep unsharded on this machine"
"$MMQ" sweep "$spec" --out "$work/unsharded" -q

say "submit: $shards-task job array + dependent merge (tools/slurm-sweep.sbatch)"
SBATCH_ARGS="--cpus-per-task=1 --mem=500M --time=00:20:00" \
    tools/slurm-sweep.sbatch "$spec" "$work/cluster" "$shards" | tee "$work/submit.txt"
array_id=$(sed -n 's/^submitted shards: job array \([0-9]*\).*/\1/p' "$work/submit.txt")
merge_id=$(sed -n 's/.*merge: job \([0-9]*\).*/\1/p' "$work/submit.txt")
squeue -o '%.10i %.16j %.8T %.10M %R'

say "wait for the array and the merge"
for _ in $(seq 600); do
    left=$(squeue -h -j "$array_id,$merge_id" 2>/dev/null | wc -l)
    [ "$left" -eq 0 ] && break
    sleep 1
done
scontrol -o show job "$array_id" | sed -n 's/.*JobId=\([0-9]*\) ArrayJobId=[0-9]* ArrayTaskId=\([0-9]*\).*JobState=\([A-Z_]*\).*ExitCode=\([0-9:]*\).*/  shard task \2 (job \1): \3, exit \4/p' | sort -k3n
scontrol -o show job "$merge_id" | sed -n 's/.*JobId=\([0-9]*\) .*JobState=\([A-Z_]*\).*ExitCode=\([0-9:]*\).*/  merge (job \1): \2, exit \3/p'
for f in "$work"/cluster/logs/*.out; do
    echo "--- $(basename "$f")"
    cat "$f"
done

say "compare merged cluster results with the unsharded reference"
if cmp "$work/unsharded/results.csv" "$work/cluster/merged/results.csv"; then
    rows=$(($(wc -l <"$work/unsharded/results.csv") - 1))
    echo "IDENTICAL: $work/cluster/merged/results.csv == $work/unsharded/results.csv ($rows rows, $(sha256sum <"$work/unsharded/results.csv" | cut -c1-16))"
else
    echo "DIFFERENT: see $work" >&2
    exit 1
fi

if [ "${SKIP_TIMELIMIT:-0}" != 1 ]; then
    say "time limit: Slurm's SIGINT before the limit stops mmq cleanly (about 2 minutes; SKIP_TIMELIMIT=1 skips)"
    # Two jobs of a few milliseconds and two that would take hours, in a 3-minute job
    # that Slurm signals (B:INT) 60 s before its limit.
    cat >"$work/long.toml" <<EOF
name = "time-limit"
world = "$root/worlds/paper-9x9.toml"
learner = "mmq"
max_delay = 20
steps = [20000, 3000000000]
baseline = false
seeds = 2
EOF
    SBATCH_ARGS="--cpus-per-task=2 --time=3 --signal=B:INT@60" \
        tools/slurm-sweep.sbatch "$work/long.toml" "$work/long" 1 | tee "$work/submit-long.txt"
    long_id=$(sed -n 's/^submitted shards: job array \([0-9]*\).*/\1/p' "$work/submit-long.txt")
    long_merge=$(sed -n 's/.*merge: job \([0-9]*\).*/\1/p' "$work/submit-long.txt")
    for _ in $(seq 400); do
        [ "$(squeue -h -j "$long_id" 2>/dev/null | wc -l)" -eq 0 ] && break
        sleep 1
    done
    # The shard was interrupted (exit 130), so its afterok merge can never run.
    scancel "$long_merge" 2>/dev/null || true
    scontrol -o show job "$long_id" |
        sed -n 's/.*JobState=\([A-Z_]*\).*ExitCode=\([0-9:]*\).*RunTime=\([0-9:]*\) TimeLimit=\([0-9:]*\).*/  shard: \1 (exit \2) after \3 of its \4 limit/p'
    cat "$work"/long/logs/shard-*.out
    if grep -q '"complete": false' "$work/long/shards/1/sweep.json" &&
        [ "$(find "$work/long/shards/1/cells" -name 'seed-*.json' | wc -l)" -eq 2 ] &&
        grep -q '^interrupted: 2 job' "$work"/long/logs/shard-*.out; then
        echo "STOPPED CLEANLY: the 2 short jobs kept, the 2 long ones left to resume ($work/long/shards/1)"
    else
        echo "the time-limit signal did not stop mmq as expected; see $work/long" >&2
        exit 1
    fi
fi
echo "files kept in $work"

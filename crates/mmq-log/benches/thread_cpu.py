#!/usr/bin/env python3
"""Runs a command and prints its wall time, its user CPU time and, per thread, the time on a CPU and the
time waiting for one, from /proc/PID/task/TID/schedstat (Linux; polled every 5 ms, the
last value seen per thread kept, so the last few ms of a thread may be missed).

The recorder's wall-clock cost with a free second core is the growth of the main
thread's CPU time (the run's critical path): the writer thread `mmq-log-writer` then runs
beside it. On a busy machine the main thread also waits for a CPU (`runqueue`), and
`other` (wall − CPU − runqueue: blocked, e.g. waiting for the writer at a flush, plus
process start and exit) shows whether it waited for the writer.

usage: thread_cpu.py CMD...   (see docs/logs.md, "Cost")
"""
import os
import subprocess
import sys
import time

t0 = time.perf_counter()
p = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
last = {}
usage = None
while usage is None:
    try:
        for tid in os.listdir(f"/proc/{p.pid}/task"):
            try:
                comm = open(f"/proc/{p.pid}/task/{tid}/comm").read().strip()
                f = open(f"/proc/{p.pid}/task/{tid}/schedstat").read().split()
                last[tid] = (comm, int(f[0]), int(f[1]))
            except OSError:
                pass
    except OSError:
        pass
    pid, _, ru = os.wait4(p.pid, os.WNOHANG)
    if pid:
        usage = ru
    else:
        time.sleep(0.005)
wall = time.perf_counter() - t0
_, cpu, wait = last.get(str(p.pid), ("?", 0, 0))
writer = sum(ns for c, ns, _ in last.values() if c == "mmq-log-writer") / 1e9
print(
    f"wall {wall:.3f} user {usage.ru_utime:.3f} main cpu {cpu / 1e9:.3f} runqueue {wait / 1e9:.3f} "
    f"other {wall - (cpu + wait) / 1e9:.3f} writer cpu {writer:.3f}"
)

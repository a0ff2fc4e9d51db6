#!/usr/bin/env python3
"""Run a command and say, after it, its wall time and peak resident memory in the words of
`/usr/bin/time -v` (which not every machine has): `python3 bench/peak_rss.py CMD ARGS...`.
Exits with the command's status."""
import os, subprocess, sys, time

start = time.monotonic()
child = subprocess.Popen(sys.argv[1:])
_, status, usage = os.wait4(child.pid, 0)
print(f"\tElapsed (wall clock) time (seconds): {time.monotonic() - start:.1f}", file=sys.stderr)
print(f"\tMaximum resident set size (kbytes): {usage.ru_maxrss}", file=sys.stderr)
sys.exit(os.waitstatus_to_exitcode(status))

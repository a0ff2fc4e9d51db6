#!/usr/bin/env python3
"""Time a first start: `osmab serve` on an empty data directory until both boards of the demo
release show the reference mapper and the five controls.

Usage: python3 bench/first_start.py target/release/osmab /tmp/empty-data-dir
"""
import json, subprocess, sys, time, urllib.request, os
t0 = time.monotonic()
# The demo config's `assets` pack is the repository's.
env = dict(os.environ, OSMAB_DATA_DIR=sys.argv[2], OSMAB_BIND="127.0.0.1:18181", OSMAB_ASSETS_ROOT=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
p = subprocess.Popen([sys.argv[1], "serve"], env=env, stdout=subprocess.DEVNULL, stderr=open(sys.argv[2] + ".log", "w"))
seen = {}
try:
    while time.monotonic() - t0 < 900:
        try:
            b = json.load(urllib.request.urlopen("http://127.0.0.1:18181/api/v1/leaderboard", timeout=5))
            n = len(b.get("entries", []))
            if n not in seen:
                seen[n] = time.monotonic() - t0
                print(f"{seen[n]:.1f} s: {n} entries on the test board", flush=True)
            if n >= 6:
                v = json.load(urllib.request.urlopen("http://127.0.0.1:18181/api/v1/leaderboard?split=val", timeout=5))
                if len(v.get("entries", [])) >= 6:
                    print(f"{time.monotonic() - t0:.1f} s: both boards full", flush=True)
                    break
        except Exception:
            pass
        time.sleep(0.5)
finally:
    p.terminate(); p.wait()

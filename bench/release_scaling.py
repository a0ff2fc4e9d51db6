#!/usr/bin/env python3
"""Thread scaling of a release build: the same config and secret built from an empty folder
with RAYON_NUM_THREADS = 1, 2, 4, 8, 16 (or the counts given), each timed end to end with its
peak memory, and every build's manifest digest compared with the first (a release is the same
to the byte on any number of threads). Builds a thread count the machine lacks too (it then
measures oversubscription, not scaling): pass --threads to choose.

Usage:
  python3 bench/release_scaling.py target/release/osmab configs/release-full.toml /tmp/scaling \
      [--threads 1,2,4,8,16] [--secret S] [--keep]

Writes /tmp/scaling/scaling.json and prints a table (threads, seconds, speed-up, peak RSS,
digest). Each build's log is /tmp/scaling/t<N>.log; its folder is removed after it unless
--keep (a full release at 1200x680 is about 40 GB).
"""
import argparse, json, os, shutil, subprocess, sys, time

parser = argparse.ArgumentParser()
parser.add_argument("osmab")
parser.add_argument("config")
parser.add_argument("work")
parser.add_argument("--threads", default="1,2,4,8,16")
parser.add_argument("--secret", default="release-scaling-secret-0001")
parser.add_argument("--keep", action="store_true")
args = parser.parse_args()

os.makedirs(args.work, exist_ok=True)
rows = []
for threads in [int(t) for t in args.threads.split(",")]:
    out = os.path.join(args.work, f"t{threads}")
    shutil.rmtree(out, ignore_errors=True)
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads), OSMAB_SPLIT_SECRET=args.secret)
    log_path = os.path.join(args.work, f"t{threads}.log")
    start = time.monotonic()
    with open(log_path, "w") as log:
        build = subprocess.Popen([args.osmab, "release", "build", "--config", args.config, "--out", out],
                                 env=env, stdout=log, stderr=subprocess.STDOUT)
        # wait4 gives this build's own peak RSS (in KiB on Linux), with no /usr/bin/time needed.
        _, status, usage = os.wait4(build.pid, 0)
    seconds = time.monotonic() - start
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        sys.exit(f"the build on {threads} threads failed (exit {code}); see {log_path}")
    peak_kib = usage.ru_maxrss
    # The public files' digest and the hidden ground truth's (the test scenes' answers).
    digest = json.load(open(os.path.join(out, "manifest.json")))["digest"] + " " + \
        json.load(open(os.path.join(out, "ground_truth", "manifest.json")))["digest"]
    rows.append({"threads": threads, "seconds": round(seconds, 1), "peak_rss_mib": round(peak_kib / 1024), "digest": digest})
    if not args.keep:
        shutil.rmtree(out, ignore_errors=True)
    print(json.dumps(rows[-1]), flush=True)

first = rows[0]
print(f"\n| threads | seconds | speed-up over {first['threads']} | peak RSS | same bytes as {first['threads']} |")
print("|---:|---:|---:|---:|---|")
for r in rows:
    print(f"| {r['threads']} | {r['seconds']:.1f} | {first['seconds'] / r['seconds']:.2f} | {r['peak_rss_mib']} MiB | {'yes' if r['digest'] == first['digest'] else 'NO'} |")
json.dump({"config": args.config, "rows": rows}, open(os.path.join(args.work, "scaling.json"), "w"), indent=2)
if any(r["digest"] != first["digest"] for r in rows):
    sys.exit("the release differs between thread counts")

#!/usr/bin/env python3
"""Release build split across workers: how close to linear is it?

Builds the same sample of the full release (`configs/release-full.toml` at 1200x680 with its trajectories, a few
of its scenes) through the real service, once per worker count: `osmab serve` (no in-process worker) and N
`osmab worker --concurrency 1` processes on PostgreSQL, each worker pinned to a core of its own (`taskset -c i`)
and single-threaded (`RAYON_NUM_THREADS=1`), so one worker is one core's worth of work. The build job prepares
the scenes on one worker, fans out one render job per scene (all its lightings) to all of them, and one worker assembles
the release (ground truth, questions, quality report, manifest). The benchmark follows the build job's stages
and every render job from the admin API and reports, per worker count: the whole build, each phase, and the
speed-up against one worker, for the whole build and for the rendering alone. Standard library only.

    cargo build --release -p osmab
    python3 bench/release_workers.py --workers 1,2 --out docs/performance-release-workers.json

On a 2-core machine at most 2 workers can have a core each; `--workers` beyond the machine's cores is refused.
PostgreSQL: `--database-url` names a server where the benchmark may create and drop a database.
"""

import argparse
import json
import os
import platform
import re
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cluster import Cluster, free_port, wait_listening  # noqa: E402
from service import ADMIN, request  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "osmab")


def sample_config(furniture, manipuland, version):
    """The full release's config with fewer scenes (and test scenes to match): same resolution, trajectories and
    lightings, so a sequence costs what it costs in the full release."""
    with open(os.path.join(ROOT, "configs", "release-full.toml")) as f:
        text = f.read()
    text = re.sub(r'(?m)^version = ".*"$', f'version = "{version}"', text)
    text = re.sub(r"(?m)^furniture = \d+$", f"furniture = {furniture}", text)
    text = re.sub(r"(?m)^manipuland = \d+$", f"manipuland = {manipuland}", text)
    text = re.sub(r"(?m)^test_furniture = \d+$", f"test_furniture = {min(1, furniture)}", text)
    text = re.sub(r"(?m)^test_manipuland = \d+$", f"test_manipuland = {min(1, manipuland)}", text)
    return text


class Deployment(Cluster):
    """A database, one server and `workers` pinned workers sharing one data directory."""

    def __init__(self, args, workers):
        super().__init__(args.database_url, "osmab-release-workers-")
        data = os.path.join(self.root, "data")
        os.makedirs(data)
        self.env = {
            "PATH": os.environ.get("PATH", ""), "RUST_LOG": "warn",
            "DATABASE_URL": self.database_url,
            "OSMAB_DATA_DIR": data, "OSMAB_ADMIN_TOKEN": ADMIN, "OSMAB_DEMO": "false", "OSMAB_POLL_MS": "100",
            # One secret for every run: the test scenes it shapes are the same whatever the worker count.
            "OSMAB_SPLIT_SECRET": "ab" * 32,
        }
        port = free_port()
        server = self.spawn("server", [BIN, "serve"], {"OSMAB_BIND": f"127.0.0.1:{port}", "OSMAB_WORKERS": "0"})
        wait_listening(port, server, self.log("server"))
        self.base = f"http://127.0.0.1:{port}"
        for core in range(workers):
            self.spawn(f"worker-{core}", ["taskset", "-c", str(core), BIN, "worker", "--concurrency", "1"], {"RAYON_NUM_THREADS": "1"})

    def spawn(self, name, argv, extra):
        return super().spawn(name, argv, dict(self.env, **extra))


def build(deployment, config):
    """Queue the build and follow it: seconds from the request to each stage, and every render job's first seen
    running and done times."""
    started = time.time()
    queued = request(deployment.base, "POST", "/api/v1/admin/releases", {"config": config, "publish": False, "baselines": False})
    job_id = queued["job"]
    stages, renders, messages = {}, {}, []
    while True:
        now = time.time() - started
        job = request(deployment.base, "GET", f"/api/v1/jobs/{job_id}")
        stage = (job.get("progress") or {}).get("stage")
        if stage and stage not in stages:
            stages[stage] = round(now, 2)
        message = (job.get("progress") or {}).get("message")
        if message and (not messages or messages[-1][1] != message):
            messages.append((round(now, 2), message))
        for j in request(deployment.base, "GET", "/api/v1/admin/jobs")["jobs"]:
            if j["kind"] != "render_sequence":
                continue
            seen = renders.setdefault(j["subject"], {})
            if j["state"] == "running" and "running" not in seen:
                seen["running"] = round(now, 2)
                seen["worker"] = ((j.get("lease") or {}).get("worker") or "")
            if j["state"] == "succeeded" and "done" not in seen:
                seen["done"] = round(now, 2)
                seen["frames"] = (j.get("progress") or {}).get("message", "")
        if job["state"] == "succeeded":
            stages["done"] = round(now, 2)
            return {"total_s": round(now, 2), "stages": stages, "renders": renders, "messages": messages}
        if job["state"] in ("failed", "cancelled"):
            sys.exit(f"the build {job['state']}: {job.get('error')}; logs in {deployment.root}")
        if now > 7200:
            sys.exit(f"the build did not finish in 2 hours; logs in {deployment.root}")
        time.sleep(0.25)


def phases(run):
    """Seconds of preparing (until the first render job runs), rendering (first render start to last render
    done) and assembling (last render done to the build done)."""
    starts = [r["running"] for r in run["renders"].values() if "running" in r]
    ends = [r["done"] for r in run["renders"].values() if "done" in r]
    first, last = min(starts), max(ends)
    return {"prepare_s": round(first, 2), "render_s": round(last - first, 2), "assemble_s": round(run["total_s"] - last, 2)}


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", default="1,2", help="worker counts to compare, the first is the reference")
    parser.add_argument("--furniture", type=int, default=2)
    parser.add_argument("--manipuland", type=int, default=1)
    parser.add_argument("--database-url", default="postgres://postgres@127.0.0.1:5432/postgres")
    parser.add_argument("--out", help="write the raw results here as JSON")
    args = parser.parse_args()
    counts = [int(n) for n in args.workers.split(",")]
    cores = os.cpu_count() or 1
    if max(counts) > cores:
        sys.exit(f"--workers {max(counts)} is more than this machine's {cores} cores: the workers would share cores")
    if not os.path.exists(BIN):
        sys.exit(f"{BIN} is missing: cargo build --release -p osmab")
    runs = {}
    for n in counts:
        print(f"{n} worker(s): building {args.furniture} furniture + {args.manipuland} manipuland scenes ...", flush=True)
        deployment = Deployment(args, n)
        try:
            run = build(deployment, sample_config(args.furniture, args.manipuland, f"bench-workers-{n}"))
        finally:
            deployment.close()
        run["phases"] = phases(run)
        runs[n] = run
        print(f"  {run['total_s']:.1f} s: {run['phases']}", flush=True)
    reference = counts[0]
    print("\n| workers (1 core each) | whole build s | prepare s | render s | assemble s | speed-up, whole | speed-up, rendering |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for n in counts:
        run, ph = runs[n], runs[n]["phases"]
        whole = runs[reference]["total_s"] / run["total_s"] * reference
        rendering = runs[reference]["phases"]["render_s"] / ph["render_s"] * reference
        print(f"| {n} | {run['total_s']:.1f} | {ph['prepare_s']:.1f} | {ph['render_s']:.1f} | {ph['assemble_s']:.1f} | "
              f"{whole:.2f}× ({whole / n:.0%} of linear) | {rendering:.2f}× ({rendering / n:.0%} of linear) |")
    if args.out:
        with open(args.out, "w") as f:
            json.dump({"machine": {"cpus": cores, "processor": platform.processor() or platform.machine()},
                       "sample": {"furniture": args.furniture, "manipuland": args.manipuland},
                       "command": "python3 bench/release_workers.py " + " ".join(sys.argv[1:]),
                       "runs": {str(n): r for n, r in runs.items()}}, f, indent=1)


if __name__ == "__main__":
    main()

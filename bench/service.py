#!/usr/bin/env python3
"""Service benchmark: leaderboard and page throughput, large-file download, memory during a 2 GB upload.

Starts the release binary's `osmab serve` on a fresh data directory (the demo release and the baselines are
built on the first start), then drives it with `xtask http|download|upload` (cargo xtask) from the same machine.
Writes the raw lines and the numbers as JSON. Standard library only.

    cargo build --release -p osmab -p xtask
    python3 bench/service.py --out docs/performance-service.json
"""

import argparse
import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "osmab")
XTASK = os.path.join(ROOT, "target", "release", "xtask")
ADMIN = "osmab_" + "b" * 32


def request(base, method, path, body=None, token=ADMIN):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(base + path, data=data, method=method)
    req.add_header("Authorization", "Bearer " + token)
    if data is not None:
        req.add_header("Content-Type", "application/json")
    with urllib.request.urlopen(req, timeout=600) as response:
        return json.loads(response.read() or b"null")


def rss_kib(pid):
    """(VmRSS, VmHWM) of a process in KiB."""
    values = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, rest = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                values[key] = int(rest.split()[0])
    return values["VmRSS"], values["VmHWM"]


def run_bench(*args):
    out = subprocess.run([XTASK, *args], check=True, capture_output=True, text=True).stdout.strip()
    print(out, flush=True)
    return out


def parse_http(line):
    """requests/s and latencies from an `xtask http` line."""
    words = line.replace(";", " ").replace(",", " ").split()
    per_second = float(words[words.index("requests/s") - 1])
    p50 = float(words[words.index("p50") + 1])
    p99 = float(words[words.index("p99") + 1])
    errors = int(words[words.index("errors") - 1])
    return {"requests_per_s": per_second, "p50_ms": p50, "p99_ms": p99, "errors": errors}


def add_large_file(target, size):
    """Add `extras/large.bin` of `size` random bytes to the release copy in `target`, under a new version; its
    (version, path, sha256)."""
    manifest_path = os.path.join(target, "manifest.json")
    manifest = json.load(open(manifest_path))
    manifest["version"] = manifest["version"] + "-large"
    os.makedirs(os.path.join(target, "extras"), exist_ok=True)
    path = os.path.join(target, "extras", "large.bin")
    digest = hashlib.sha256()
    block = os.urandom(1 << 20)
    with open(path, "wb") as f:
        for _ in range(size >> 20):
            f.write(block)
            digest.update(block)
    manifest["files"].append({"path": "extras/large.bin", "size": size, "sha256": digest.hexdigest()})
    manifest["files"].sort(key=lambda f: f["path"])
    lines = sorted(f"{f['path']} {f['size']} {f['sha256']}\n" for f in manifest["files"])
    manifest["digest"] = hashlib.sha256("".join(lines).encode()).hexdigest()
    json.dump(manifest, open(manifest_path, "w"), indent=2)
    return manifest["version"], path, digest.hexdigest()


def large_release(data_dir, base, size):
    """A copy of the demo release with one extra `size`-byte file, imported and published."""
    builds = os.path.join(data_dir, "builds")
    demo = os.path.join(builds, sorted(os.listdir(builds))[0], "release")
    target = os.path.join(data_dir, "bench-release")
    shutil.copytree(demo, target)
    version, path, _ = add_large_file(target, size)
    request(base, "POST", "/api/v1/admin/releases/import", {"path": target, "publish": True})
    return version, path


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--port", type=int, default=18181)
    parser.add_argument("--concurrency", type=int, default=64)
    parser.add_argument("--seconds", type=float, default=10)
    parser.add_argument("--upload-bytes", type=int, default=2_000_000_000)
    parser.add_argument("--download-bytes", type=int, default=2 << 30)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    for binary in (BIN, XTASK):
        if not os.path.exists(binary):
            sys.exit(f"{binary} is missing: run `cargo build --release -p osmab -p xtask` first")

    data_dir = tempfile.mkdtemp(prefix="osmab-bench-")
    base = f"http://127.0.0.1:{args.port}"
    env = dict(os.environ, RUST_LOG="warn", OSMAB_DATA_DIR=data_dir, OSMAB_BIND=f"127.0.0.1:{args.port}", OSMAB_ADMIN_TOKEN=ADMIN,
               OSMAB_RATE_LIMIT="0", OSMAB_MAX_UPLOAD_BYTES=str(8 << 30))
    env.pop("DATABASE_URL", None)
    server = subprocess.Popen([BIN, "serve"], env=env, stdout=subprocess.DEVNULL, stderr=open(os.path.join(data_dir, "serve.log"), "w"))
    results = {"machine": os.uname().machine, "cores": os.cpu_count(), "date": time.strftime("%Y-%m-%d"), "concurrency": args.concurrency}
    try:
        started = time.time()
        while True:
            time.sleep(1)
            try:
                rows = json.loads(urllib.request.urlopen(base + "/api/v1/leaderboard", timeout=5).read())
                if len(rows.get("entries", rows.get("rows", []))) >= 5:
                    break
            except OSError:
                pass
            if time.time() - started > 600 or server.poll() is not None:
                sys.exit("the service did not come up with the baselines; see " + os.path.join(data_dir, "serve.log"))
        results["first_start_to_leaderboard_s"] = round(time.time() - started, 1)
        print(f"leaderboard populated after {results['first_start_to_leaderboard_s']} s", flush=True)

        for name, path in [("leaderboard_json", "/api/v1/leaderboard"), ("leaderboard_csv", "/api/v1/leaderboard.csv"), ("leaderboard_page", "/"),
                           ("livez", "/livez")]:
            line = run_bench("http", base + path, "--concurrency", str(args.concurrency), "--seconds", str(args.seconds))
            results[name] = parse_http(line) | {"line": line}

        team = request(base, "POST", "/api/v1/admin/teams", {"name": "bench team"})
        idle_rss, _ = rss_kib(server.pid)
        peak = [idle_rss]
        done = threading.Event()

        def sample():
            while not done.is_set():
                peak[0] = max(peak[0], rss_kib(server.pid)[0])
                time.sleep(0.02)

        sampler = threading.Thread(target=sample)
        sampler.start()
        line = run_bench("upload", base + "/api/v1/submissions?dry_run=true", "--token", team["token"], "--bytes", str(args.upload_bytes))
        done.set()
        sampler.join()
        results["upload"] = {"bytes": args.upload_bytes, "rss_before_mib": round(idle_rss / 1024, 1), "rss_peak_mib": round(peak[0] / 1024, 1),
                             "growth_mib": round((peak[0] - idle_rss) / 1024, 1), "line": line}
        print(f"upload: RSS {idle_rss / 1024:.1f} MiB before, {peak[0] / 1024:.1f} MiB peak", flush=True)

        version, local = large_release(data_dir, base, args.download_bytes)
        url = f"{base}/api/v1/releases/{version}/files/extras/large.bin"
        lines = [run_bench("download", url) for _ in range(3)]
        speeds = sorted(float(l.split("=")[1].split()[0]) for l in lines)
        started = time.time()
        subprocess.run(["cat", local], check=True, stdout=subprocess.DEVNULL)
        cat_speed = args.download_bytes / (time.time() - started) / 1e6
        direct = subprocess.run(["dd", f"if={local}", "of=/dev/null", "bs=4M", "iflag=direct"], check=True, capture_output=True, text=True).stderr
        seconds = float(direct.strip().splitlines()[-1].split(" copied, ")[1].split()[0])
        disk_speed = args.download_bytes / seconds / 1e6
        curl = None
        if shutil.which("curl"):
            curl_speeds = sorted(float(subprocess.run(["curl", "-s", "-o", "/dev/null", "-w", "%{speed_download}", url], check=True, capture_output=True,
                                                      text=True).stdout) / 1e6 for _ in range(3))
            curl = round(curl_speeds[1])
        results["download"] = {"bytes": args.download_bytes, "median_mb_per_s": speeds[1], "curl_median_mb_per_s": curl,
                               "disk_direct_read_mb_per_s": round(disk_speed), "cat_page_cache_mb_per_s": round(cat_speed), "lines": lines}
        print(f"download median {speeds[1]:.0f} MB/s (curl {curl} MB/s); the disk read with O_DIRECT {disk_speed:.0f} MB/s; "
              f"cat from the page cache {cat_speed:.0f} MB/s", flush=True)
    finally:
        server.send_signal(signal.SIGTERM)
        server.wait(timeout=60)
        shutil.rmtree(data_dir, ignore_errors=True)
    if args.out:
        json.dump(results, open(args.out, "w"), indent=2)
        print("wrote", args.out)


if __name__ == "__main__":
    main()

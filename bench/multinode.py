#!/usr/bin/env python3
"""Multi-node benchmark: two `osmab serve` and two `osmab worker` processes that share nothing but PostgreSQL and
an S3-compatible bucket (moto's server from PyPI), each with a data directory of its own, on this machine.

Measures: first start of the deployment (demo release built by the workers, baselines scored); leaderboard
requests/s through each server and through both at once; resumable-upload (tus) MB/s into the bucket through
alternating servers; download MB/s of a large release file streamed from the bucket through either server, next
to a plain GET from the bucket itself; time from upload to score and to the new entry on the other server's
leaderboard, one at a time and eight at once. Standard library only.

    cargo build --release -p osmab -p xtask
    python3 bench/multinode.py --out docs/performance-multinode.json

PostgreSQL: `--database-url` names a server where the benchmark may create and drop a database
(default postgres://postgres@127.0.0.1:5432/postgres). moto: `--moto` (default target/pyenv/bin/moto_server,
which `.ci/run` installs; `python3 -m venv target/pyenv && target/pyenv/bin/pip install 'moto[server]'`).
"""

import argparse
import hashlib
import io
import json
import os
import shutil
import statistics
import subprocess
import sys
import tarfile
import threading
import time
import urllib.error
import urllib.parse
import urllib.request
import http.client

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(ROOT, "target", "release", "osmab")
XTASK = os.path.join(ROOT, "target", "release", "xtask")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cluster import Cluster, free_port, wait_listening  # noqa: E402
from service import ADMIN, add_large_file, parse_http, request, run_bench  # noqa: E402  (the single-node benchmark's helpers)


class Deployment(Cluster):
    """moto, a database, two servers and two workers; every process logs into `root`."""

    def __init__(self, args):
        super().__init__(args.database_url, "osmab-multinode-")
        self.moto_port = free_port()
        self.moto = self.spawn("moto", [args.moto, "-H", "127.0.0.1", "-p", str(self.moto_port)], os.environ.copy())
        wait_listening(self.moto_port, self.moto, self.log("moto"))
        self.bucket = "osmab-bench"
        urllib.request.urlopen(urllib.request.Request(f"http://127.0.0.1:{self.moto_port}/{self.bucket}", method="PUT"), timeout=30).read()
        self.env = {
            "PATH": os.environ.get("PATH", ""), "RUST_LOG": "warn", "DATABASE_URL": self.database_url,
            "OSMAB_STORAGE_URL": f"s3://{self.bucket}/osmab", "AWS_ENDPOINT_URL": f"http://127.0.0.1:{self.moto_port}",
            "AWS_ACCESS_KEY_ID": "bench", "AWS_SECRET_ACCESS_KEY": "bench", "AWS_REGION": "us-east-1",
            "OSMAB_ADMIN_TOKEN": ADMIN, "OSMAB_RATE_LIMIT": "0", "OSMAB_DAILY_QUOTA": "1000", "OSMAB_MAX_UPLOAD_BYTES": str(8 << 30),
        }
        self.servers = []
        self.workers = []

    def node(self, name, argv, extra):
        data = os.path.join(self.root, name)
        os.makedirs(data)
        return self.spawn(name, [BIN, *argv], dict(self.env, OSMAB_DATA_DIR=data, **extra)), data

    def serve(self, name):
        port = free_port()
        process, data = self.node(name, ["serve"], {"OSMAB_BIND": f"127.0.0.1:{port}", "OSMAB_WORKERS": "0"})
        wait_listening(port, process, self.log(name))
        self.servers.append((name, f"http://127.0.0.1:{port}", process, data))

    def worker(self, name):
        # Workers log at info: the burst counts which worker scored what from their logs.
        process, data = self.node(name, ["worker"], {"RUST_LOG": "info"})
        self.workers.append((name, process, data))



def get_json(url, token=ADMIN):
    req = urllib.request.Request(url)
    req.add_header("Authorization", "Bearer " + token)
    with urllib.request.urlopen(req, timeout=60) as response:
        return json.loads(response.read())


def leaderboard_ids(base):
    return {e["submission_id"] for e in get_json(base + "/api/v1/leaderboard")["entries"]}


def first_start(deployment):
    """Server A, then B, then two workers; seconds until both boards show the five baselines."""
    started = time.time()
    deployment.serve("server-a")
    deployment.serve("server-b")
    deployment.worker("worker-1")
    deployment.worker("worker-2")
    while True:
        try:
            if all(len(leaderboard_ids(base)) >= 5 for _, base, _, _ in deployment.servers):
                return round(time.time() - started, 1)
        except (OSError, KeyError, ValueError):
            pass
        if time.time() - started > 900:
            sys.exit("the deployment did not come up with the baselines; logs in " + deployment.root)
        time.sleep(0.5)


def leaderboard_throughput(deployment, args):
    results = {}
    for name, base, _, _ in deployment.servers:
        line = run_bench("http", base + "/api/v1/leaderboard", "--concurrency", str(args.concurrency), "--seconds", str(args.seconds))
        results[name] = parse_http(line) | {"line": line}
    # Both servers at once, half the connections each (the two load generators share the same 2 cores).
    argv = [[XTASK, "http", base + "/api/v1/leaderboard", "--concurrency", str(args.concurrency // 2), "--seconds", str(args.seconds)]
            for _, base, _, _ in deployment.servers]
    runs = [subprocess.Popen(a, stdout=subprocess.PIPE, text=True) for a in argv]
    lines = [r.communicate()[0].strip() for r in runs]
    both = [parse_http(l) for l in lines]
    results["both"] = {"requests_per_s": round(sum(b["requests_per_s"] for b in both)), "p99_ms": max(b["p99_ms"] for b in both),
                       "errors": sum(b["errors"] for b in both), "lines": lines}
    print(f"both servers at once: {results['both']['requests_per_s']} req/s", flush=True)
    return results


def tus(base, token, method, path, headers=None, body=None):
    parsed = urllib.parse.urlsplit(base)
    connection = http.client.HTTPConnection(parsed.hostname, parsed.port, timeout=600)
    all_headers = {"Authorization": "Bearer " + token, "Tus-Resumable": "1.0.0"} | (headers or {})
    connection.request(method, path, body=body, headers=all_headers)
    response = connection.getresponse()
    payload = response.read()
    connection.close()
    if response.status >= 300:
        sys.exit(f"{method} {path}: {response.status} {payload[:500]!r}")
    return response


def resumable_upload(deployment, token, size, chunk):
    """A `size`-byte tus upload in `chunk`-byte PATCHes alternating between the servers; MB/s of the PATCHes."""
    bases = [base for _, base, _, _ in deployment.servers]
    created = tus(bases[0], token, "POST", "/api/v1/uploads", {"Upload-Length": str(size)})
    path = urllib.parse.urlsplit(created.getheader("Location")).path
    block = os.urandom(chunk)
    offset = 0
    started = time.time()
    per_server = [0.0, 0.0]
    while offset < size:
        part = block[: min(chunk, size - offset)]
        which = (offset // chunk) % 2
        t = time.time()
        answer = tus(bases[which], token, "PATCH", path, {"Upload-Offset": str(offset), "Content-Type": "application/offset+octet-stream"}, part)
        per_server[which] += time.time() - t
        offset = int(answer.getheader("Upload-Offset"))
    seconds = time.time() - started
    tus(bases[1], token, "DELETE", path)
    mb_s = size / seconds / 1e6
    print(f"resumable upload of {size / 1e6:.0f} MB in {chunk >> 20} MiB chunks through both servers: {mb_s:.0f} MB/s", flush=True)
    return {"bytes": size, "chunk_bytes": chunk, "seconds": round(seconds, 2), "mb_per_s": round(mb_s, 1)}


def bucket_put_get(deployment, size, chunk):
    """The bucket alone: `size` bytes PUT straight to moto as `chunk`-byte objects (osmab's part size) and read
    back, on one connection each way — the ceiling under the servers."""
    parsed = urllib.parse.urlsplit(f"http://127.0.0.1:{deployment.moto_port}")
    block = os.urandom(chunk)
    count = max(1, size // chunk)
    connection = http.client.HTTPConnection(parsed.hostname, parsed.port, timeout=600)
    started = time.time()
    for i in range(count):
        connection.request("PUT", f"/{deployment.bucket}/bench/direct-{i}", body=block)
        response = connection.getresponse()
        response.read()
        if response.status != 200:
            sys.exit(f"moto refused a PUT: {response.status}")
    put = count * chunk / (time.time() - started) / 1e6
    started = time.time()
    for i in range(count):
        connection.request("GET", f"/{deployment.bucket}/bench/direct-{i}")
        response = connection.getresponse()
        while response.read(1 << 20):
            pass
    got = count * chunk / (time.time() - started) / 1e6
    connection.close()
    print(f"moto alone, {count} objects of {chunk >> 20} MiB: PUT {put:.0f} MB/s, GET {got:.0f} MB/s", flush=True)
    return {"bytes": count * chunk, "object_bytes": chunk, "put_mb_per_s": round(put, 1), "get_mb_per_s": round(got, 1)}


def large_release(deployment, size):
    """A copy of the demo release with one extra `size`-byte file, imported through server A and published."""
    cached = cached_release(deployment)
    target = os.path.join(deployment.root, "bench-release")
    shutil.copytree(cached, target)
    manifest_path = os.path.join(target, "manifest.json")
    manifest = json.load(open(manifest_path))
    missing = [f["path"] for f in manifest["files"] if not os.path.exists(os.path.join(target, f["path"]))]
    if missing:
        # The node cache keeps only what scoring reads; the frames and archives stay in the bucket.
        base = deployment.servers[0][1]
        for path in missing:
            os.makedirs(os.path.dirname(os.path.join(target, path)), exist_ok=True)
            with urllib.request.urlopen(f"{base}/api/v1/releases/{manifest['version']}/files/{path}", timeout=600) as r, open(os.path.join(target, path), "wb") as f:
                shutil.copyfileobj(r, f, 1 << 20)
    version, _, sha256 = add_large_file(target, size)
    started = time.time()
    request(deployment.servers[0][1], "POST", "/api/v1/admin/releases/import", {"path": target, "publish": True})
    seconds = time.time() - started
    shutil.rmtree(target)
    return version, sha256, seconds


def cached_release(deployment):
    """A worker's node-local copy of the current release (ground truth, questions, manifest)."""
    for _, _, data in deployment.workers:
        releases = os.path.join(data, "cache", "releases")
        if os.path.isdir(releases):
            names = [n for n in os.listdir(releases) if not n.startswith(".")]
            if names:
                return os.path.join(releases, sorted(names)[0])
    sys.exit("no worker has cached the release")


def oracle_archives(deployment):
    """A function giving the oracle baseline as a tar under a method name of its own (the
    service answers a repeated archive with the submission it already has)."""
    out = os.path.join(deployment.root, "oracle")
    subprocess.run([BIN, "baseline", "oracle", "--release", cached_release(deployment), "--out", out], check=True, capture_output=True)
    card = json.load(open(os.path.join(out, "submission.json")))

    def archive(name):
        card["method"]["name"] = name
        json.dump(card, open(os.path.join(out, "submission.json"), "w"))
        buffer = io.BytesIO()
        with tarfile.open(fileobj=buffer, mode="w") as tar:
            for entry in sorted(os.listdir(out)):
                tar.add(os.path.join(out, entry), arcname=entry)
        return buffer.getvalue()

    return archive


def submit(base, token, archive):
    req = urllib.request.Request(base + "/api/v1/submissions", data=archive, method="POST")
    req.add_header("Authorization", "Bearer " + token)
    req.add_header("Content-Type", "application/x-tar")
    with urllib.request.urlopen(req, timeout=600) as response:
        return json.loads(response.read())["id"]


def wait_scored(base, token, ident):
    while True:
        view = get_json(f"{base}/api/v1/submissions/{ident}", token)
        if view["state"] in ("scored", "failed", "cancelled"):
            if view["state"] != "scored":
                sys.exit(f"submission {ident} ended {view['state']}: {json.dumps(view)[:800]}")
            return time.time()
        time.sleep(0.02)


def wait_on_board(base, ident):
    while ident not in leaderboard_ids(base):
        time.sleep(0.02)
    return time.time()


def upload_to_score(deployment, token, archives, rounds):
    """One submission at a time: uploaded through one server, watched through the other."""
    bases = [base for _, base, _, _ in deployment.servers]
    rows = []
    for i in range(rounds):
        through, watch = bases[i % 2], bases[(i + 1) % 2]
        archive = archives(f"bench oracle {i}")
        started = time.time()
        ident = submit(through, token, archive)
        accepted = time.time()
        scored = wait_scored(watch, token, ident)
        shown = wait_on_board(watch, ident)
        rows.append({"upload_s": round(accepted - started, 3), "accepted_to_scored_s": round(scored - accepted, 3),
                     "scored_to_other_board_s": round(shown - scored, 3), "upload_to_other_board_s": round(shown - started, 3)})
        print(f"round {i}: {rows[-1]}", flush=True)
    return {"archive_bytes": len(archive), "rounds": rows,
            "median_upload_to_other_board_s": statistics.median(r["upload_to_other_board_s"] for r in rows),
            "median_accepted_to_scored_s": statistics.median(r["accepted_to_scored_s"] for r in rows),
            "max_scored_to_other_board_s": max(r["scored_to_other_board_s"] for r in rows)}


def burst(deployment, token, archives, count):
    """`count` submissions at once through both servers; seconds until all are scored, and who scored them."""
    bases = [base for _, base, _, _ in deployment.servers]
    tars = [archives(f"bench burst {i}") for i in range(count)]
    idents = [None] * count

    def send(i):
        idents[i] = submit(bases[i % 2], token, tars[i])

    threads = [threading.Thread(target=send, args=(i,)) for i in range(count)]
    started = time.time()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if None in idents:
        sys.exit("an upload of the burst failed")
    uploaded = time.time()
    for ident in idents:
        wait_scored(bases[0], token, ident)
    done = time.time()
    by_worker = {}
    for name, _, _ in deployment.workers:
        log = open(deployment.log(name)).read()
        by_worker[name] = sum(1 for ident in idents if ident in log)
    print(f"{count} at once: uploaded in {uploaded - started:.2f} s, all scored {done - started:.2f} s after the first upload; {by_worker}", flush=True)
    return {"submissions": count, "upload_s": round(uploaded - started, 2), "all_scored_s": round(done - started, 2), "mentions_in_worker_logs": by_worker}


def download(deployment, version, path, sha256, size):
    results = {}
    for name, base, _, _ in deployment.servers:
        url = f"{base}/api/v1/releases/{version}/files/{path}"
        lines = [run_bench("download", url) for _ in range(3)]
        speeds = sorted(float(l.split("=")[1].split()[0]) for l in lines)
        results[name] = {"median_mb_per_s": speeds[1], "lines": lines}
    # One through B checked byte for byte.
    digest = hashlib.sha256()
    with urllib.request.urlopen(f"{deployment.servers[1][1]}/api/v1/releases/{version}/files/{path}", timeout=600) as response:
        while block := response.read(1 << 20):
            digest.update(block)
    if digest.hexdigest() != sha256:
        sys.exit("the file downloaded through server B differs from the one imported through A")
    results["sha256_matches"] = True
    results["bytes"] = size
    return results


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--database-url", default="postgres://postgres@127.0.0.1:5432/postgres")
    parser.add_argument("--moto", default=os.path.join(ROOT, "target", "pyenv", "bin", "moto_server"))
    parser.add_argument("--concurrency", type=int, default=64)
    parser.add_argument("--seconds", type=float, default=10)
    parser.add_argument("--upload-bytes", type=int, default=1 << 30)
    parser.add_argument("--chunk-bytes", type=int, default=8 << 20)
    parser.add_argument("--download-bytes", type=int, default=1 << 30)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--burst", type=int, default=8)
    parser.add_argument("--keep", action="store_true", help="keep the logs and data directories")
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    for binary in (BIN, XTASK, args.moto):
        if not os.path.exists(binary):
            sys.exit(f"{binary} is missing (see this program's help)")

    deployment = Deployment(args)
    results = {"machine": os.uname().machine, "cores": os.cpu_count(), "date": time.strftime("%Y-%m-%d"),
               "layout": "2 servers (OSMAB_WORKERS=0) + 2 workers, separate data directories, PostgreSQL, moto S3"}
    try:
        results["first_start_to_both_boards_s"] = first_start(deployment)
        print(f"both leaderboards populated after {results['first_start_to_both_boards_s']} s", flush=True)
        results["leaderboard"] = leaderboard_throughput(deployment, args)
        team = request(deployment.servers[0][1], "POST", "/api/v1/admin/teams", {"name": "bench team"})
        archives = oracle_archives(deployment)
        results["upload_to_score"] = upload_to_score(deployment, team["token"], archives, args.rounds)
        results["burst"] = burst(deployment, team["token"], archives, args.burst)
        results["bucket_alone"] = bucket_put_get(deployment, min(args.upload_bytes, 256 << 20), args.chunk_bytes)
        results["resumable_upload"] = resumable_upload(deployment, team["token"], args.upload_bytes, args.chunk_bytes)
        version, sha256, import_s = large_release(deployment, args.download_bytes)
        results["import_large_release_s"] = round(import_s, 1)
        results["download"] = download(deployment, version, "extras/large.bin", sha256, args.download_bytes)
    finally:
        deployment.close(args.keep)
    if args.out:
        json.dump(results, open(args.out, "w"), indent=2)
        print("wrote", args.out)


if __name__ == "__main__":
    main()

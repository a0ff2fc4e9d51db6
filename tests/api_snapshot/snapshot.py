#!/usr/bin/env python3
"""A snapshot of every JSON answer of the API, to show that a refactoring changed none.

Runs one scenario against an `osmab` binary — import a release, create a team, upload the
oracle and a degraded baseline (plus a dry run and a repeat), wait for both scores, re-score
one, edit a method card — then requests every JSON route (public, team and admin) and the pages, and writes
the answers with ids, tokens, timestamps and durations replaced by stable placeholders:

    python3 tests/api_snapshot/snapshot.py --bin target/debug/osmab --release target/tmp/e2e-release/release --out new.json
    python3 tests/api_snapshot/snapshot.py --bin OLD_BUILD/osmab --release target/tmp/e2e-release/release --out old.json
    python3 tests/api_snapshot/snapshot.py --compare old.json new.json

`--compare` reports every difference of value (key order is not a difference in JSON).
Standard library only.
"""

from __future__ import annotations

import argparse
import hashlib
import base64
import io
import json
import os
import re
import socket
import subprocess
import sys
import tarfile
import tempfile
import time
import urllib.error
import urllib.request

ADMIN = "osmab_snapshotadmintoken000000000000"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    def __init__(self, binary: str, data: str):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        env = dict(os.environ, OSMAB_DATA_DIR=data, OSMAB_ADMIN_TOKEN=ADMIN, OSMAB_DEMO="false", OSMAB_POLL_MS="50",
                   OSMAB_RATE_LIMIT="0", OSMAB_BIND=f"127.0.0.1:{self.port}", RUST_LOG="warn")
        self.process = subprocess.Popen([binary, "serve"], env=env, stdout=subprocess.DEVNULL, stderr=open(os.path.join(data, "serve.log"), "w"))
        for _ in range(200):
            try:
                if self.request("GET", "/livez")[0] == 200:
                    return
            except OSError:
                pass
            time.sleep(0.05)
        raise SystemExit("the server did not start")

    def request(self, method: str, path: str, token: str | None = None, body: bytes | None = None, headers: dict | None = None):
        request = urllib.request.Request(self.url + path, method=method, data=body, headers=dict(headers or {}))
        if token:
            request.add_header("Authorization", f"Bearer {token}")
        try:
            with urllib.request.urlopen(request, timeout=60) as response:
                return response.status, response.read()
        except urllib.error.HTTPError as e:
            return e.code, e.read()

    def json(self, method: str, path: str, token: str | None = None, payload=None, raw: bytes | None = None, headers=None):
        body = raw if raw is not None else (json.dumps(payload).encode() if payload is not None else None)
        hdrs = dict(headers or {})
        if payload is not None:
            hdrs["Content-Type"] = "application/json"
        status, data = self.request(method, path, token, body, hdrs)
        try:
            return status, json.loads(data)
        except ValueError:
            return status, data.decode(errors="replace")

    def stop(self):
        self.process.terminate()
        self.process.wait(timeout=30)


def tar_of(folder: str) -> bytes:
    out = io.BytesIO()
    with tarfile.open(fileobj=out, mode="w", format=tarfile.USTAR_FORMAT) as tar:
        for root, _, files in sorted(os.walk(folder)):
            for name in sorted(files):
                path = os.path.join(root, name)
                info = tar.gettarinfo(path, arcname=os.path.relpath(path, folder))
                info.mtime, info.uid, info.gid, info.uname, info.gname = 0, 0, 0, "", ""
                with open(path, "rb") as f:
                    tar.addfile(info, f)
    return out.getvalue()


def upload(server: Server, token: str, archive: bytes, query: str = "", key: str | None = None):
    digest = base64.b64encode(hashlib.sha256(archive).digest()).decode()
    headers = {"Content-Type": "application/x-tar", "Content-Digest": f"sha-256=:{digest}:"}
    if key:
        headers["Idempotency-Key"] = key
    return server.json("POST", f"/api/v1/submissions{query}", token, raw=archive, headers=headers)


def wait_done(server: Server, token: str, sid: str):
    for _ in range(1200):
        _, view = server.json("GET", f"/api/v1/submissions/{sid}", token)
        if view.get("state") in ("scored", "failed", "cancelled") and not any(j["state"] in ("queued", "running") for j in view.get("jobs", [])):
            return view
        time.sleep(0.1)
    raise SystemExit(f"{sid} did not finish")


TIMESTAMP = re.compile(r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?Z$")
VOLATILE_KEYS = {"run_after", "created_at", "updated_at", "at", "registered_at", "published_at", "submitted_at", "resets_at", "expires_at", "revoked_at"}


def normalise(value, names: dict):
    """Ids, tokens and hints by first appearance; timestamps, worker names and the server's port dropped."""
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            if k in VOLATILE_KEYS and isinstance(v, str) and TIMESTAMP.match(v):
                out[k] = "<time>"
            elif k == "hint" and isinstance(v, str):
                out[k] = v[:6] + "<random>"
            elif k == "lease":
                out[k] = None if v is None else "<lease>"
            elif k == "progress" and isinstance(v, dict):
                out[k] = {kk: vv for kk, vv in normalise(v, names).items() if kk not in ("message",)}
            else:
                out[k] = normalise(v, names)
        return out
    if isinstance(value, list):
        return [normalise(v, names) for v in value]
    if isinstance(value, str):
        def name_of(match):
            token = match.group(0)
            names.setdefault(token, f"<{token.split('_')[0]}#{len(names)}>")
            return names[token]
        value = re.sub(r"\b(sub|job|team|tok|osmab)_[A-Za-z0-9]{8,}\b", name_of, value)
        value = re.sub(r"//127\.0\.0\.1:\d+", "//127.0.0.1:<port>", value)
        return re.sub(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d+)?Z", "<time>", value)
    return value


def scenario(binary: str, release: str) -> dict:
    data = tempfile.mkdtemp(prefix="osmab-snapshot-")
    server = Server(binary, data)
    answers = {}
    try:
        def keep(name, status_and_body):
            answers[name] = {"status": status_and_body[0], "body": status_and_body[1]}
            return status_and_body[1]

        keep("POST /api/v1/admin/releases/import", server.json("POST", "/api/v1/admin/releases/import", ADMIN, {"path": release, "publish": True}))
        team = keep("POST /api/v1/admin/teams", server.json("POST", "/api/v1/admin/teams", ADMIN, {"name": "Team Snapshot"}))
        token = team["token"]
        archives = {}
        for name in ("oracle", "merge"):
            folder = os.path.join(data, f"baseline-{name}")
            subprocess.run([binary, "baseline", name, "--release", release, "--out", folder], check=True, stdout=subprocess.DEVNULL)
            # Method names starting with "baseline" are the service's own: upload as a team's.
            card_path = os.path.join(folder, "submission.json")
            with open(card_path) as f:
                card = json.load(f)
            card["method"]["name"] = f"team-{name}"
            with open(card_path, "w") as f:
                json.dump(card, f, indent=2)
            archives[name] = tar_of(folder)
        keep("POST /api/v1/submissions?dry_run=true", upload(server, token, archives["merge"], "?dry_run=true"))
        oracle = keep("POST /api/v1/submissions (oracle)", upload(server, token, archives["oracle"], key="snapshot-oracle"))
        wait_done(server, token, oracle["id"])
        # Once scored, so the repeat's answer does not depend on the worker's timing.
        keep("POST /api/v1/submissions (repeat)", upload(server, token, archives["oracle"], key="snapshot-oracle"))
        merge = keep("POST /api/v1/submissions (merge)", upload(server, token, archives["merge"]))
        wait_done(server, token, merge["id"])
        keep("POST rescore", server.json("POST", f"/api/v1/admin/submissions/{merge['id']}/rescore", ADMIN))
        view = wait_done(server, token, merge["id"])
        keep("PATCH /api/v1/submissions/{merge}", server.json("PATCH", f"/api/v1/submissions/{merge['id']}", token, {"name": "Merged classes", "paper_url": "https://example.org/p"}))
        version = answers["POST /api/v1/admin/releases/import"]["body"]["version"]
        reads = [
            ("/livez", None), ("/readyz", None), ("/api/v1/releases", None), (f"/api/v1/releases/{version}", None),
            (f"/api/v1/releases/{version}/manifest.json", None), ("/api/v1/leaderboard", None), ("/api/v1/leaderboard/vqa", None),
            ("/api/v1/leaderboard/vqa?table=2", None), ("/api/v1/leaderboard/vqa?table=3", None),
            ("/api/v1/me", token), ("/api/v1/submissions", token), (f"/api/v1/submissions/{oracle['id']}", token),
            (f"/api/v1/submissions/{merge['id']}", None), (f"/api/v1/jobs/{view['jobs'][0]['id']}", token),
            (f"/api/v1/jobs/{view['jobs'][0]['id']}", ADMIN), ("/api/v1/admin/teams", ADMIN),
            (f"/api/v1/admin/teams/{team['id']}/tokens", ADMIN), ("/api/v1/admin/submissions", ADMIN), ("/api/v1/admin/jobs", ADMIN),
            ("/api/v1/leaderboard.csv", None), ("/api/v1/leaderboard/vqa.csv?table=2", None), ("/api/v1/leaderboard/vqa.csv?table=3", None),
            ("/api/v1/submissions/nope", None), ("/api/v1/leaderboard?release=nope", None), ("/api/v1/admin/teams", token),
            ("/api/v1/quota", token), ("/api/v1/keys", None), ("/api/v1/nowhere", None), ("/api/v1/openapi.json", None), ("/api/docs", None),
            # The pages, as HTML text.
            ("/", None), ("/?agg=overall_mean&subset=manipuland&sort=camera.macc", None), ("/?sort=bogus.x&agg=zzz", None),
            (f"/submissions/{oracle['id']}", token), (f"/releases/{version}", None), ("/about", None),
        ]
        for path, who in reads:
            label = f"GET {path}" + (" (admin)" if who == ADMIN else " (team)" if who else "")
            keep(label, server.json("GET", path, who))
        keep("PATCH /api/v1/admin/teams/{id}", server.json("PATCH", f"/api/v1/admin/teams/{team['id']}", ADMIN, {"daily_quota": 7}))
        keep("POST /api/v1/admin/teams/{id}/tokens", server.json("POST", f"/api/v1/admin/teams/{team['id']}/tokens", ADMIN, {"expires_in_days": 3}))
        keep("POST cancel (scored)", server.json("POST", f"/api/v1/submissions/{merge['id']}/cancel", token))
    finally:
        server.stop()
    names: dict = {}
    out = {}
    for k, v in answers.items():
        body = normalise(v, names)
        out[normalise(k, names)] = body
    return out


def differences(a, b, at="$"):
    if type(a) is not type(b) and not (isinstance(a, (int, float)) and isinstance(b, (int, float))):
        return [f"{at}: {json.dumps(a)[:200]} → {json.dumps(b)[:200]}"]
    if isinstance(a, dict):
        out = []
        for k in sorted(set(a) | set(b)):
            if k not in a:
                out.append(f"{at}.{k}: added {json.dumps(b[k])[:200]}")
            elif k not in b:
                out.append(f"{at}.{k}: removed {json.dumps(a[k])[:200]}")
            else:
                out.extend(differences(a[k], b[k], f"{at}.{k}"))
        return out
    if isinstance(a, list):
        if len(a) != len(b):
            return [f"{at}: {len(a)} items → {len(b)} items"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in differences(x, y, f"{at}[{i}]")]
    return [] if a == b else [f"{at}: {json.dumps(a)[:200]} → {json.dumps(b)[:200]}"]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bin")
    parser.add_argument("--release")
    parser.add_argument("--out")
    parser.add_argument("--compare", nargs=2, metavar=("OLD", "NEW"))
    args = parser.parse_args()
    if args.compare:
        old, new = (json.load(open(p)) for p in args.compare)
        found = differences(old, new)
        print("\n".join(found) if found else f"no difference in {len(old)} answers")
        sys.exit(1 if found else 0)
    snapshot = scenario(os.path.abspath(args.bin), os.path.abspath(args.release))
    with open(args.out, "w") as f:
        json.dump(snapshot, f, indent=1, sort_keys=True)
    print(f"{len(snapshot)} answers written to {args.out}")


if __name__ == "__main__":
    main()

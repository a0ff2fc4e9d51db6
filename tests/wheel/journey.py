#!/usr/bin/env python3
"""A team's journey with the pip-installed client, against a real `osmab serve`.

Installs the osmab-client wheel into a fresh virtualenv (its one dependency, NumPy, from
PyPI), then plays a team that has nothing but that virtualenv and a token:

    osmab-client login → quota → download (baseline lighting) → osmab-export init,
    text-features and conceptgraphs (a ConceptGraphs-shaped pickle, every scene) → osmab-client
    validate (offline, scored on the val scenes) → for each split of the release, the hidden
    test split first: submit --watch (until scored) → status, results, receipt --verify,
    leaderboard

The service is the repository's `osmab serve` (OSMAB_BIN) on a free port with a fresh data
folder, the release the cargo tests built (OSMAB_TEST_RELEASE) imported by the operator, and
the team made by the operator with `osmab admin team create`. With a release that has a test
split (the cargo tests' e2e-split-release), the team ends with a verified receipt of a score on
the hidden test scenes. Every installed command runs
from the virtualenv's bin folder with a PATH that holds nothing of the repository.

    python3 tests/wheel/journey.py --wheel target/wheels/osmab_client-*.whl \\
        --osmab target/debug/osmab --release target/tmp/e2e-split-release/release

Exit status 0 when every step did what a team expects, 1 with the failing step otherwise.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.request
import venv
from pathlib import Path

ADMIN_TOKEN = "osmab_wheeljourneyadmin000000000000000"


# Print what the client said at each split (--show), to read it as a team would.
SHOW = False


class StepFailed(Exception):
    pass


def step(title):
    print(f"-- {title}", flush=True)


def run(argv, env, cwd, expect=0, timeout=600):
    """Run one command; its output, and a failure naming it when the status is not `expect`."""
    done = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True, timeout=timeout)
    if done.returncode != expect:
        raise StepFailed(f"{' '.join(map(str, argv))} exited {done.returncode} (expected {expect})\n{done.stdout}\n{done.stderr}")
    return done.stdout + done.stderr


def expect_in(text, needle, what):
    if needle not in text:
        raise StepFailed(f"{what}: expected {needle!r} in\n{text}")


def install(wheel, root):
    """A fresh virtualenv with the wheel installed; its bin folder."""
    env_dir = root / "venv"
    venv.EnvBuilder(with_pip=True, clear=True).create(env_dir)
    bin_dir = env_dir / "bin"
    subprocess.run([bin_dir / "python", "-m", "pip", "install", "-q", str(wheel)], check=True)
    return bin_dir


class Service:
    """`osmab serve` on a free port with a fresh data folder, demo off."""

    def __init__(self, osmab, data):
        env = {k: v for k, v in os.environ.items() if not k.startswith("OSMAB_")}
        env.update(
            OSMAB_DATA_DIR=str(data), OSMAB_BIND="127.0.0.1:0", OSMAB_DEMO="false", OSMAB_ADMIN_TOKEN=ADMIN_TOKEN,
            OSMAB_POLL_MS="50", OSMAB_RATE_LIMIT="0", OSMAB_SHUTDOWN_GRACE_SECS="5",
        )
        self.env = env
        self.log = open(data.parent / "serve.log", "w")
        self.proc = subprocess.Popen([str(osmab), "serve"], env=env, stdout=subprocess.PIPE, stderr=self.log, text=True)
        line = self.proc.stdout.readline().strip()
        if not line.startswith("osmab listening on "):
            raise StepFailed(f"osmab serve did not start: {line!r} (log: {data.parent / 'serve.log'})")
        self.url = line.removeprefix("osmab listening on ")

    def admin(self, method, path, body):
        request = urllib.request.Request(
            self.url + path, method=method, data=json.dumps(body).encode(),
            headers={"authorization": f"Bearer {ADMIN_TOKEN}", "content-type": "application/json"},
        )
        with urllib.request.urlopen(request, timeout=600) as response:
            return json.load(response)

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.log.close()


# What a team's own ConceptGraphs run leaves behind, made with the virtualenv's NumPy (the
# wheel's dependency): a map pickle of three objects with points and CLIP features, and the
# class-name embeddings the exporter turns into text features.
METHOD_OUTPUTS = """
import gzip, pickle, sys
import numpy as np
home, classes = sys.argv[1], int(sys.argv[2])
rng = np.random.default_rng(7)
objects = []
for i in range(3):
    feature = np.zeros(16, dtype=np.float32)
    feature[(i + 3) % classes] = 1.0
    objects.append({"pcd_np": rng.uniform(-1.0, 1.0, size=(200, 3)) + [0.0, 1.0, 0.0], "clip_ft": feature, "class_name": ["item"]})
with gzip.open(f"{home}/cg.pkl.gz", "wb") as f:
    pickle.dump({"objects": objects}, f)
np.save(f"{home}/emb.npy", np.eye(classes, 16, dtype=np.float32) + 0.01)
"""


def journey(args, root):
    step("install the wheel into a fresh virtualenv")
    bin_dir = install(args.wheel, root)
    home = root / "home"
    home.mkdir()
    # The team's shell: the virtualenv's commands and the system's, nothing of the repository.
    env = {"PATH": f"{bin_dir}:/usr/bin:/bin", "HOME": str(home), "LANG": "C.UTF-8"}
    client, export = str(bin_dir / "osmab-client"), str(bin_dir / "osmab-export")
    expect_in(run([client, "--version"], env, home), "osmab-client", "the client's version")
    expect_in(run([client, "--help"], env, home), "submit", "the client's commands")
    expect_in(run([export, "--help"], env, home), "conceptgraphs", "the exporter's commands")

    step("start osmab serve; the operator imports the release and makes a team")
    service = Service(args.osmab, root / "data")
    try:
        version = service.admin("POST", "/api/v1/admin/releases/import", {"path": str(args.release), "publish": True})["version"]
        made = run([str(args.osmab), "admin", "team", "create", "Wheel Journey", "--url", service.url], service.env, root)
        token = next(word for word in made.split() if word.startswith("osmab_"))
        team_journey(bin_dir, env, home, service.url, token, version)
    finally:
        service.stop()


def team_journey(bin_dir, env, home, url, token, version):
    client, export = str(bin_dir / "osmab-client"), str(bin_dir / "osmab-export")
    step("log in, download the release's baseline sequences")
    run([client, "login", "--url", url, "--token", token], env, home)
    expect_in(run([client, "quota"], env, home), "Wheel Journey", "the quota names the team")
    release = home / "release"
    run([client, "download", "--out", str(release), "--lighting", "baseline"], env, home)
    manifest = json.loads((release / "manifest.json").read_text())
    if manifest["version"] != version:
        raise StepFailed(f"downloaded release {manifest['version']}, the service's is {version}")
    classes = json.loads((release / "classes.json").read_text())["classes"]

    step("export a ConceptGraphs map with osmab-export")
    sub = home / "sub"
    run([export, "init", "--out", str(sub), "--release", version, "--method", "Wheel journey"], env, home)
    run([str(bin_dir / "python"), "-c", METHOD_OUTPUTS, str(home), str(len(classes))], env, home)
    run([export, "text-features", "--classes", str(release / "classes.json"), "--embeddings", str(home / "emb.npy"), "--out", str(sub)], env, home)
    # The method mapped every scene under the baseline lighting (test scenes included: a
    # team maps them from their frames, and only the service scores them).
    for scene in (s["id"] for s in manifest["scenes"]):
        run([export, "conceptgraphs", "--map", str(home / "cg.pkl.gz"), "--lighting", "baseline", "--scene", scene, "--out", str(sub)], env, home)
        if not (sub / "maps" / "baseline" / f"{scene}.npz").is_file():
            raise StepFailed(f"osmab-export wrote no map for {scene}")

    step("validate offline (scores the val scenes), then submit to each split and follow it until scored")
    expect_in(run([client, "validate", str(sub), "--release-dir", str(release)], env, home), "Valid for the", "offline validation")
    splits = sorted({s["split"] for s in manifest["scenes"]}, key=lambda split: split != "test")  # the main board first
    for split in splits:
        submitted = run([client, "submit", str(sub), "--split", split, "--watch"], env, home)
        expect_in(submitted, "scored", f"submit --split {split} --watch")
        sid = next(word.strip(".,:;`") for word in submitted.split() if word.startswith("sub_"))
        expect_in(run([client, "status", sid], env, home), "scored", "status")
        expect_in(run([client, "results", sid], env, home), "baseline", "results")
        receipt = run([client, "receipt", sid, "--verify"], env, home)
        if SHOW:
            print(submitted, receipt, run([client, "leaderboard", "--split", split], env, home), sep="\n")
        expect_in(receipt, f"Valid receipt issued by {url} for submission {sid}", f"receipt --verify of the {split} submission")
        expect_in(receipt, "(matches the results file)", "receipt --verify checks the results")
        expect_in(run([client, "leaderboard", "--split", split], env, home), "Wheel journey", f"the {split} board lists the method")
        step(f"{split}: {sid} scored, its receipt verified, on the {split} board")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--wheel", required=True, type=Path)
    ap.add_argument("--osmab", required=True, type=Path, help="the service's binary (osmab serve, osmab admin)")
    ap.add_argument("--release", required=True, type=Path, help="a built release folder the operator imports")
    ap.add_argument("--keep", action="store_true", help="keep the scratch folder (its path is printed)")
    ap.add_argument("--show", action="store_true", help="print what submit, receipt and leaderboard said")
    args = ap.parse_args()
    global SHOW
    SHOW = args.show
    args.wheel, args.osmab, args.release = (path.resolve() for path in (args.wheel, args.osmab, args.release))
    root = Path(tempfile.mkdtemp(prefix="osmab-wheel-journey-"))
    try:
        journey(args, root)
    except (StepFailed, OSError, subprocess.CalledProcessError, subprocess.TimeoutExpired) as e:
        print(f"FAIL: {e}", file=sys.stderr)
        args.keep = True
        return 1
    finally:
        if args.keep:
            print(f"scratch kept in {root}", file=sys.stderr)
        else:
            shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Benchmark `osmab eval semseg` against the NumPy/SciPy reference (bench/reference_semseg.py).

Usage (from the repo root, system python3, stdlib only):
    python3 bench/semseg_vs_scipy.py [--sizes 5000000x1000000,20000000x2000000]
                                     [--repeat 3] [--out docs/performance-semseg.json]

Steps: make bench/.venv with numpy + scipy; `cargo build --release -p osmab`; for each
size GxP (G ground-truth points, P map points) generate bench/data/GxP with
`osmab bench synth` unless it holds a `.complete` marker; run the Rust evaluator and the
reference alternately --repeat times, timing wall clock and peak RSS (os.wait4); check that
both produce the same confusion matrix; print a Markdown table and write raw results to --out.
"""
import argparse
import json
import os
import platform
import shlex
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = Path("bench/.venv")
VENV_PY = VENV / "bin" / "python"
OSMAB = Path("target/release/osmab")
REF = Path("bench/reference_semseg.py")
REF_UNSET = ("OPENBLAS_CORETYPE", "OPENBLAS_L2_SIZE")  # slow a current numpy on this machine
METRICS = ("miou", "fmiou", "macc")


def ensure_venv():
    """Create bench/.venv if missing, install numpy + scipy, return their versions."""
    if not VENV_PY.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
    pip = subprocess.run([str(VENV_PY), "-m", "pip", "install", "-q", "numpy", "scipy"],
                         capture_output=True, text=True)
    if pip.returncode != 0:
        sys.exit(f"error: `pip install numpy scipy` into {VENV} failed:\n{pip.stdout}{pip.stderr}")
    out = subprocess.run([str(VENV_PY), "-c", "import numpy, scipy; print(numpy.__version__, scipy.__version__)"],
                         check=True, capture_output=True, text=True).stdout.split()
    return {"numpy": out[0], "scipy": out[1]}


def parse_sizes(text):
    """`GxP` (the room's shell unmapped, as many methods leave it, ground truth frame by
    frame), with variants after `:` joined by `+`: `room` (the map also covers floor, walls
    and ceiling), `random` (the ground-truth points in a random order, as a shuffled or
    voxel-downsampled ground truth arrives) -> [(G, P, covers_room, random_order)]."""
    sizes = []
    for item in text.split(","):
        item, _, variants = item.lower().partition(":")
        flags = set(filter(None, variants.split("+")))
        if flags - {"room", "random"}:
            sys.exit(f"error: unknown size variant(s) {sorted(flags - {'room', 'random'})} (expected room, random)")
        g, p = item.split("x")
        sizes.append((int(g), int(p), "room" in flags, "random" in flags))
    return sizes


def case_name(g, p, covers_room, random_order):
    return f"{g}x{p}" + ("-room" if covers_room else "") + ("-random" if random_order else "")


def run_timed(cmd, env=None):
    """Run cmd; return wall seconds, peak RSS KiB, and the last JSON line of its stderr."""
    with tempfile.TemporaryFile() as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        stderr = err.read().decode(errors="replace")
    if proc.returncode != 0:
        sys.exit(f"error: {shlex.join(map(str, cmd))} exited {proc.returncode}:\n{stderr[-4000:]}")
    timings = None
    for line in stderr.splitlines():
        try:
            parsed = json.loads(line)
        except ValueError:
            continue
        if isinstance(parsed, dict):
            timings = parsed
    if timings is None:
        sys.exit(f"error: no JSON timings line on stderr of {shlex.join(map(str, cmd))}")
    return {"wall_s": wall, "maxrss_kib": usage.ru_maxrss, "timings": timings}


def compare(rust_json, ref_json):
    """Agreement of the two evaluators' outputs."""
    a, b = json.loads(rust_json.read_text()), json.loads(ref_json.read_text())
    res = {"labels_equal": a["labels"] == b["labels"],
           "max_abs_metric_diff": max(abs(a["metrics"][k] - b["metrics"][k]) for k in METRICS),
           "metrics_osmab": a["metrics"], "metrics_scipy": b["metrics"]}
    if res["labels_equal"] and len(a["matrix"]) == len(b["matrix"]):
        diffs = [abs(x - y) for ra, rb in zip(a["matrix"], b["matrix"]) for x, y in zip(ra, rb)]
        res["matrices_equal"] = not any(diffs)
        res["differing_cells"] = sum(d != 0 for d in diffs)
        res["points_labelled_differently"] = sum(diffs) // 2
        res["points_compared"] = sum(map(sum, b["matrix"]))
    else:
        res["matrices_equal"] = False
    return res


def machine():
    info = {"nproc": len(os.sched_getaffinity(0)), "platform": platform.platform()}
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            info["cpu"] = line.split(":", 1)[1].strip()
            break
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemTotal"):
            info["mem_total_gib"] = round(int(line.split()[1]) / 2**20, 1)
    return info


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default="5000000x1000000,5000000x1000000:room,5000000x1000000:random,5000000x1000000:room+random,"
                    "20000000x2000000,20000000x2000000:room,20000000x2000000:random,20000000x2000000:room+random",
                    help="comma-separated GT_POINTSxMAP_POINTS (default: %(default)s)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per tool and size (default: %(default)s)")
    ap.add_argument("--out", default="docs/performance-semseg.json", help="raw results JSON (default: %(default)s)")
    args = ap.parse_args()
    sizes = parse_sizes(args.sizes)
    command = shlex.join(["python3", "bench/semseg_vs_scipy.py", *sys.argv[1:]])
    os.chdir(ROOT)

    versions = ensure_venv()
    subprocess.run(["cargo", "build", "--release", "-p", "osmab"], check=True)
    ref_env = {k: v for k, v in os.environ.items() if k not in REF_UNSET}
    unset = {k: os.environ.get(k) for k in REF_UNSET}  # original values (None = was not set)

    results = []
    for g, p, covers_room, random_order in sizes:
        d = Path("bench/data") / case_name(g, p, covers_room, random_order)
        if not (d / ".complete").exists():
            print(f"generating {d} ...", file=sys.stderr)
            subprocess.run([str(OSMAB), "bench", "synth", "--gt-points", str(g), "--map-points", str(p),
                            *(["--map-covers-room"] if covers_room else []), *(["--shuffle"] if random_order else []),
                            "--out", str(d)], check=True)
            (d / ".complete").touch()
        inputs = ["--gt", str(d / "gt"), "--map", str(d / "map.npz"),
                  "--text-features", str(d / "text_features.npz")]
        out_rust, out_ref = d / "out-osmab.json", d / "out-scipy.json"
        runs = {"osmab": [], "scipy": []}
        for i in range(args.repeat):
            print(f"{d.name}: run {i + 1}/{args.repeat}", file=sys.stderr)
            runs["osmab"].append(run_timed([str(OSMAB), "eval", "semseg", *inputs,
                                            "--json", str(out_rust), "--timings"]))
            runs["scipy"].append(run_timed([str(VENV_PY), str(REF), *inputs,
                                            "--json", str(out_ref), "--timings"], env=ref_env))
        nn = {"osmab": [r["timings"]["nearest_s"] for r in runs["osmab"]],
              "scipy": [r["timings"]["tree_build_s"] + r["timings"]["query_s"] for r in runs["scipy"]]}
        summary = {stage: {tool: statistics.median(vals[tool]) for tool in runs}
                   for stage, vals in (("nearest-neighbour association", nn),
                                       ("whole eval semseg", {t: [r["wall_s"] for r in runs[t]] for t in runs}))}
        peak = {t: max(r["maxrss_kib"] for r in runs[t]) / 1024 for t in runs}
        results.append({"gt_points": g, "map_points": p, "map_covers_room": covers_room, "random_order": random_order,
                        "runs": runs, "median_s": summary,
                        "peak_rss_mib": peak, "agreement": compare(out_rust, out_ref)})

    lines = ["| size | stage | osmab median s | SciPy median s | speed-up | osmab peak RSS MiB | SciPy peak RSS MiB |",
             "|---|---|---:|---:|---:|---:|---:|"]
    for r in results:
        size = f"{r['gt_points']:,} GT × {r['map_points']:,} map" + (
            ", map covers the room" if r["map_covers_room"] else ", room shell unmapped") + (
            ", GT in random order" if r.get("random_order") else ", GT frame by frame")
        for stage, med in r["median_s"].items():
            lines.append(f"| {size} | {stage} | {med['osmab']:.3f} | {med['scipy']:.3f} | "
                         f"{med['scipy'] / med['osmab']:.1f}× | {r['peak_rss_mib']['osmab']:.0f} | "
                         f"{r['peak_rss_mib']['scipy']:.0f} |")
    lines.append("")
    for r in results:
        a = r["agreement"]
        if a["matrices_equal"]:
            verdict = "identical labels and confusion matrices"
        elif a["labels_equal"] and "differing_cells" in a:
            verdict = (f"{a['points_labelled_differently']} of {a['points_compared']:,} points labelled "
                       f"differently ({a['differing_cells']} confusion cells differ)")
        else:
            verdict = "LABELS DIFFER"
        lines.append(f"- agreement {case_name(r['gt_points'], r['map_points'], r['map_covers_room'], r.get('random_order'))}: {verdict}; "
                     f"max |metric diff| = {a['max_abs_metric_diff']:.2e}")
    m = machine()
    lines += ["", f"Machine: {m['nproc']} CPUs, {m.get('cpu', '?')}, {m.get('mem_total_gib', '?')} GiB RAM; "
              f"numpy {versions['numpy']}, scipy {versions['scipy']}"
              + "; reference run with " + ", ".join(f"{k} unset (was {v!r})" for k, v in unset.items()),
              f"Command: `{command}`"]
    print("\n".join(lines))

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps({
        "command": command, "machine": m, "versions": versions, "repeat": args.repeat,
        "reference_env_unset": unset, "results": results, "table_markdown": "\n".join(lines)}, indent=2) + "\n")


if __name__ == "__main__":
    main()

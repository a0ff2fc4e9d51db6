#!/usr/bin/env python3
"""Check osmab's server-rendered pages in headless Chromium, with JavaScript disabled,
and take a screenshot of each.

The script starts `osmab serve` on a free port with a fresh data directory (the demo
release with its reference mapper and five controls, scored, is built on start), loads every page in headless
Chromium with JavaScript switched off, checks what the page shows against the JSON API,
saves a full-page PNG of it, then stops the server (SIGTERM, expecting exit 0).

Only the standard library is used. Chromium is driven over the DevTools protocol on a
pipe (`--remote-debugging-pipe`) rather than with `--dump-dom`/`--screenshot`, because
`--dump-dom` reads the DOM through JavaScript and prints nothing once JavaScript is
disabled; over the protocol the DOM is read with the DOM domain, which needs no script.

    apt-get install -y chromium
    python3 tests/browser/check_pages.py --out target/browser-screenshots

Environment: OSMAB_BIN (the osmab binary; default target/release/osmab if it exists,
else target/debug/osmab), CHROMIUM (the browser; default the first of chromium,
chromium-browser, google-chrome on PATH). Exit status: 0 when every check passed, 1 when
one failed, 2 when the run could not start (no binary, no browser, server did not come up).
"""

from __future__ import annotations

import argparse
import base64
import fcntl
import html.parser
import json
import os
import re
import select
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
WIDTH, HEIGHT = 1400, 1000
PHONE_WIDTH, PHONE_HEIGHT = 390, 844
# The build the operator starts in the check of a running build's page: the service tests'
# small release (two scenes), as another version with a shorter path.
BUILD_CONFIG = (
    (ROOT / "tests/fixtures/release-small.toml")
    .read_text()
    .replace('version = "e2e-1"', 'version = "browser-1"', 1)
    .replace('created = "2026-11-22"', 'created = "2026-11-27"', 1)
    .replace("seed = 7", "seed = 11", 1)
    .replace("max_frames = 300", "max_frames = 200", 1)
)
MIN_PNG_BYTES = 10 * 1024
MAX_SHOT_HEIGHT = 8000
METRICS = ["miou", "fmiou", "macc"]
# The reference mapper and the five controls made from the ground truth.
EXPECTED_ENTRIES = 6
# Scenes of the demo release (configs/release-demo.toml: four furniture, three manipuland).
DEMO_SCENES = 7


class Failure(Exception):
    """A check did not hold."""


class Fatal(Exception):
    """The run cannot go on (no binary, no browser, the server did not start)."""


def expect(cond, message: str) -> None:
    if not cond:
        raise Failure(message)


def log(message: str) -> None:
    print(f"[{time.strftime('%H:%M:%S')}] {message}", flush=True)


# --------------------------------------------------------------------------- DOM parsing


VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}


class Node:
    def __init__(self, tag: str, attrs: dict, parent: "Node | None"):
        self.tag, self.attrs, self.parent, self.children = tag, attrs, parent, []

    def classes(self) -> set:
        return set(self.attrs.get("class", "").split())

    def iter(self):
        yield self
        for c in self.children:
            if isinstance(c, Node):
                yield from c.iter()

    def find_all(self, tag=None, id=None, cls=None) -> list:
        return [
            n
            for n in self.iter()
            if n is not self
            and (tag is None or n.tag == tag)
            and (id is None or n.attrs.get("id") == id)
            and (cls is None or cls in n.classes())
        ]

    def find(self, tag=None, id=None, cls=None) -> "Node | None":
        found = self.find_all(tag, id, cls)
        return found[0] if found else None

    def kids(self, tag: str) -> list:
        return [c for c in self.children if isinstance(c, Node) and c.tag == tag]

    def text(self) -> str:
        parts = []
        for c in self.children:
            parts.append(c.text() if isinstance(c, Node) else c)
        return "".join(parts)

    def clean(self) -> str:
        return " ".join(self.text().split())


class TreeBuilder(html.parser.HTMLParser):
    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.root = Node("#document", {}, None)
        self.cur = self.root

    def handle_starttag(self, tag, attrs):
        node = Node(tag, {k: (v or "") for k, v in attrs}, self.cur)
        self.cur.children.append(node)
        if tag not in VOID:
            self.cur = node

    def handle_startendtag(self, tag, attrs):
        self.cur.children.append(Node(tag, {k: (v or "") for k, v in attrs}, self.cur))

    def handle_endtag(self, tag):
        n = self.cur
        while n is not None and n.tag != tag:
            n = n.parent
        if n is not None and n.parent is not None:
            self.cur = n.parent

    def handle_data(self, data):
        self.cur.children.append(data)


def parse_html(text: str) -> Node:
    b = TreeBuilder()
    b.feed(text)
    b.close()
    return b.root


# ------------------------------------------------------------------------------ Chromium


def find_chromium(explicit: str | None) -> str:
    for cand in [explicit, os.environ.get("CHROMIUM"), "chromium", "chromium-browser", "google-chrome", "google-chrome-stable"]:
        if cand:
            path = shutil.which(cand) or (cand if os.path.isfile(cand) and os.access(cand, os.X_OK) else None)
            if path:
                return path
    raise Fatal("no Chromium found: install it with `apt-get install -y chromium`, or set CHROMIUM=/path/to/chrome")


class Browser:
    """Headless Chromium driven over the DevTools protocol on a pipe (fds 3 and 4)."""

    def __init__(self, exe: str, profile: Path, log_path: Path):
        cmd_r, cmd_w = os.pipe()  # we write commands, Chromium reads them on fd 3
        res_r, res_w = os.pipe()  # Chromium writes answers on fd 4, we read them

        def child_fds():
            a = fcntl.fcntl(cmd_r, fcntl.F_DUPFD, 10)
            b = fcntl.fcntl(res_w, fcntl.F_DUPFD, 10)
            os.dup2(a, 3)
            os.dup2(b, 4)

        args = [
            exe,
            "--headless=new",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            f"--window-size={WIDTH},{HEIGHT}",
            # JavaScript off for every page; Emulation.setScriptExecutionDisabled below too.
            "--blink-settings=scriptEnabled=false",
            "--remote-debugging-pipe",
            f"--user-data-dir={profile}",
            "--no-first-run",
            "--no-default-browser-check",
            "--disable-extensions",
            "--disable-background-networking",
            "--disable-sync",
            "--mute-audio",
            "--force-color-profile=srgb",
            "about:blank",
        ]
        self.log_file = open(log_path, "wb")
        self.proc = subprocess.Popen(
            args, stdin=subprocess.DEVNULL, stdout=self.log_file, stderr=subprocess.STDOUT, close_fds=False, preexec_fn=child_fds
        )
        os.close(cmd_r)
        os.close(res_w)
        self.w, self.r = cmd_w, res_r
        self.buf = b""
        self.next_id = 0
        self.events: list = []
        try:
            self.version = self.send("Browser.getVersion", timeout=30)["product"]
        except Exception as e:
            self.close()
            raise Fatal(f"Chromium did not answer on the DevTools pipe ({e}); see {log_path}")

    def _read_message(self, deadline: float) -> dict:
        while b"\0" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise Failure("timed out waiting for Chromium")
            ready, _, _ = select.select([self.r], [], [], min(left, 1.0))
            if ready:
                chunk = os.read(self.r, 1 << 20)
                if not chunk:
                    raise Fatal("Chromium closed the DevTools pipe (did it crash?)")
                self.buf += chunk
            elif self.proc.poll() is not None:
                raise Fatal(f"Chromium exited with status {self.proc.returncode}")
        raw, self.buf = self.buf.split(b"\0", 1)
        return json.loads(raw)

    def send(self, method: str, params: dict | None = None, session: str | None = None, timeout: float = 60) -> dict:
        self.next_id += 1
        msg = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        data = json.dumps(msg).encode() + b"\0"
        while data:
            data = data[os.write(self.w, data):]
        deadline = time.monotonic() + timeout
        while True:
            m = self._read_message(deadline)
            if m.get("id") == self.next_id:
                if "error" in m:
                    raise Failure(f"{method}: {m['error'].get('message')}")
                return m.get("result", {})
            if "method" in m:
                self.events.append(m)

    def wait_event(self, name: str, session: str, timeout: float = 60) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            for i, e in enumerate(self.events):
                if e["method"] == name and e.get("sessionId") == session:
                    return self.events.pop(i)
            m = self._read_message(deadline)
            if "method" in m:
                self.events.append(m)

    def close(self) -> None:
        try:
            if self.proc.poll() is None:
                try:
                    self.send("Browser.close", timeout=10)
                except Exception:
                    pass
                try:
                    self.proc.wait(10)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait(10)
        finally:
            for fd in (self.w, self.r):
                try:
                    os.close(fd)
                except OSError:
                    pass
            self.log_file.close()


class Page:
    """One tab, JavaScript disabled, a fixed 1400 x 1000 viewport."""

    def __init__(self, browser: Browser, dark: bool = False, width: int = WIDTH):
        self.b = browser
        self.width = width
        self.target = browser.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        self.sid = browser.send("Target.attachToTarget", {"targetId": self.target, "flatten": True})["sessionId"]
        self.cmd("Page.enable")
        self.cmd("Network.enable")
        self.cmd("Emulation.setScriptExecutionDisabled", {"value": True})
        self.cmd("Emulation.setDeviceMetricsOverride", {"width": width, "height": HEIGHT, "deviceScaleFactor": 1, "mobile": False})
        self.cmd("Emulation.setEmulatedMedia", {"media": "screen", "features": [{"name": "prefers-color-scheme", "value": "dark" if dark else "light"}]})

    def cmd(self, method: str, params: dict | None = None, timeout: float = 60) -> dict:
        return self.b.send(method, params, self.sid, timeout)

    def goto(self, url: str, timeout: float = 60) -> dict:
        """Load `url`; return the main document's response and the failed sub-resources."""
        self.b.events = [e for e in self.b.events if e.get("sessionId") != self.sid]
        nav = self.cmd("Page.navigate", {"url": url})
        expect(not nav.get("errorText"), f"navigation to {url} failed: {nav.get('errorText')}")
        self.b.wait_event("Page.loadEventFired", self.sid, timeout)
        events = [e for e in self.b.events if e.get("sessionId") == self.sid]
        requests = {e["params"]["requestId"]: e["params"]["request"]["url"] for e in events if e["method"] == "Network.requestWillBeSent"}
        document, bad = None, []
        for e in events:
            p = e["params"]
            if e["method"] == "Network.responseReceived":
                status = p["response"]["status"]
                if p.get("type") == "Document" and document is None:
                    document = p["response"]
                elif status >= 400:
                    bad.append(f"{p['response']['url']} -> HTTP {status}")
            elif e["method"] == "Network.loadingFailed" and not p.get("canceled"):
                bad.append(f"{requests.get(p['requestId'], p['requestId'])} -> {p.get('errorText')} {p.get('blockedReason', '')}".strip())
        expect(document is not None, f"no document response for {url}")
        return {"document": document, "failed": bad, "requests": sorted(set(requests.values()))}

    def dom(self) -> tuple[str, Node]:
        root = self.cmd("DOM.getDocument", {"depth": 1})["root"]
        html_node = next(c for c in root.get("children", []) if c.get("nodeName") == "HTML")
        text = self.cmd("DOM.getOuterHTML", {"nodeId": html_node["nodeId"]})["outerHTML"]
        return text, parse_html(text)

    def boxes(self, selector: str) -> list:
        """Rendered (width, height) of every element matching `selector` (no JavaScript needed)."""
        root = self.cmd("DOM.getDocument", {"depth": 0})["root"]["nodeId"]
        out = []
        for node in self.cmd("DOM.querySelectorAll", {"nodeId": root, "selector": selector})["nodeIds"]:
            try:
                m = self.cmd("DOM.getBoxModel", {"nodeId": node})["model"]
                out.append((m["width"], m["height"]))
            except Failure:
                out.append((0, 0))  # not rendered
        return out

    def node(self, selector: str) -> int:
        root = self.cmd("DOM.getDocument", {"depth": 0})["root"]["nodeId"]
        node = self.cmd("DOM.querySelector", {"nodeId": root, "selector": selector})["nodeId"]
        expect(node, f"nothing matches {selector!r}")
        return node

    def type_into(self, selector: str, text: str) -> None:
        """Focus a form field and type `text` as a user would (no page script involved)."""
        self.cmd("DOM.focus", {"nodeId": self.node(selector)})
        self.cmd("Input.insertText", {"text": text})

    def click(self, selector: str) -> None:
        """Click the middle of an element with the mouse (no page load expected)."""
        node = self.node(selector)
        self.cmd("DOM.scrollIntoViewIfNeeded", {"nodeId": node})
        quad = self.cmd("DOM.getBoxModel", {"nodeId": node})["model"]["content"]
        x, y = sum(quad[0::2]) / 4, sum(quad[1::2]) / 4
        for kind in ("mousePressed", "mouseReleased"):
            self.cmd("Input.dispatchMouseEvent", {"type": kind, "x": x, "y": y, "button": "left", "clickCount": 1})

    def click_and_wait(self, selector: str, timeout: float = 60) -> None:
        """Click the middle of an element with the mouse and wait for the next page load."""
        node = self.node(selector)
        self.cmd("DOM.scrollIntoViewIfNeeded", {"nodeId": node})
        quad = self.cmd("DOM.getBoxModel", {"nodeId": node})["model"]["content"]
        x, y = sum(quad[0::2]) / 4, sum(quad[1::2]) / 4
        self.b.events = [e for e in self.b.events if e.get("sessionId") != self.sid]
        for kind in ("mousePressed", "mouseReleased"):
            self.cmd("Input.dispatchMouseEvent", {"type": kind, "x": x, "y": y, "button": "left", "clickCount": 1})
        self.b.wait_event("Page.loadEventFired", self.sid, timeout)

    def screenshot(self, path: Path) -> tuple[int, int, int]:
        metrics = self.cmd("Page.getLayoutMetrics")
        size = metrics.get("cssContentSize") or metrics["contentSize"]
        height = int(min(max(size["height"], HEIGHT), MAX_SHOT_HEIGHT))
        shot = self.cmd(
            "Page.captureScreenshot",
            {"format": "png", "captureBeyondViewport": True, "clip": {"x": 0, "y": 0, "width": self.width, "height": height, "scale": 1}},
        )
        data = base64.b64decode(shot["data"])
        path.write_bytes(data)
        expect(data[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name} is not a PNG")
        w, h = struct.unpack(">II", data[16:24])
        expect(len(data) > MIN_PNG_BYTES, f"{path.name} is only {len(data)} bytes (a blank page?)")
        return w, h, len(data)

    def overflow(self) -> tuple[int, int]:
        """(document.documentElement.scrollWidth, innerWidth), asked through the DevTools
        protocol's own evaluation (page scripts stay disabled)."""
        got = self.cmd("Runtime.evaluate", {"expression": "[document.documentElement.scrollWidth, innerWidth]", "returnByValue": True})
        value = got.get("result", {}).get("value")
        expect(isinstance(value, list) and len(value) == 2, f"Runtime.evaluate gave {got}")
        return int(value[0]), int(value[1])

    def close(self) -> None:
        try:
            self.b.send("Target.closeTarget", {"targetId": self.target}, timeout=10)
        except Exception:
            pass


# -------------------------------------------------------------------------------- server


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def http_get(url: str, method: str = "GET", timeout: float = 30):
    req = urllib.request.Request(url, method=method)
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, r.headers, (r.read() if method == "GET" else b"")
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()


def get_json(url: str):
    status, _, body = http_get(url)
    expect(status == 200, f"GET {url} -> HTTP {status}")
    return json.loads(body)


def osmab_binary(explicit: str | None) -> Path:
    name = explicit or os.environ.get("OSMAB_BIN")
    if name:
        path = Path(name)
        path = path if path.is_absolute() else (Path.cwd() / path if (Path.cwd() / path).exists() else ROOT / path)
    else:
        release = ROOT / "target/release/osmab"
        path = release if release.exists() else ROOT / "target/debug/osmab"
    if not (path.is_file() and os.access(path, os.X_OK)):
        raise Fatal(f"no osmab binary at {path}: build it (cargo build) or set OSMAB_BIN")
    return path


class Server:
    def __init__(self, binary: Path, data_dir: Path, log_path: Path):
        self.port = free_port()
        self.base = f"http://127.0.0.1:{self.port}"
        env = dict(os.environ)
        # The demo config's `assets` pack is the repository's (the server runs elsewhere).
        env.update({"OSMAB_DATA_DIR": str(data_dir), "OSMAB_BIND": f"127.0.0.1:{self.port}", "OSMAB_ASSETS_ROOT": str(ROOT)})
        env.setdefault("OSMAB_DEMO", "true")
        env.setdefault("RUST_LOG", "warn")
        env.pop("OSMAB_CONFIG", None)
        self.log_path = log_path
        self.log_file = open(log_path, "wb")
        self.proc = subprocess.Popen(
            [str(binary), "serve"], cwd=str(data_dir.parent), env=env, stdin=subprocess.DEVNULL, stdout=self.log_file, stderr=subprocess.STDOUT
        )

    def log_tail(self, lines: int = 25) -> str:
        try:
            text = self.log_path.read_text(errors="replace").splitlines()
        except OSError:
            return ""
        return "\n".join("    " + re.sub(r"\x1b\[[0-9;]*m", "", line) for line in text[-lines:])

    def wait_ready(self, timeout: float) -> dict:
        deadline = time.monotonic() + timeout
        last = "no answer yet"
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise Fatal(f"osmab serve exited with status {self.proc.returncode} before it was ready:\n{self.log_tail()}")
            try:
                status, _, body = http_get(f"{self.base}/api/v1/leaderboard", timeout=5)
                if status == 200:
                    board = json.loads(body)
                    n = len(board.get("entries", []))
                    last = f"{n} scored entries"
                    if n >= EXPECTED_ENTRIES:
                        return board
                else:
                    last = f"HTTP {status}"
            except (OSError, ValueError) as e:
                last = str(e)
            time.sleep(0.5)
        raise Fatal(f"the leaderboard did not reach {EXPECTED_ENTRIES} scored entries in {timeout:.0f} s (last: {last}):\n{self.log_tail()}")

    def stop(self, timeout: float = 30) -> tuple[int | None, float]:
        t0 = time.monotonic()
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
                self.log_file.close()
                return None, time.monotonic() - t0
        self.log_file.close()
        return self.proc.returncode, time.monotonic() - t0


# -------------------------------------------------------------------------------- checks


def pct(v) -> str:
    return "–" if v is None else f"{100.0 * v:.1f}"


def signed_pct(v) -> str:
    return "–" if v is None else f"{100.0 * v:+.1f}%"


def board_value(entry: dict, lighting: str, agg: str, subset: str, metric: str):
    semseg = entry["scores"]["semseg"].get(lighting, {})
    node = semseg.get(agg, {}) if subset == "all" else semseg.get("subsets", {}).get(subset, {}).get(agg, {})
    v = node.get(metric)
    return float(v) if isinstance(v, (int, float)) else None


def board_interval(entry: dict, lighting: str, agg: str, subset: str, metric: str):
    """The 95 % interval of a pooled value, as the API gives it beside the value."""
    if agg != "overall":
        return None
    semseg = entry["scores"]["semseg"].get(lighting, {})
    node = semseg.get("overall", {}) if subset == "all" else semseg.get("subsets", {}).get(subset, {}).get("overall", {})
    return node.get("ci95", {}).get(metric)


def spread(interval) -> str:
    """How the page writes an interval beside its value: ± half its width in percent."""
    return "" if interval is None else f"±{50.0 * (interval[1] - interval[0]):.1f}"


def common_page_checks(page: Node, html_text: str, loaded: dict) -> list:
    """Checks every page must pass; returns notes."""
    doc = loaded["document"]
    expect(doc["status"] == 200, f"HTTP {doc['status']} for {doc['url']}")
    expect(doc.get("mimeType") == "text/html", f"content type {doc.get('mimeType')} for {doc['url']}")
    expect(not loaded["failed"], "sub-resources failed to load: " + "; ".join(loaded["failed"]))
    expect(any(u.endswith("/static/style.css") for u in loaded["requests"]), "the stylesheet /static/style.css was not requested")
    expect(page.find("header", cls="site") is not None, "no <header class=site>")
    expect(page.find("main") is not None, "no <main>")
    expect(page.find("footer", cls="site") is not None, "no <footer class=site>")
    expect("{{" not in html_text and "{%" not in html_text, "unrendered template syntax in the page")
    scripts = page.find_all("script")
    return [f"{len(scripts)} <script>"] if scripts else []


def check_board(page: Node, board: dict, agg: str, subset: str, sort: str, labels: dict, intervals: bool = True, all_metrics: bool = False) -> str:
    """The board's table against the API. The page shows mIoU alone per lighting unless
    `all_metrics` (or sorted by another metric); groups and intervals only where the board
    has scenes enough for them (`significance`)."""
    metrics = METRICS if all_metrics or not sort.endswith(".miou") else ["miou"]
    significance = board.get("significance", True)
    intervals = intervals and significance
    table = page.find(id="leaderboard")
    expect(table is not None, "no table#leaderboard")
    tbody = table.find("tbody")
    rows = tbody.kids("tr") if tbody else []
    entries = board["entries"]
    expect(len(rows) == len(entries) == EXPECTED_ENTRIES, f"{len(rows)} rows in #leaderboard tbody, expected {EXPECTED_ENTRIES}")
    lightings = board["lightings"]
    # Headers: one group per lighting, one sort link per lighting x metric, the sorted one marked.
    head_rows = table.find("thead").kids("tr")
    groups = [th.clean() for th in head_rows[0].kids("th") if "group" in th.classes()]
    expect(groups[: len(lightings)] == [labels.get(l, l) for l in lightings], f"lighting headers {groups}")
    links = [th.find("a") for th in head_rows[1].kids("th") if th.find("a") is not None]
    keys = [urllib.parse.parse_qs(urllib.parse.urlsplit(a.attrs["href"]).query).get("sort", [""])[0] for a in links]
    expect(keys == [f"{l}.{m}" for l in lightings for m in metrics], f"sort links {keys}")
    sorted_th = [th for th in head_rows[1].kids("th") if "sorted" in th.classes()]
    expect(len(sorted_th) == 1, f"{len(sorted_th)} headers marked sorted")
    sorted_key = urllib.parse.parse_qs(urllib.parse.urlsplit(sorted_th[0].find("a").attrs["href"]).query)["sort"][0]
    expect(sorted_key == sort and "▼" in sorted_th[0].text(), f"sorted header is {sorted_key!r}, expected {sort!r} with ▼")
    # Active choices.
    choices = page.find(cls="choices")
    active = {urllib.parse.parse_qs(urllib.parse.urlsplit(a.attrs["href"]).query).get(k, [""])[0] for a in choices.find_all("a", cls="active") for k in ("agg", "subset")}
    expect({agg, subset} <= active, f"active choices {sorted(active)} do not include {agg!r} and {subset!r}")
    # Rows: ranks, methods, tags, every number against the JSON API.
    by_method = {e["method"]: e for e in entries}
    sl, sm = sort.split(".")
    shown = []
    for i, tr in enumerate(rows):
        tds = tr.kids("td")
        expect(tds[0].clean() == str(i + 1), f"row {i + 1} has rank {tds[0].clean()!r}")
        method = tds[2].find("a").clean()
        expect(method in by_method, f"row {i + 1}: unknown method {method!r}")
        e = by_method[method]
        want_group = str(e["rank_group"]) if significance else "–"
        expect(tds[1].clean() == want_group, f"{method}: rank group {tds[1].clean()!r}, expected {want_group} (the API says {e['rank_group']}, significance {significance})")
        expect(tds[2].find("a").attrs["href"] == f"/submissions/{e['submission_id']}", f"{method}: link {tds[2].find('a').attrs['href']}")
        tags = [s.clean() for s in tds[2].find_all("span", cls="tag")]
        if e.get("reference"):
            expect("baseline" not in tr.classes() and "reference" in tags, f"{method}: the reference mapper is not tagged reference: {tags}")
        elif e.get("baseline"):
            expect("baseline" in tr.classes() and "control" in tags, f"{method}: a control made from the ground truth is not tagged control: {tags}")
        team = tds[2].find("span", cls="team")
        expect(team is not None and team.clean() == e["team"], f"{method}: team {team.clean() if team else None!r} under the method")
        cells = [td.clean() for td in tds[3 : 3 + len(lightings) * len(metrics)]]
        want = [pct(board_value(e, l, agg, subset, m)) + (spread(board_interval(e, l, agg, subset, m)) if intervals else "") for l in lightings for m in metrics]
        expect(cells == want, f"{method}: cells {cells}, the API says {want}")
        if agg == "overall" and subset == "all" and intervals:
            expect(any("±" in c for c in cells), f"{method}: no interval shown on pooled values: {cells}")
        robustness = [td.clean() for td in tds[-2:]]
        want_robustness = [pct(e["robustness"].get("worst_miou")), pct(e["robustness"].get("largest_drop"))]
        expect(robustness == want_robustness, f"{method}: robustness cells {robustness}, the API says {want_robustness}")
        changes = [td.clean() for td in tr.find_all("td", cls="change")]
        # The change of mIoU against the Baseline lighting, for the aggregate and scenes shown.
        def change(l):
            v, base = board_value(e, l, agg, subset, "miou"), board_value(e, "baseline", agg, subset, "miou")
            return (v - base) / base if v is not None and base else None

        want_changes = [signed_pct(change(l)) for l in lightings if l != "baseline"]
        if agg == "overall" and subset == "all":
            api = [signed_pct(e["scores"].get("relative_change", {}).get(l, {}).get("overall", {}).get("miou")) for l in lightings if l != "baseline"]
            expect(want_changes == api, f"{method}: pooled changes {want_changes} differ from the API's relative_change {api}")
        expect(changes == want_changes, f"{method}: change cells {changes}, the API says {want_changes}")
        shown.append((method, board_value(e, sl, agg, subset, sm)))
    methods = [m for m, _ in shown]
    expect(len(set(methods)) == len(methods), f"a method appears twice: {methods}")
    values = [v if v is not None else float("-inf") for _, v in shown]
    expect(all(a >= b for a, b in zip(values, values[1:])), f"rows not in descending {sort}: {shown}")
    best = max(entries, key=lambda e: board_value(e, sl, agg, subset, sm) or float("-inf"))
    expect(shown[0][0] == best["method"], f"first row is {shown[0][0]}, the API's best {sort} ({agg}, {subset}) is {best['method']}")
    return f"{len(rows)} rows, first {shown[0][0]} ({pct(shown[0][1])}); order " + " > ".join(m.removeprefix("baseline-") for m in methods)


def lighting_labels(page: Node, board: dict) -> dict:
    head = page.find(id="leaderboard").find("thead").kids("tr")[0]
    groups = [th.clean() for th in head.kids("th") if "group" in th.classes()]
    return dict(zip(board["lightings"], groups))


# ---------------------------------------------------------------------------------- main


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(ROOT / "target/browser-screenshots"), help="where the PNGs go (default target/browser-screenshots)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary data dir (and Chromium profile) for debugging")
    ap.add_argument("--bin", help="osmab binary (default $OSMAB_BIN, else target/release/osmab or target/debug/osmab)")
    ap.add_argument("--chromium", help="Chromium binary (default $CHROMIUM, else chromium on PATH)")
    ap.add_argument("--timeout", type=float, default=600, help="seconds to wait for the six scored reference entries (default 600)")
    args = ap.parse_args()

    started = time.monotonic()
    results: list = []  # (check, ok, seconds, detail)
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    for old in out.iterdir():  # screenshots and DOM dumps of an earlier run, nothing else
        if re.fullmatch(r"\d\d-[a-z0-9-]+\.(png|html)", old.name):
            old.unlink()
    tmp = Path(tempfile.mkdtemp(prefix="osmab-browser-"))
    data_dir = tmp / "data"
    data_dir.mkdir()
    server = browser = None

    def run(name: str, fn) -> None:
        t0 = time.monotonic()
        try:
            detail = fn() or ""
            results.append((name, True, time.monotonic() - t0, detail))
            log(f"PASS {name}: {detail}")
        except Failure as e:
            results.append((name, False, time.monotonic() - t0, str(e)))
            log(f"FAIL {name}: {e}")
        except Fatal:
            raise
        except Exception as e:  # a bug in a check, or an unexpected page shape
            results.append((name, False, time.monotonic() - t0, f"{type(e).__name__}: {e}"))
            log(f"FAIL {name}: {type(e).__name__}: {e}")

    try:
        binary = osmab_binary(args.bin)
        chromium = find_chromium(args.chromium)
        log(f"osmab {binary}, data dir {data_dir}")
        server = Server(binary, data_dir, out / "server.log")
        log(f"waiting for {EXPECTED_ENTRIES} scored baselines on {server.base} (up to {args.timeout:.0f} s)")
        t0 = time.monotonic()
        board = server.wait_ready(args.timeout)
        results.append(("server ready", True, time.monotonic() - t0, f"{len(board['entries'])} scored entries, release {board['release']}"))
        log(f"ready after {time.monotonic() - t0:.1f} s")
        base = server.base
        browser = Browser(chromium, tmp / "chromium-profile", out / "chromium.log")
        log(f"browser {browser.version} ({chromium})")
        state: dict = {"labels": {}, "links": set(), "sort_link": None}

        def load(url_path: str, shot: str, *, dark=False, width=WIDTH):
            page = Page(browser, dark=dark, width=width)
            try:
                loaded = page.goto(base + url_path)
                html_text, dom = page.dom()
                (out / f"{shot}.html").write_text(html_text)
                notes = common_page_checks(dom, html_text, loaded)
                w, h, size = page.screenshot(out / f"{shot}.png")
                for a in dom.find_all("a"):
                    href = a.attrs.get("href", "")
                    if href.startswith("/"):
                        state["links"].add(href)
                for img in dom.find_all("img"):
                    if img.attrs.get("src", "").startswith("/"):
                        state["links"].add(img.attrs["src"])
                return page, dom, f"{shot}.png {w}x{h} {size // 1024} kB" + ("; " + ", ".join(notes) if notes else "")
            except BaseException:
                page.close()
                raise

        def js_is_off():
            page = Page(browser)
            try:
                probe = "<p id=x>static</p><script>document.getElementById('x').textContent='js ran'</script>"
                page.goto("data:text/html," + urllib.parse.quote(probe))
                _, dom = page.dom()
                expect(dom.find(id="x").clean() == "static", "JavaScript ran although it should be disabled")
                return "a probe script did not run"
            finally:
                page.close()

        def leaderboard_default():
            page, dom, shot = load("/", "01-leaderboard")
            try:
                hrefs = [a.attrs["href"] for a in dom.find(id="leaderboard").find("thead").find_all("a")]
                state["sort_link"] = next((h for h in reversed(hrefs) if "sort=baseline.miou" not in h), None)
                state["labels"] = lighting_labels(dom, board)
                summary = check_board(dom, board, "overall", "all", f"{board['lightings'][0]}.miou", state["labels"])
                oracle = [tr for tr in dom.find(id="leaderboard").find("tbody").kids("tr") if "baseline-oracle" in tr.clean()]
                expect(oracle and "100.0±0.0" in [td.clean() for td in oracle[0].kids("td")], "the baseline-oracle row does not show 100.0±0.0")
                groups = [tr.kids("td")[1].clean() for tr in dom.find(id="leaderboard").find("tbody").kids("tr")]
                expect(groups[0] == "1" and len(set(groups)) > 1, f"rank groups {groups}: the oracle alone in group 1, the others below")
                summary += "; rank groups " + " ".join(groups)
                svg = dom.find("svg", cls="chart")
                expect(svg is not None, "no <svg class=chart>")
                expect(len(svg.find_all("rect")) >= len(board["lightings"]) - 1, "the chart has no bars")
                legend = svg.clean()
                expect("baseline-perceive" in legend and "baseline-oracle" not in legend, f"the chart shows the reference mapper and no control: {legend[:300]}")
                sw, sh = (page.boxes("svg.chart") or [(0, 0)])[0]  # the robustness chart comes first
                expect(sw > 300 and sh > 100, f"the chart renders at {sw:.0f}x{sh:.0f} px")
                (tw, _), = page.boxes("#leaderboard")
                ww = page.boxes(".table-wrap")[0][0]  # the segmentation table's wrapper comes first
                overflow = f"; table {tw:.0f}px wide in a {ww:.0f}px wrapper (scrolls sideways)" if tw > ww + 1 else ""
                return f"{summary}; chart {sw:.0f}x{sh:.0f}; {shot}{overflow}"
            finally:
                page.close()

        def leaderboard_vqa():
            page, dom, shot = load("/", "10-leaderboard-vqa")
            try:
                table = dom.find(id="vqa-board")
                expect(table is not None, "no question-answering table (#vqa-board)")
                rows = table.find("tbody").kids("tr")
                with_vqa = [e for e in board["entries"] if isinstance(e["scores"].get("vqa"), dict)]
                expect(len(rows) == len(with_vqa) == EXPECTED_ENTRIES, f"{len(rows)} VQA rows for {len(with_vqa)} entries with VQA scores")
                checked = 0
                for tr, entry in zip(rows, with_vqa):
                    tds = [td.clean() for td in tr.kids("td")]
                    expect(tds[0] == entry["method"], f"VQA row {tds[0]!r}, expected {entry['method']!r}")
                    cells = iter(tds[1:])
                    # A test board pools VQA over every lighting (one "All lightings" group).
                    pooled = board["split"] == "test"
                    for lighting in (["all"] if pooled else board["lightings"]):
                        at = entry["scores"]["vqa"]["all_lightings"] if pooled else entry["scores"]["vqa"]["lightings"][lighting]
                        for question_set in ("prompt_grounded", "standard"):
                            for group in ("Measurements", "Relations"):
                                # A group a test score withholds (fewer than five scenes) is absent: "–".
                                want = pct(at[question_set]["groups"].get(group, {}).get("accuracy"))
                                got = next(cells)
                                expect(got == want, f"{entry['method']} {lighting} {question_set} {group}: page {got}, API {want}")
                                checked += 1
                groups = [th.clean() for th in table.find("thead").find_all("th", cls="group")]
                expect(groups == (["All lightings"] if pooled else [state["labels"].get(l, l) for l in board["lightings"]]), f"VQA column groups {groups}")
                # A blank is explained in words: on a test board, withheld (not zero).
                blanks = any(td.clean() == "–" for tr in rows for td in tr.kids("td"))
                note = dom.find(id="vqa-blanks")
                expect(not blanks or (note is not None and ("withheld" in note.clean()) == pooled), f"'–' cells without a note saying why: {note.clean() if note else None}")
                charts = page.boxes(".charts svg")
                expect(len(charts) == 4 and all(w > 200 and h > 100 for w, h in charts), f"the VQA charts render at {charts}")
                return f"{len(rows)} rows, {checked} cells equal to the API ({'over all lightings' if pooled else 'per lighting'}), 4 charts; {shot}"
            finally:
                page.close()

        def leaderboard_splits():
            # The demo holds out a test split: the default board ranks it, the val board is one link away.
            page, dom, shot = load("/", "15-leaderboard-test-split")
            try:
                expect(board.get("split") == "test" and board.get("splits") == ["test", "val"], f"the default board is {board.get('split')} of {board.get('splits')}")
                marker = dom.find(id="split")
                expect(marker is not None and marker.attrs.get("data-split") == "test", "the page does not say it shows the test split")
                links = [a.attrs["href"] for a in dom.find_all("a", cls="board-choice")]
                val_link = next((h for h in links if "split=val" in h), None)
                expect(val_link is not None, f"no link to the val board among {links}")
            finally:
                page.close()
            # The baselines of both splits are scored one after another: wait for val's too.
            deadline = time.monotonic() + args.timeout
            while True:
                val_board = get_json(f"{base}/api/v1/leaderboard?split=val")
                if len(val_board["entries"]) >= EXPECTED_ENTRIES or time.monotonic() > deadline:
                    break
                time.sleep(0.5)
            expect(val_board["split"] == "val" and len(val_board["entries"]) == EXPECTED_ENTRIES, f"the val board has {len(val_board['entries'])} entries")
            page, dom, shot_val = load(val_link, "16-leaderboard-val-split")
            try:
                expect(dom.find(id="split").attrs.get("data-split") == "val", "the val board's page does not say val")
                # The demo's val split is two scenes: too few for intervals and rank groups,
                # which the page says instead of showing a group per entry.
                manifest = get_json(f"{base}/api/v1/releases/{val_board['release']}/manifest.json")
                val_scenes = sum(1 for scene in manifest["scenes"] if scene.get("split", "val") == "val")
                expect(val_board.get("scenes") == val_scenes and val_board.get("significance") is (val_scenes >= 5), f"the val board pools {val_board.get('scenes')} scenes, significance {val_board.get('significance')}")
                if not val_board["significance"]:
                    note = dom.find(id="groups-explained")
                    expect(note is not None and "too few" in note.clean(), "the val board does not say it has too few scenes for groups")
                summary = check_board(dom, val_board, "overall", "all", f"{val_board['lightings'][0]}.miou", state["labels"])
                return f"test board by default, val board linked and equal to its API ({summary}); {shot}, {shot_val}"
            finally:
                page.close()

        def leaderboard_all_metrics():
            page, dom, shot = load("/?release=" + board["release"] + "&metrics=all", "18-leaderboard-all-metrics")
            try:
                links = [a.attrs["href"] for a in dom.find_all("a", cls="metric-choice")]
                expect(len(links) == 2 and any("metrics=miou" in h for h in links), f"metric choices {links}")
                return check_board(dom, board, "overall", "all", f"{board['lightings'][0]}.miou", state["labels"], all_metrics=True) + "; " + shot
            finally:
                page.close()

        def lighting_thumbnails():
            page, dom, shot = load("/", "19-leaderboard-lightings")
            try:
                figures = dom.find_all("figure", cls="lighting")
                expect(len(figures) == len(board["lightings"]) == 4, f"{len(figures)} lighting figures for {board['lightings']}")
                frames = set()
                for figure, lighting in zip(figures, board["lightings"]):
                    caption = figure.find("figcaption").clean()
                    label = state["labels"].get(lighting, lighting)
                    expect(caption.startswith(label) and len(caption) > len(label) + 20, f"{lighting}: caption {caption!r} does not explain {label}")
                    expect(lighting in caption, f"{lighting}: the caption {caption!r} does not give the name the files and the client use")
                    src = figure.find("img").attrs["src"]
                    expect(f"/sequences/{lighting}/" in src, f"{lighting}: the frame {src} is not of that lighting")
                    frames.add(src.replace(f"/sequences/{lighting}/", "/sequences/*/"))
                    status, headers, body = http_get(base + src)
                    expect(status == 200 and body[:2] == b"\xff\xd8", f"{src}: HTTP {status}")
                expect(len(frames) == 1, f"the four frames are not the same frame of one scene: {sorted(frames)}")
                nominal = next(f for f, l in zip(figures, board["lightings"]) if l == "no_lights").find("figcaption").clean()
                expect("emission" in nominal and "flat" in nominal, f"Nominal Lights is not explained as mesh emission: {nominal!r}")
                shown = page.boxes(".lightings img")
                expect(len(shown) == 4 and all(w > 150 and h > 80 for w, h in shown), f"the frames render at {shown}")
                expect(dom.find(id="groups-explained") is not None and "significantly better" in dom.find(id="groups-explained").clean(), "Group is not explained on the page")
                return f"4 frames of {next(iter(frames)).rsplit('/', 3)[-3]}, each captioned, rendered {shown[0][0]:.0f}x{shown[0][1]:.0f}; Group explained; {shot}"
            finally:
                page.close()

        def leaderboard_sorted():
            page, dom, shot = load("/?release=" + board["release"] + "&agg=overall_mean&subset=all&sort=no_lights.macc", "02-leaderboard-sorted-no-lights-macc")
            try:
                return check_board(dom, board, "overall_mean", "all", "no_lights.macc", state["labels"]) + "; " + shot
            finally:
                page.close()

        def leaderboard_manipuland():
            page, dom, shot = load("/?release=" + board["release"] + "&subset=manipuland", "03-leaderboard-manipuland")
            try:
                return check_board(dom, board, "overall", "manipuland", f"{board['lightings'][0]}.miou", state["labels"]) + "; " + shot
            finally:
                page.close()

        def follow_sort_link():
            href = state["sort_link"]
            expect(href, "no sort link (th a) found on the leaderboard")
            q = {k: v[0] for k, v in urllib.parse.parse_qs(urllib.parse.urlsplit(href).query).items()}
            page, dom, shot = load(href, "04-leaderboard-followed-sort-link")
            try:
                got = check_board(dom, board, q.get("agg", "overall"), q.get("subset", "all"), q["sort"], state["labels"], all_metrics=q.get("metrics") == "all")
                return f"{href} -> {got}; {shot}"
            finally:
                page.close()

        def release_page():
            version = board["release"]
            manifest = get_json(f"{base}/api/v1/releases/{version}/manifest.json")
            page, dom, shot = load(f"/releases/{version}", "05-release")
            try:
                expect(version in dom.find("h1").clean(), f"h1 is {dom.find('h1').clean()!r}")
                cards = dom.find_all("article", cls="scene")
                scenes = manifest["scenes"]
                expect(len(cards) == len(scenes) == DEMO_SCENES, f"{len(cards)} scene cards, the manifest has {len(scenes)} scenes (expected {DEMO_SCENES})")
                for card, scene in zip(cards, scenes):
                    h3 = card.find("h3").clean()
                    expect(scene["id"] in h3 and scene["subset"] in h3 and scene["split"] in h3, f"card title {h3!r} for {scene['id']} ({scene['subset']}, {scene['split']})")
                    if scene["split"] == "test":
                        # A test scene publishes no prompt: the card says so, the manifest has none.
                        expect("prompt" not in scene and "hidden test scene" in card.find("p").clean(), f"{scene['id']}: {card.find('p').clean()!r}")
                    else:
                        expect(card.find("p").clean() == " ".join(scene["prompt"].split()), f"{scene['id']}: prompt differs from the manifest")
                    img = card.find("img")
                    expect(img is not None and img.attrs.get("src"), f"{scene['id']}: no <img>")
                    status, headers, body = http_get(base + img.attrs["src"])
                    ctype = headers.get("content-type", "")
                    expect(status == 200 and ctype.startswith("image/jpeg") and body[:2] == b"\xff\xd8", f"{img.attrs['src']}: HTTP {status} {ctype}")
                    expect(img.attrs["src"].endswith(scene["preview"]), f"{scene['id']}: the thumbnail is not the manifest's preview frame")
                rendered = page.boxes(".scene img")
                expect(len(rendered) == DEMO_SCENES and all(w > 100 and h > 50 for w, h in rendered), f"thumbnails render at {rendered}")
                # The overview: every scene (rows) under every lighting (columns), one PNG.
                overview = dom.find("figure", cls="overview")
                expect(overview is not None and overview.find("img") is not None, "no overview figure")
                status, headers, body = http_get(base + overview.find("img").attrs["src"])
                expect(status == 200 and body[:8] == b"\x89PNG\r\n\x1a\n", f"overview: HTTP {status}")
                width, height = struct.unpack(">II", body[16:24])
                expect(width > 4 * 190 and height > DEMO_SCENES * 100, f"overview is {width}x{height}, expected 4 lightings x {DEMO_SCENES} scenes of thumbnails")
                shown = page.boxes(".overview img")
                expect(len(shown) == 1 and shown[0][0] > 400, f"overview renders at {shown}")
                archive_table = [t for t in dom.find_all("table") if "SHA-256" in t.find("thead").clean()]
                expect(archive_table, "no archive table")
                rows = archive_table[0].find("tbody").kids("tr")
                want = len(manifest["lightings"]) * len(scenes)
                expect(len(rows) == want == 4 * DEMO_SCENES, f"{len(rows)} archive rows, expected {want} ({4 * DEMO_SCENES})")
                by_path = {a["path"]: a for a in manifest["archives"]}
                for tr in rows:
                    tds = tr.kids("td")
                    href = tds[2].find("a").attrs["href"]
                    path = href.split("/files/", 1)[-1]
                    expect(path in by_path, f"archive link {href} is not in the manifest")
                    expect(tds[4].clean() == by_path[path]["sha256"], f"{path}: SHA-256 differs from the manifest")
                    expect(tds[1].clean() == by_path[path]["scene"], f"{path}: scene cell {tds[1].clean()!r}")
                return f"{len(cards)} scene cards (thumbnails {rendered[0][0]:.0f}x{rendered[0][1]:.0f} px), {len(rows)} archives; {shot}"
            finally:
                page.close()

        def submission_page():
            entry = next((e for e in board["entries"] if e["method"] == "baseline-pose-drift"), board["entries"][0])
            page, dom, shot = load(f"/submissions/{entry['submission_id']}", "06-submission")
            try:
                expect(entry["method"] in dom.find("h1").clean(), f"h1 is {dom.find('h1').clean()!r}")
                state_p = dom.find("p", cls="state")
                expect(state_p is not None and state_p.find("strong").clean() == "scored" and "state-scored" in state_p.classes(), "the state is not 'scored'")
                expect(all(m.attrs.get("http-equiv") != "refresh" for m in dom.find_all("meta")), "a scored submission still refreshes itself")
                main = dom.find("main")
                heads = [n for n in main.iter() if n.tag in ("h2", "table")]
                # The leaderboard carries aggregates; the per-scene tables come with the submission —
                # of a val one: a test submission shows no number of fewer than five test scenes,
                # so its tables are the pooled rows only, and a notice says why.
                scores = get_json(f"{base}/api/v1/submissions/{entry['submission_id']}")["scores"]
                semseg = scores["semseg"]
                if scores.get("split") == "test":
                    notice = dom.find(id="withheld")
                    expect(notice is not None and "fewer than 5 test scenes" in notice.clean(), "a test submission's page does not say what it withholds")
                    expect(all("scenes" not in semseg[l] for l in semseg), "the API shows a test submission's per-scene rows")
                tables = 0
                for i, lighting in enumerate(board["lightings"]):
                    label = state["labels"].get(lighting, lighting)
                    idx = next((k for k, n in enumerate(heads) if n.tag == "h2" and n.clean() == label), None)
                    expect(idx is not None and idx + 1 < len(heads) and heads[idx + 1].tag == "table", f"no table under <h2>{label}</h2>")
                    rows = heads[idx + 1].find("tbody").kids("tr")
                    scenes = sorted(semseg[lighting].get("scenes", {}))
                    pooled = semseg[lighting].get("pooled")
                    mean_label = f"mean over {pooled} scenes" if pooled else "mean over scenes"
                    ci = semseg[lighting]["overall"].get("ci95")
                    expect(len(rows) == len(scenes) + 2 + (ci is not None), f"{label}: {len(rows)} rows, expected {len(scenes)} scenes + mean + pooled + its interval")
                    for tr, scene in zip(rows, scenes + [mean_label, "pooled"]):
                        tds = [td.clean() for td in tr.kids("td")]
                        src = semseg[lighting].get("scenes", {}).get(scene) or semseg[lighting]["overall_mean" if scene.startswith("mean") else "overall"]
                        want = [scene] + [pct(src.get(m)) for m in METRICS]
                        expect(tds == want, f"{label}: row {tds}, the API says {want}")
                    if ci is not None:
                        tds = [td.clean() for td in rows[-1].kids("td")]
                        want = ["pooled, 95 % interval"] + [f"{100 * ci[m][0]:.1f}–{100 * ci[m][1]:.1f}" for m in METRICS]
                        expect(tds == want, f"{label}: interval row {tds}, the API says {want}")
                    tables += 1
                history = [t for t in main.find_all("table") if "State" in t.find("thead").clean()]
                expect(history and "scored" in history[0].find("tbody").clean(), "the history does not show 'scored'")
                return f"{entry['method']} ({scores.get('split')}): scored, {tables} per-lighting tables of {len(scenes)} scene rows; {shot}"
            finally:
                page.close()

        def api_docs():
            page, dom, shot = load("/api/docs", "07-api-docs")
            try:
                paths = {r.kids("td")[1].clean() for r in dom.find("table").find("tbody").kids("tr")}
                for p in ("/api/v1/submissions", "/api/v1/leaderboard", "/api/v1/releases/{version}"):
                    expect(p in paths, f"{p} is not listed")
                expect(dom.find("dl", cls="codes") is not None, "no error codes")
                return f"{len(paths)} paths listed; {shot}"
            finally:
                page.close()

        def extra_views():
            notes = []
            for name, kw in (("08-leaderboard-dark", {"dark": True}), ("09-leaderboard-narrow", {"width": 420})):
                page, dom, shot = load("/", name, **kw)
                page.close()
                expect(len(dom.find(id="leaderboard").find("tbody").kids("tr")) == EXPECTED_ENTRIES, f"{name}: rows missing")
                notes.append(shot)
            return "; ".join(notes)

        def internal_links():
            checked, bad = 0, []
            extra = {"/releases/current", "/api/v1/openapi.json"}
            for href in sorted(state["links"] | extra):
                status, _, _ = http_get(base + href, method="HEAD")
                if status == 405:
                    status, _, _ = http_get(base + href)
                checked += 1
                if status != 200:
                    bad.append(f"{href} -> {status}")
            expect(not bad, "broken links: " + "; ".join(bad))
            return f"{checked} distinct internal links and images answer 200"

        run("JavaScript disabled", js_is_off)
        run("leaderboard (default)", leaderboard_default)
        run("leaderboard question answering", leaderboard_vqa)
        run("leaderboard sort=no_lights.macc agg=overall_mean", leaderboard_sorted)
        run("leaderboard metrics=all", leaderboard_all_metrics)
        run("leaderboard lightings explained with a frame each", lighting_thumbnails)
        run("leaderboard subset=manipuland", leaderboard_manipuland)
        run("leaderboard test and val boards", leaderboard_splits)
        run("follow a sort link from the leaderboard", follow_sort_link)
        run("release page", release_page)
        run("submission page", submission_page)
        run("API docs page", api_docs)
        run("leaderboard dark + 420px wide", extra_views)
        def operator_console():
            token = os.environ.get("OSMAB_ADMIN_TOKEN") or (data_dir / "admin-token").read_text().strip()
            page, dom, _ = load("/admin", "11-admin-login")
            try:
                expect(dom.find("input", id="token") is not None, "/admin without a session does not show the sign-in form")
                page.type_into("#token", token)
                page.click_and_wait("form.admin-form button")
                text, dom = page.dom()
                (out / "12-admin-console.html").write_text(text)
                expect(dom.find("h1").clean() == "Operator console", f"signing in led to {dom.find('h1').clean()!r}")
                releases = dom.find(id="admin-releases").find("tbody").kids("tr")
                expect(any(board["release"] in tr.clean() and "current" in tr.clean() for tr in releases), "the current release is not listed as current")
                builds = dom.find(id="admin-builds").find("tbody").kids("tr")
                expect(builds and "succeeded" in builds[0].clean(), f"the demo build is not listed as succeeded: {[b.clean() for b in builds]}")
                rows = dom.find(id="admin-submissions").find("tbody").kids("tr")
                expect(len(rows) >= EXPECTED_ENTRIES, f"{len(rows)} submissions listed")
                w, h, size = page.screenshot(out / "12-admin-console.png")
                # Flag the first entry through its form, as a user would, then clear it.
                target = next(e for e in board["entries"] if e["method"] == "baseline-merge")
                page.type_into(f"form[action='/admin/submissions/{target['submission_id']}/flag'] input[name=reason]", "checked by the browser test")
                page.click_and_wait(f"form[action='/admin/submissions/{target['submission_id']}/flag'] button")
                _, dom = page.dom()
                expect("is flagged" in dom.find("p", cls="notice").clean(), "no notice after flagging")
                flagged = next(e for e in get_json(f"{base}/api/v1/leaderboard")["entries"] if e["submission_id"] == target["submission_id"])
                expect(flagged.get("flagged") == "checked by the browser test", f"the API does not show the flag: {flagged.get('flagged')!r}")
                page.click_and_wait(f"form[action='/admin/submissions/{target['submission_id']}/unflag'] button")
                cleared = next(e for e in get_json(f"{base}/api/v1/leaderboard")["entries"] if e["submission_id"] == target["submission_id"])
                expect("flagged" not in cleared, "the flag was not cleared")
                # A team created through the form: its token shown once, and it works.
                page.type_into("#create-team input[name=name]", "Browser Team")
                page.click_and_wait("#create-team button")
                _, dom = page.dom()
                token_node = dom.find(id="team-token")
                expect(token_node is not None and len(token_node.clean()) > 20, "the new team's token is not shown")
                req = urllib.request.Request(f"{base}/api/v1/me", headers={"Authorization": f"Bearer {token_node.clean()}"})
                with urllib.request.urlopen(req, timeout=30) as r:
                    me = json.loads(r.read())
                expect(me["team"]["name"] == "Browser Team", f"the token is not the new team's: {me}")
                page.goto(f"{base}/admin")
                _, dom = page.dom()
                teams = [tr.kids("td")[0].clean() for tr in dom.find(id="admin-teams").find("tbody").kids("tr")]
                expect("Browser Team" in teams, f"the new team is not listed: {teams}")
                # A build's page and the quality comparison.
                state["build_page"] = dom.find(id="admin-builds").find("tbody").find("a").attrs["href"]
                page.click_and_wait("#admin-builds tbody tr a")
                _, dom = page.dom()
                stages = [li.clean() for li in dom.find(id="stages").kids("li")]
                expect(stages[-1] == "done" and "done" in dom.find(id="stages").kids("li")[-1].classes(), f"the build's stages {stages}")
                renders = dom.find(id="render-jobs").find("tbody").kids("tr")
                expect(len(renders) >= 4 and all("succeeded" in r.clean() for r in renders), f"{len(renders)} render jobs, not all succeeded")
                bw, bh, bsize = page.screenshot(out / "13-admin-build.png")
                page.goto(f"{base}/admin/releases/{board['release']}/quality")
                _, dom = page.dom()
                measures = dom.find(id="quality-compare").find("tbody").kids("tr")
                expect(any("scenes passing the bar" in m.clean() for m in measures), "no quality measures")
                boards = dom.find_all("table", cls="draft-board")
                expect(len(boards) == 2 and all(len(b.find("tbody").kids("tr")) == EXPECTED_ENTRIES for b in boards), f"the release's own boards: {len(boards)} tables")
                qw, qh, qsize = page.screenshot(out / "14-admin-quality.png")
                return (f"signed in through the form; {len(releases)} releases, {len(rows)} submissions; flagged and cleared through the forms; "
                        f"build with {len(renders)} render jobs; 12-admin-console.png {w}x{h}, 13-admin-build.png {bw}x{bh}, 14-admin-quality.png {qw}x{qh}")
            finally:
                page.close()

        run("internal links", internal_links)
        run("operator console (sign in, flag, build, quality)", operator_console)

        def about_page():
            page, dom, shot = load("/about", "17-about")
            try:
                expect(dom.find("h1").clean() == "About OSMa-Bench++", f"the About page's title is {dom.find('h1').clean()!r}")
                for section in ("take-part", "splits", "cite", "licence"):
                    expect(dom.find(id=section) is not None, f"the About page has no #{section} section")
                expect(board["release"] in dom.clean(), "the About page does not name the current release")
            finally:
                page.close()
            # Every page the checks above opened links to it (the saved DOM of each).
            dumps = sorted(out.glob("*.html"))
            missing = [d.name for d in dumps if 'href="/about"' not in d.read_text()]
            expect(dumps and not missing, f"pages without a link to /about: {missing}")
            return f"{shot}; linked from all {len(dumps)} pages opened"

        def take_part():
            # A stranger asks for access on the page, as a user would.
            page, dom, shot = load("/take-part", "30-take-part")
            try:
                for field, value in (("team_name", "Stranger Lab"), ("contact", "lead@stranger.example"), ("affiliation", "Stranger University"),
                                     ("method_url", "https://stranger.example/paper")):
                    page.type_into(f"#ask-access input[name={field}]", value)
                page.click_and_wait("#ask-access button")
                _, dom = page.dom()
                code_node = dom.find(id="claim-code")
                expect(code_node is not None and code_node.clean().startswith("osmab_claim_"), "asking shows no claim code")
                code = code_node.clean()
                aw, ah, _ = page.screenshot(out / "31-take-part-asked.png")
                # The operator approves it in the console (signed in by the console check).
                page.goto(f"{base}/admin")
                _, dom = page.dom()
                if dom.find(id="admin-access-requests") is None and dom.find("input", id="token") is not None:
                    page.type_into("#token", os.environ.get("OSMAB_ADMIN_TOKEN") or (data_dir / "admin-token").read_text().strip())
                    page.click_and_wait("form.admin-form button")
                    _, dom = page.dom()
                rows = dom.find(id="admin-access-requests").find("tbody").kids("tr")
                expect(any("Stranger Lab" in r.clean() for r in rows), f"the console does not list the request: {[r.clean() for r in rows]}")
                form = next(f for f in dom.find(id="admin-access-requests").find_all("form") if f.attrs.get("action", "").endswith("/approve"))
                page.click_and_wait(f"form[action='{form.attrs['action']}'] button")
                _, dom = page.dom()
                expect("Stranger Lab is created" in dom.find("p", cls="notice").clean(), "no notice after approving")
                # The stranger collects the token with the code, once; it works.
                page.goto(f"{base}/take-part")
                page.type_into("#collect-access input[name=claim_code]", code)
                page.click_and_wait("#collect-access button")
                _, dom = page.dom()
                token_node = dom.find(id="team-token")
                expect(token_node is not None, "collecting shows no token")
                req = urllib.request.Request(f"{base}/api/v1/me", headers={"Authorization": f"Bearer {token_node.clean()}"})
                with urllib.request.urlopen(req, timeout=30) as r:
                    me = json.loads(r.read())
                expect(me["team"]["name"] == "Stranger Lab", f"the collected token is not the team's: {me}")
                cw, ch, _ = page.screenshot(out / "32-take-part-collected.png")
            finally:
                page.close()
            phone, _, phone_shot = load("/take-part", "33-take-part-phone", width=PHONE_WIDTH)
            try:
                scroll, width = phone.overflow()
                expect(scroll <= width + 1, f"the Take part page scrolls sideways at {PHONE_WIDTH} px ({scroll} > {width})")
            finally:
                phone.close()
            return f"{shot}; asked, approved in the console, collected a working token; 31-take-part-asked.png {aw}x{ah}, 32-take-part-collected.png {cw}x{ch}; {phone_shot}"

        run("about page, linked from every page", about_page)
        run("take part: ask, approve in the console, collect the token", take_part)

        def not_found_page():
            page = Page(browser)
            try:
                loaded = page.goto(base + "/release")
                doc = loaded["document"]
                expect(doc["status"] == 404 and doc.get("mimeType") == "text/html", f"a mistyped page answers {doc['status']} {doc.get('mimeType')}")
                html_text, dom = page.dom()
                (out / "34-not-found.html").write_text(html_text)
                expect(dom.find("h1").clean() == "Not found" and dom.find("header", cls="site") is not None, f"a mistyped page shows {dom.find('h1').clean()!r}")
                expect('rel="icon"' in html_text, "no favicon link")
                w, h, _ = page.screenshot(out / "34-not-found.png")
            finally:
                page.close()
            with urllib.request.urlopen(f"{base}/static/favicon.svg", timeout=30) as r:
                expect(r.headers.get("content-type") == "image/svg+xml", f"the favicon answers {r.headers.get('content-type')}")
            return f"34-not-found.png {w}x{h}: an HTML page with the site's navigation, not problem+json; favicon served"

        run("a mistyped page: an HTML 404", not_found_page)

        def phone_width():
            # 390 x 844 CSS px, as an iPhone 12-15; signed in (the console's cookie), so the
            # operator's pages are checked too.
            entry = next((e for e in board["entries"] if e["method"] == "baseline-pose-drift"), board["entries"][0])
            pages = [
                ("/", "20-phone-leaderboard"),
                ("/?split=val", "21-phone-leaderboard-val"),
                (f"/submissions/{entry['submission_id']}", "22-phone-submission"),
                (f"/releases/{board['release']}", "23-phone-release"),
                ("/about", "24-phone-about"),
                ("/api/docs", "25-phone-api-docs"),
                ("/admin", "26-phone-admin"),
                (f"/admin/releases/{board['release']}/quality", "27-phone-admin-quality"),
            ]
            if state.get("build_page"):
                pages.append((state["build_page"], "28-phone-admin-build"))
            wide, notes = [], []
            for path, shot in pages:
                page, dom, _ = load(path, shot, width=PHONE_WIDTH)
                try:
                    scroll, inner = page.overflow()
                    notes.append(f"{path} {scroll}/{inner}")
                    if scroll > inner:
                        wide.append(f"{path}: {scroll} px wide in {inner}")
                    if path == "/":
                        # The first screen shows numbers: the board's first row is within it.
                        first = page.cmd("DOM.getBoxModel", {"nodeId": page.node("#leaderboard tbody tr")})["model"]["content"]
                        expect(first[1] < PHONE_HEIGHT, f"the board's first row starts at {first[1]:.0f} px, below the first screen")
                        svg = page.boxes("svg.chart.narrow")
                        expect(svg and svg[0][0] > 300, f"the narrow chart renders at {svg}")
                        # The board itself fits: no sideways scrolling inside its wrapper either.
                        (tw, _), = page.boxes("#leaderboard")
                        ww = page.boxes(".table-wrap")[0][0]
                        expect(tw <= ww + 1, f"the board is {tw:.0f} px wide in a {ww:.0f} px wrapper at {PHONE_WIDTH} px")
                    if path == "/?split=val":
                        # Too few scenes for groups: the rank, not an empty group column, shows.
                        ranks = page.boxes("#leaderboard tbody td.rank")
                        expect(ranks and ranks[0][0] > 0, f"no rank visible on the val board at {PHONE_WIDTH} px: {ranks}")
                finally:
                    page.close()
            expect(not wide, "wider than the phone: " + "; ".join(wide))
            return f"{len(pages)} pages, none wider than {PHONE_WIDTH} px (scrollWidth/innerWidth: " + ", ".join(notes) + ")"

        run(f"no horizontal overflow at {PHONE_WIDTH} px", phone_width)

        def build_while_running():
            # Start a small build through the regeneration form, as an operator would, and
            # read its page while it runs: the stage it is in and how long it has taken.
            config = BUILD_CONFIG
            page = Page(browser)
            try:
                page.goto(f"{base}/admin")
                page.cmd("DOM.focus", {"nodeId": page.node("#config")})
                for kind in ("keyDown", "keyUp"):
                    page.cmd("Input.dispatchKeyEvent", {"type": kind, "key": "a", "code": "KeyA", "modifiers": 2, "commands": ["selectAll"] if kind == "keyDown" else []})
                page.cmd("Input.insertText", {"text": config})
                page.click("form[action='/admin/regenerate'] input[name=baselines]")  # no baselines: a draft only
                page.click_and_wait("form[action='/admin/regenerate'] button")
                _, dom = page.dom()
                # The form leads to the new build's page.
                title = dom.find("h1").clean()
                expect(title.startswith("Build of release browser-1"), f"starting the build led to {title!r}")
                job_path = "/admin/jobs/" + dom.find("h1").find("small").clean()
                seen, deadline = [], time.monotonic() + args.timeout
                while time.monotonic() < deadline:
                    page.goto(base + job_path)
                    _, dom = page.dom()
                    current = [li.clean() for li in dom.find(id="stages").kids("li") if "current" in li.classes()]
                    status = dom.find(id="build-status").clean()
                    elapsed = dom.find(id="elapsed").clean()
                    if current and current[0] != "done":
                        expect(re.match(r"\d+ (s|min)", elapsed), f"no elapsed time on the running build's page: {status!r}")
                        if not seen or seen[-1][0] != current[0]:
                            seen.append((current[0], status))
                            if current[0] == "rendering":
                                expect(re.search(r"\d+ of \d+ scenes", status), f"the rendering stage does not say how far it is: {status!r}")
                                page.screenshot(out / "29-admin-build-running.png")
                    if "done" in dom.find(id="stages").kids("li")[-1].classes() or "failed" in status:
                        break
                    time.sleep(0.3)
                expect(seen, "never saw the build running")
                expect("failed" not in status, f"the build failed: {status}")
                renders = dom.find(id="render-jobs").find("tbody").kids("tr")
                expect(renders and all("rendered in" in r.clean() for r in renders), f"finished render rows: {[r.clean() for r in renders][:2]}")
                qpage, qdom, qshot = load("/admin/releases/browser-1/quality", "30-admin-quality-draft")
                try:
                    figures = qdom.find(cls="sheets-compare").find_all("figure")
                    expect(len(figures) == 2 and "current" in figures[1].clean(), f"{len(figures)} contact sheets on the draft's quality page")
                    shown = qpage.boxes(".sheets-compare img")
                    expect(len(shown) == 2 and all(h > 100 for _, h in shown), f"the draft's and the current release's sheets render at {shown}")
                    expect("No entry is scored on browser-1 yet" in qdom.clean(), "a draft without baselines does not say its boards are empty")
                finally:
                    qpage.close()
                return "while running: " + "; ".join(f"{stage}: {status}" for stage, status in seen) + f"; then done ({len(renders)} render rows say 'rendered in')"
            finally:
                page.close()

        run("a build's page while it runs (stage, elapsed, remaining)", build_while_running)

        def earlier_release_stays_reachable():
            # The operator publishes the draft just built: it becomes the current release,
            # and the first release's board stays one click away on the switcher.
            first = board["release"]
            token = os.environ.get("OSMAB_ADMIN_TOKEN") or (data_dir / "admin-token").read_text().strip()
            req = urllib.request.Request(f"{base}/api/v1/admin/releases/browser-1/publish", method="POST", headers={"Authorization": f"Bearer {token}"})
            with urllib.request.urlopen(req, timeout=60) as r:
                expect(r.status == 200, f"publishing browser-1 answered {r.status}")
            page, dom, _ = load("/", "35-leaderboard-after-a-new-release")
            try:
                choices = [(a.clean(), a.attrs.get("href", ""), "active" in a.classes()) for a in dom.find_all("a") if "release-choice" in a.classes()]
                labels = " ".join(label for label, _, _ in choices)
                expect(len(choices) >= 2 and first in labels and "browser-1" in labels, f"the release switcher lists {choices}")
                active = [label for label, _, on in choices if on]
                expect(len(active) == 1 and "browser-1" in active[0], f"the current release is not the one marked: {choices}")
                expect(page.boxes(".release-choice"), "the release switcher is not rendered")
            finally:
                page.close()
            older = next(href for label, href, _ in choices if first in label)
            page, dom, _ = load(older, "36-leaderboard-earlier-release")
            try:
                notice = dom.find(id="older-release")
                expect(notice is not None and "browser-1" in notice.clean(), f"the earlier board does not name the current release: {notice and notice.clean()}")
                rows = dom.find(id="leaderboard").find("tbody").kids("tr")
                expect(len(rows) == len(board["entries"]), f"the earlier board shows {len(rows)} entries, {len(board['entries'])} were scored on it")
            finally:
                page.close()
            return f"switcher: {labels}; {older} keeps its {len(rows)} entries and names browser-1 as current"

        run("an earlier release's board stays reachable (release switcher)", earlier_release_stays_reachable)
    except Fatal as e:
        results.append(("setup", False, time.monotonic() - started, str(e)))
        log(f"FATAL {e}")
    finally:
        if browser is not None:
            browser.close()
        if server is not None:
            code, took = server.stop(30)
            ok = code == 0
            results.append(("server stops on SIGTERM", ok, took, f"exit status {code}" if code is not None else "still running after 30 s, killed"))
            log(f"{'PASS' if ok else 'FAIL'} server stop: exit {code} after {took:.1f} s")
        if args.keep:
            log(f"kept {tmp} (data dir {data_dir})")
        else:
            shutil.rmtree(tmp, ignore_errors=True)

    total = time.monotonic() - started
    width = max(len(r[0]) for r in results)
    print()
    print(f"{'check':<{width}}  result  time    detail")
    print(f"{'-' * width}  ------  ------  ------")
    for name, ok, secs, detail in results:
        print(f"{name:<{width}}  {'PASS' if ok else 'FAIL':<6}  {secs:5.1f}s  {detail}")
    failed = [r for r in results if not r[1]]
    passed = len(results) - len(failed)
    print()
    print(f"screenshots and DOM dumps in {out}; total {total:.1f} s")
    print(f"browser: {passed} passed, {len(failed)} failed")
    if failed:
        print("FAILED: " + "; ".join(f"{r[0]}: {r[3]}" for r in failed), file=sys.stderr)
        if any(r[0] == "setup" for r in failed):
            return 2
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())

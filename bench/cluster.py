"""What the multi-process benchmarks share: free ports, waiting for a listener, a scratch
PostgreSQL database, and a set of processes that log into one folder and are stopped
(SIGTERM, then SIGKILL after 60 s) and cleaned up together.

Standard library only (and the `psql` client)."""

from __future__ import annotations

import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_listening(port, process, log, seconds=60):
    started = time.time()
    while time.time() - started < seconds:
        if process.poll() is not None:
            sys.exit(f"a process exited early; see {log}")
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            return
        except OSError:
            time.sleep(0.1)
    sys.exit(f"nothing listened on {port} after {seconds} s; see {log}")


def psql(url, sql):
    subprocess.run(["psql", url, "-v", "ON_ERROR_STOP=1", "-q", "-c", sql], check=True, capture_output=True)


class Cluster:
    """A scratch folder (`root`) where every process logs, a fresh database on the
    PostgreSQL server of `admin_url` (`database_url`), and the processes started."""

    def __init__(self, admin_url, prefix):
        self.root = tempfile.mkdtemp(prefix=prefix)
        self.processes = []
        self.admin_url = admin_url
        self.database = "osmab_bench_" + secrets.token_hex(4)
        psql(self.admin_url, f"CREATE DATABASE {self.database}")
        parsed = urllib.parse.urlsplit(self.admin_url)
        self.database_url = urllib.parse.urlunsplit(parsed._replace(path="/" + self.database))

    def log(self, name):
        return os.path.join(self.root, name + ".log")

    def spawn(self, name, argv, env):
        """Start `argv` with exactly `env`, its stderr into `name`.log."""
        process = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=open(self.log(name), "w"))
        self.processes.append(process)
        return process

    def close(self, keep=False):
        """Stop every process (the last started first), drop the database, and remove the
        folder unless `keep` (then say where the logs are)."""
        for process in reversed(self.processes):
            if process.poll() is None:
                process.send_signal(signal.SIGTERM)
        for process in self.processes:
            try:
                process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                process.kill()
        try:
            psql(self.admin_url, f"DROP DATABASE IF EXISTS {self.database} WITH (FORCE)")
        except subprocess.CalledProcessError as e:
            print("could not drop", self.database, e.stderr, file=sys.stderr)
        if keep:
            print("logs kept in", self.root)
        else:
            shutil.rmtree(self.root, ignore_errors=True)

"""Scale-out: several server processes behind one address answer any request (components are stateless)."""
from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import requests

from tests.ghserver.conftest import hops_body, hops_tree

ROOT = Path(__file__).resolve().parents[2]


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(url, timeout=60):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        try:
            if requests.get(url, timeout=1).status_code == 200:
                return
        except requests.RequestException:
            time.sleep(0.2)
    raise RuntimeError(f"server at {url} did not start")


@pytest.mark.skipif(not hasattr(socket, "SO_REUSEPORT"), reason="SO_REUSEPORT not available")
def test_two_processes_on_one_port_share_the_load():
    port = _free_port()
    cmd = [sys.executable, "-m", "ghserver", "--log-level", "WARNING", "serve", "--port", str(port), "--reuse-port",
           "--workers", "0", "--components", "tests.ghserver.echo:registry"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    procs = [subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
             for _ in range(2)]
    try:
        url = f"http://127.0.0.1:{port}"
        _wait(url + "/test/nap")
        time.sleep(1.0)  # let the second process come up too
        pids = set()
        for i in range(60):
            # a fresh connection each time, so the kernel can pick either process
            r = requests.post(f"{url}/solve", json=hops_body("test/nap", hops_tree("seconds", ["0"])),
                              headers={"Connection": "close"}, timeout=10)
            assert r.status_code == 200
            pids.add(int(r.json()["values"][1]["InnerTree"]["{0}"][0]["data"]))
            r = requests.post(f"{url}/solve", json=hops_body("echo/scale", hops_tree("x", [str(i + 0.5)])),
                              headers={"Connection": "close"}, timeout=10)
            assert float(r.json()["values"][0]["InnerTree"]["{0}"][0]["data"]) == 2.0 * (i + 0.5)
        assert pids == {p.pid for p in procs}, "both processes answered"
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait(timeout=10)

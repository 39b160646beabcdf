"""Abuse benchmark: the attacks of issue #20 at full size against a real ``ghserver serve`` on its defaults.

For each attack it prints the request size, the answer (status, JSON or not), the time, the peak resident memory
of the solver processes and of the server process during the attack (VmHWM from /proc, reset before each attack),
and whether the catalogue and a small solve were still answered right after. The target: every answer JSON, the
server responsive, and no solver process over 200 MB for a refused request.

    python benchmarks/abuse.py [--workers 2] [--quick]

Linux only (/proc).
"""
from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import requests

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from ghserver.workers import peak_rss_mb, reset_peak_rss  # noqa: E402
from tests.ghserver import attacks  # noqa: E402


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def children(pid: int) -> list[int]:
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    if int(f.read().rsplit(")", 1)[1].split()[1]) == pid:
                        out.append(int(d))
            except (OSError, ValueError, IndexError):
                pass
    return out


def worker_pids(server_pid: int) -> list[int]:
    """Solver processes: forked by the forkserver, itself a child of the server."""
    return [w for c in children(server_pid) for w in children(c)]


def small_solve(url: str) -> bool:
    body = {"pointer": "metrics/planarity", "values": [{"ParamName": "mesh", "InnerTree": {}}]}
    try:
        cat = requests.get(url + "/", timeout=10).status_code == 200
        r = requests.post(url + "/solve", json=body, timeout=30)
        return cat and r.headers.get("Content-Type", "").startswith("application/json")
    except requests.RequestException:
        return False


def send(url: str, data: bytes, headers: dict | None = None):
    try:
        r = requests.post(url + "/solve", data=data, timeout=300,
                          headers={"Content-Type": "application/json", **(headers or {})})
        ctype = r.headers.get("Content-Type", "")
        is_json = ctype.startswith("application/json")
        msg = (r.json().get("errors") or [""])[0] if is_json else r.text[:80]
        return r.status_code, is_json, msg
    except requests.RequestException as exc:
        return 0, False, f"{type(exc).__name__}"


def idle_connections(url: str, port: int, n: int = 300):
    socks = [socket.create_connection(("127.0.0.1", port), timeout=10) for _ in range(n)]
    try:
        t0 = time.perf_counter()
        ok = small_solve(url)
        return (200 if ok else 0), ok, f"{n} idle connections open: catalogue + solve in " \
                                        f"{1000 * (time.perf_counter() - t0):.0f} ms"
    finally:
        for s in socks:
            s.close()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--quick", action="store_true", help="smaller bombs and bodies")
    args = ap.parse_args()
    if not os.path.exists("/proc/self/status"):
        raise SystemExit("needs Linux /proc")
    port = free_port()
    url = f"http://127.0.0.1:{port}"
    proc = subprocess.Popen([sys.executable, "-m", "ghserver", "--log-level", "WARNING", "serve", "--port", str(port),
                             "--workers", str(args.workers)], cwd=ROOT)
    try:
        end = time.monotonic() + 120
        while time.monotonic() < end:
            try:
                if requests.get(url + "/", timeout=1).status_code == 200:
                    break
            except requests.RequestException:
                time.sleep(0.3)
        small_solve(url)  # workers up
        big = 178_000_000 if not args.quick else 20_000_000  # the largest a uint32 buffer size allows: 6.4 GB
        cases = [
            ("bomb: mesh inflating to 36 MB", lambda: attacks.bomb_body("metrics/planarity", "mesh", 10**6)),
            ("bomb: mesh inflating to 1.7 GB", lambda: attacks.bomb_body("metrics/planarity", "mesh", 47_000_000)),
            (f"bomb: mesh inflating to {36 * big / 1e9:.1f} GB",
             lambda: attacks.bomb_body("metrics/planarity", "mesh", big)),
            ("20 meshes of 4.9M vertices in one branch",
             lambda: attacks.bomb_body("metrics/planarity", "mesh", 4_900_000, copies=20)),
            ("JSON of {},{},… (26x once parsed)", lambda: attacks.empty_objects_body(94 if not args.quick else 20)),
            ("integer of 5,000 digits", lambda: attacks.long_integer_body(5000)),
            ("body over the 512 MB limit", lambda: b" " * ((600 if not args.quick else 520) * 2**20)),
        ]
        server_pid = proc.pid
        rows = []
        for name, make in cases:
            data = make()
            pids = worker_pids(server_pid)
            for p in pids + [server_pid]:
                reset_peak_rss(p)
            t0 = time.perf_counter()
            status, is_json, msg = send(url, data)
            dt = time.perf_counter() - t0
            peak = max([peak_rss_mb(p) for p in set(pids) | set(worker_pids(server_pid))] + [0])
            rows.append((name, len(data), status, is_json, dt, peak, peak_rss_mb(server_pid), small_solve(url), msg))
            del data
        # cross-site and connection attacks
        good = json.dumps({"pointer": "metrics/planarity", "values": []}).encode()
        for name, headers in (("cross-site text/plain POST", {"Content-Type": "text/plain",
                                                             "Origin": "http://evil.example"}),
                              ("DNS-rebound Host", {"Host": f"evil.example:{port}"})):
            pids = worker_pids(server_pid)
            for p in pids + [server_pid]:
                reset_peak_rss(p)
            t0 = time.perf_counter()
            status, is_json, msg = send(url, good, headers)
            rows.append((name, len(good), status, is_json, time.perf_counter() - t0,
                         max(peak_rss_mb(p) for p in pids), peak_rss_mb(server_pid), small_solve(url), msg))
        t0 = time.perf_counter()
        status, ok, msg = idle_connections(url, port)
        rows.append(("300 idle connections", 0, status, ok, time.perf_counter() - t0,
                     max(peak_rss_mb(p) for p in worker_pids(server_pid)), peak_rss_mb(server_pid), ok, msg))
    finally:
        proc.terminate()
        proc.wait(30)
    print(f"ghserver serve --workers {args.workers} (defaults otherwise)")
    print("| attack | request | answer | JSON | time | peak solver process | peak server process | "
          "responsive after | message |")
    print("|---|---:|---:|---|---:|---:|---:|---|---|")
    for name, size, status, is_json, dt, peak, speak, ok, msg in rows:
        print(f"| {name} | {size / 2**20:.2f} MB | {status} | {'yes' if is_json else 'NO'} | {dt:.2f} s | "
              f"{peak:.0f} MB | {speak:.0f} MB | {'yes' if ok else 'NO'} | {msg[:90]} |")
    bad = [r for r in rows if not r[3] or r[5] >= 200 or not r[7]]
    print("target met: every answer JSON, solver processes under 200 MB, server responsive" if not bad
          else f"target missed by: {', '.join(r[0] for r in bad)}")
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())

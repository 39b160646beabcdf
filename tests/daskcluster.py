"""A real Dask cluster on loopback for the tests: one ``dask scheduler`` and N ``dask worker`` processes.

The processes are the ones a user starts by hand (``python -m distributed.cli.dask_scheduler`` is the ``dask
scheduler`` command), so the tests exercise the same wire protocol, pickling and retries as a deployment.

Use: ``with LoopbackCluster(workers=2) as cluster: ...`` then connect to ``cluster.address``.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

START_TIMEOUT = 60.0


class LoopbackCluster:
    """Start a scheduler and ``workers`` single-threaded worker processes on 127.0.0.1; ``close()`` stops them."""

    def __init__(self, workers: int = 2, *, nthreads: int = 1, memory_limit: str = "4GiB"):
        self._dir = tempfile.TemporaryDirectory(prefix="pq-dask-")
        self.scheduler_file = Path(self._dir.name) / "scheduler.json"
        env = dict(os.environ, DASK_DISTRIBUTED__WORKER__DAEMON="False", PYTHONUNBUFFERED="1")
        self._env = env
        self._nthreads = nthreads
        self._memory_limit = memory_limit
        self.scheduler = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0",
             "--dashboard-address", ":0", "--scheduler-file", str(self.scheduler_file)],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, cwd=self._dir.name)
        self.address = self._wait_address()
        self.workers: list[subprocess.Popen] = []
        try:
            for i in range(workers):
                self.add_worker(f"w{i}")
            self.wait_workers(workers)
        except Exception:
            self.close()
            raise

    def _wait_address(self) -> str:
        deadline = time.monotonic() + START_TIMEOUT
        while time.monotonic() < deadline:
            if self.scheduler.poll() is not None:
                raise RuntimeError("dask scheduler exited at start")
            try:
                return json.loads(self.scheduler_file.read_text())["address"]
            except (OSError, ValueError, KeyError):
                time.sleep(0.1)
        raise TimeoutError("dask scheduler did not start")

    def add_worker(self, name: str) -> subprocess.Popen:
        """Start one more worker process (``dask worker ADDRESS``)."""
        proc = subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--nworkers", "1",
             "--nthreads", str(self._nthreads), "--memory-limit", self._memory_limit, "--name", name,
             "--no-dashboard", "--no-nanny", "--local-directory", self._dir.name],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=self._env, cwd=self._dir.name)
        self.workers.append(proc)
        return proc

    def wait_workers(self, n: int, timeout: float = START_TIMEOUT) -> None:
        """Wait until the scheduler knows ``n`` workers."""
        from distributed import Client  # deferred import: only tests that start a cluster pay for it

        with Client(self.address, timeout=timeout) as client:
            client.wait_for_workers(n, timeout=timeout)

    def kill_worker(self, i: int = 0) -> None:
        """SIGKILL worker ``i`` (a crash, not a clean shutdown)."""
        proc = self.workers[i]
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
            proc.wait(10)

    def close(self) -> None:
        for proc in [*self.workers, self.scheduler]:
            if proc.poll() is None:
                proc.terminate()
        for proc in [*self.workers, self.scheduler]:
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait(5)
        self._dir.cleanup()

    def __enter__(self) -> "LoopbackCluster":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

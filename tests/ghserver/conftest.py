"""Fixtures for the server tests: an app with the echo components, and a real waitress server on loopback."""
from __future__ import annotations

import json
import threading

import pytest

from ghserver.app import Config, create_app
from ghserver.cli import make_server
from tests.conftest import data_file
from tests.ghserver import echo


def hops_tree(name: str, items: list, key: str = "{0}", type_: str | None = None) -> dict:
    """A Hops DataTree with one branch."""
    return {"ParamName": name, "InnerTree": {key: [{"type": type_, "data": d} if type_ else {"data": d}
                                                   for d in items]}}


def hops_body(pointer: str, *trees, **extra) -> dict:
    """A solve body shaped exactly as Hops 0.16 sends it (hops-protocol.md §1.4)."""
    body = {"absolutetolerance": 0.001, "angletolerance": 1.0, "modelunits": "Millimeters", "dataversion": 7,
            "algo": None, "pointer": pointer, "cachesolve": False, "values": list(trees), "warnings": [],
            "errors": []}
    body.update(extra)
    return body


def shared_json(name: str) -> dict:
    return json.loads(data_file(f"hops/{name}").read_text())


@pytest.fixture(scope="session")
def echo_registry():
    return echo.registry()


@pytest.fixture
def app(echo_registry):
    return create_app(Config(cache_size=0), registry=echo_registry)


@pytest.fixture
def client(app):
    return app.test_client()


class LiveServer:
    """A waitress server in a thread; stopped from its own loop thread so no socket is closed under select()."""

    def __init__(self, app, threads=8, **kw):
        self.server = make_server(app, "127.0.0.1", 0, threads=threads, **kw)
        self.port = self.server.effective_port
        self.url = f"http://127.0.0.1:{self.port}"
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        srv = self.server
        while not self._stop.is_set():
            srv.asyncore.loop(timeout=0.05, map=srv._map, count=1, use_poll=srv.adj.asyncore_use_poll)
        srv.close()

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self.thread.join(timeout=10)


@pytest.fixture
def live_server(echo_registry):
    """The echo components plus the published ones, on a real waitress server bound to a free loopback port."""
    from ghserver.endpoints import COMPONENTS
    from ghserver.registry import Registry

    reg = Registry(list(echo_registry) + list(COMPONENTS))
    with LiveServer(create_app(Config(cache_size=16), registry=reg)) as srv:
        yield srv

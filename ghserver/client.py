"""Python client: call any component of a running server with numpy arrays, trimesh or rhino3dm objects.

Example (against a running ``ghserver serve``; ``tests/ghserver/test_published.py`` calls every component this
way)::

    from ghserver.client import Client
    c = Client("http://127.0.0.1:5000")
    res = c.call("metrics/planarity", mesh=(V, F))
    res.max_planarity

Inputs are encoded by the kind the server's metadata declares; outputs come back as numpy arrays, floats,
``(V, F)`` tuples, … in a NamedTuple named after the component. An output spread over several branches comes
back as a dict ``{path tuple: value}``. Errors raise :class:`ClientError` with the server's message.

Long solves run as jobs (``POST /jobs/<component>``)::

    job = c.submit("fields/pq_from_conjugate_field", mesh=(V, T), target_length=2.0)
    c.status(job)["progress"]          # 0..1, with the stage in c.status(job)["stage"]
    res = c.result(job)                # waits; the same NamedTuple as c.call(...)
    c.cancel(job)                      # stops it (or forgets a finished one)
"""
from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from collections import namedtuple
from typing import Any

import numpy as np

from components.core.types import NurbsSurface, Plane
from ghserver import convert
from ghserver import params as P
from ghserver.protocol import format_path, parse_path


class ClientError(RuntimeError):
    """The server answered with errors (``status``, ``errors``) or could not be reached."""

    def __init__(self, message: str, status: int | None = None, errors: list[str] | None = None):
        super().__init__(message)
        self.status = status
        self.errors = errors or [message]


def _as_mesh(value):
    if isinstance(value, (tuple, list)) and len(value) in (2, 3):
        return np.asarray(value[0], dtype=np.float64), np.asarray(value[1], dtype=np.int64)
    if hasattr(value, "vertices") and hasattr(value, "faces"):  # trimesh.Trimesh
        return np.asarray(value.vertices, dtype=np.float64), np.asarray(value.faces, dtype=np.int64)
    if convert.is_rhino_object(value):
        return convert.to_value(value)
    raise TypeError(f"cannot use {type(value).__name__} as a mesh: pass (V, F), a trimesh mesh or a rhino3dm Mesh")


def _encode_input(kind: str, value) -> dict:
    if kind == "Mesh":
        V, F = _as_mesh(value)
        return {"type": "Rhino.Geometry.Mesh", "data": convert.encode_mesh(V, F)}
    if convert.is_rhino_object(value):
        if kind in ("Curve", "Surface"):
            return {"type": f"Rhino.Geometry.{type(value).__name__}", "data": convert.encode_object(value)}
        value = convert.to_value(value)
    if kind == "Surface":
        if not isinstance(value, NurbsSurface):
            raise TypeError("a Surface input needs a components.core.types.NurbsSurface or a rhino3dm surface")
        return {"type": "Rhino.Geometry.NurbsSurface", "data": convert.encode_surface(value)}
    if kind == "Plane" and not isinstance(value, Plane):
        value = Plane(*value)
    return P.encode_item(kind, value)


def _items(kind: str, access: str, value) -> list:
    if access == "item":
        return [value]
    if kind in ("Point", "Vector") and np.ndim(value) == 1:
        return [value]
    if isinstance(value, np.ndarray):
        return list(value)
    if kind == "Mesh" and isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], np.ndarray):
        return [value]
    if isinstance(value, (list, tuple)):
        return list(value)
    return [value]


def _decode_output(kind: str, access: str, tree: dict):
    branches = {parse_path(k): [P.decode_item(kind, it) for it in items] for k, items in tree.items()}

    def value(items):
        if access == "item" and len(items) == 1:
            return items[0]
        if kind in ("Number", "Integer", "Boolean"):
            dtype = {"Number": np.float64, "Integer": np.int64, "Boolean": bool}[kind]
            return np.asarray(items, dtype=dtype)
        if kind in ("Point", "Vector"):
            return np.asarray(items, dtype=np.float64).reshape(-1, 3)
        if kind == "Line":
            return np.asarray(items, dtype=np.float64).reshape(-1, 2, 3)
        return items

    if not branches:
        return None if access == "item" else []
    if len(branches) == 1:
        return value(next(iter(branches.values())))
    return {path: value(items) for path, items in branches.items()}


class Client:
    """A connection to a component server.

    Parameters
    ----------
    url : str
        Server root, e.g. ``"http://127.0.0.1:5000"``.
    timeout : float
        Seconds to wait for an answer (Hops' default is 100).
    api_key : str, optional
        Sent as the ``RhinoComputeKey`` header (servers bound beyond loopback require it).
    """

    def __init__(self, url: str = "http://127.0.0.1:5000", timeout: float = 100.0, api_key: str | None = None):
        self.url = url.rstrip("/")
        self.timeout = timeout
        self.headers = {"RhinoComputeKey": api_key} if api_key else {}
        self._meta: dict[str, dict] = {}

    def _request(self, url: str, data: bytes | None = None, headers: dict | None = None,
                 method: str | None = None) -> tuple[int, bytes]:
        """One HTTP exchange (standard library only): ``(status, body)``; unreachable servers raise ClientError."""
        req = urllib.request.Request(url, data=data, headers={**self.headers, **(headers or {})},
                                     method=method or ("POST" if data is not None else "GET"))
        try:
            with urllib.request.urlopen(req, timeout=self.timeout) as r:
                return r.status, r.read()
        except urllib.error.HTTPError as exc:  # an answer with an error status: its body holds the message
            return exc.code, exc.read()
        except (urllib.error.URLError, OSError) as exc:
            raise ClientError(f"cannot reach {self.url}: {getattr(exc, 'reason', exc)}") from None

    def _get(self, path: str):
        status, raw = self._request(f"{self.url}/{path.lstrip('/')}", headers={"Accept": "application/json"})
        body = self._json(status, raw)
        if status != 200:
            errors = body.get("Errors") or body.get("errors") or [f"HTTP {status}"]
            raise ClientError("; ".join(errors), status, errors)
        return body

    @staticmethod
    def _json(status: int, raw: bytes):
        try:
            return json.loads(raw.decode("utf-8"))
        except (ValueError, UnicodeDecodeError):
            raise ClientError(f"server answered HTTP {status} without JSON", status) from None

    def components(self) -> list[dict]:
        """The catalogue: metadata of every component."""
        return self._get("/")

    def metadata(self, uri: str) -> dict:
        """Metadata of one component (cached per client)."""
        uri = uri.strip("/")
        if uri not in self._meta:
            self._meta[uri] = self._get(uri)
        return self._meta[uri]

    def request_body(self, uri: str, inputs: dict[str, Any], absolute_tolerance: float | None = None,
                     angle_tolerance_degrees: float | None = None, model_units: str | None = None,
                     cachesolve: bool = False) -> dict:
        """The Hops-shaped solve body for ``inputs`` (omitted inputs get the component's defaults)."""
        meta = self.metadata(uri)
        names = [p["Name"] for p in meta["Inputs"]]
        unknown = set(inputs) - set(names)
        if unknown:
            raise ClientError(f"{uri} has no input(s) {sorted(unknown)}; its inputs are {names}")
        values = []
        for p in meta["Inputs"]:
            name, kind = p["Name"], p["ParamType"]
            access = "tree" if p.get("TreeAccess") else ("item" if p.get("AtMost") == 1 else "list")
            inner = {}
            if name in inputs and inputs[name] is not None:
                v = inputs[name]
                try:
                    if access == "tree":
                        inner = {format_path(tuple(k) if isinstance(k, tuple) else (int(k),)):
                                 [_encode_input(kind, x) for x in items] for k, items in v.items()}
                    else:
                        inner = {"{0}": [_encode_input(kind, x) for x in _items(kind, access, v)]}
                except (TypeError, ValueError, P.OutputError) as exc:
                    raise ClientError(f"{name}: {exc}") from None
            values.append({"ParamName": name, "InnerTree": inner})
        body = {"pointer": uri, "values": values, "cachesolve": cachesolve}
        if absolute_tolerance:
            body["absolutetolerance"] = absolute_tolerance
        if angle_tolerance_degrees:
            body["angletolerance"] = angle_tolerance_degrees
        if model_units:
            body["modelunits"] = model_units
        return body

    def call(self, uri: str, /, **inputs):
        """Solve component ``uri`` with keyword inputs; returns a NamedTuple of its outputs.

        Tolerances can be passed as ``_absolute_tolerance``, ``_angle_tolerance_degrees`` and ``_model_units``.
        Warnings from the server are in the result's ``warnings`` field.
        """
        uri = uri.strip("/")
        status, raw = self._post(uri, uri, inputs)
        return self._result(uri, status, self._json(status, raw))

    def _post(self, path: str, uri: str, inputs: dict) -> tuple[int, bytes]:
        opts = {k[1:]: inputs.pop(k) for k in list(inputs) if k.startswith("_")}
        body = self.request_body(uri, inputs, **opts)
        return self._request(f"{self.url}/{path}", data=json.dumps(body, ensure_ascii=False).encode("utf-8"),
                             headers={"Content-Type": "application/json; charset=utf-8"})

    def submit(self, uri: str, /, **inputs) -> str:
        """Start component ``uri`` as a job (inputs as for :meth:`call`); returns the job id at once."""
        uri = uri.strip("/")
        status, raw = self._post(f"jobs/{uri}", uri, inputs)
        resp = self._json(status, raw)
        if status != 202:
            errors = resp.get("errors") or [f"HTTP {status}"]
            raise ClientError(f"{uri}: " + "; ".join(errors), status, errors)
        return resp["id"]

    def status(self, job: str) -> dict:
        """A job's state (``queued``, ``running``, ``done``, ``failed``, ``cancelled``), ``progress`` 0..1 and
        ``stage``; a finished job's ``result`` is the raw ``/solve`` answer (see :meth:`result`)."""
        status, raw = self._request(f"{self.url}/jobs/{job}", headers={"Accept": "application/json"})
        resp = self._json(status, raw)
        if status != 200:
            errors = resp.get("errors") or [f"HTTP {status}"]
            raise ClientError("; ".join(errors), status, errors)
        return resp

    def result(self, job: str, timeout: float | None = None, poll: float = 0.5):
        """Wait for a job (at most ``timeout`` seconds, default: for ever) and return its outputs as :meth:`call`
        does; a failed or cancelled job raises :class:`ClientError`."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            st = self.status(job)
            if st["state"] == "cancelled":
                raise ClientError(f"job {job} was cancelled", 499, ["cancelled"])
            if st["state"] in ("done", "failed"):
                return self._result(st.get("component") or "", int(st.get("status") or 500), st.get("result") or {})
            if deadline is not None and time.monotonic() > deadline:
                raise ClientError(f"job {job} is still {st['state']} after {timeout:g} s "
                                  f"({100 * st.get('progress', 0):.0f}%)", None, ["timeout"])
            time.sleep(poll)

    def cancel(self, job: str) -> dict:
        """Cancel a queued or running job (its solver process is stopped), or forget a finished one."""
        status, raw = self._request(f"{self.url}/jobs/{job}", headers={"Accept": "application/json"},
                                    method="DELETE")
        resp = self._json(status, raw)
        if status != 200:
            errors = resp.get("errors") or [f"HTTP {status}"]
            raise ClientError("; ".join(errors), status, errors)
        return resp

    def _result(self, uri: str, status: int, resp: dict):
        """The NamedTuple of a ``/solve`` answer, or :class:`ClientError` with its errors."""
        errors = resp.get("errors") or []
        if status != 200 or errors:
            raise ClientError(f"{uri}: " + "; ".join(errors or [f"HTTP {status}"]), status, errors)
        meta = self.metadata(uri)
        outs = meta["Outputs"]
        by_name = {t.get("ParamName"): t.get("InnerTree", {}) for t in resp.get("values", [])}
        fields = [o["Name"] for o in outs] + ["warnings"]
        Result = namedtuple(meta.get("Name") or "Result", fields, rename=True)
        vals = [_decode_output(o["ParamType"], o.get("Access", "tree"), by_name.get(o["Name"], {})) for o in outs]
        return Result(*vals, resp.get("warnings", []))

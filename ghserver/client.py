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
"""
from __future__ import annotations

import json
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

    def _request(self, url: str, data: bytes | None = None, headers: dict | None = None) -> tuple[int, bytes]:
        """One HTTP exchange (standard library only): ``(status, body)``; unreachable servers raise ClientError."""
        req = urllib.request.Request(url, data=data, headers={**self.headers, **(headers or {})},
                                     method="POST" if data is not None else "GET")
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
        opts = {k[1:]: inputs.pop(k) for k in list(inputs) if k.startswith("_")}
        uri = uri.strip("/")
        body = self.request_body(uri, inputs, **opts)
        status, raw = self._request(f"{self.url}/{uri}", data=json.dumps(body, ensure_ascii=False).encode("utf-8"),
                                    headers={"Content-Type": "application/json; charset=utf-8"})
        resp = self._json(status, raw)
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

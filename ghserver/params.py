"""Hops param kinds ⇄ Python values: one item of a data tree at a time.

An input item is ``{"type": <.NET type name>, "data": <string>}`` (hops-protocol.md §3); clients such as
``compute_rhino3d`` leave ``type`` out and may put a number or a dict in ``data``, so decoding goes by the
declared kind of the input, never by ``type``. Output items follow the checklist encodings exactly: integers
never as ``"3.0"``, strings JSON-quoted without ASCII escaping, points as ``{"X","Y","Z"}``, no NaN.
"""
from __future__ import annotations

import json
import math
from typing import Any

import numpy as np

from components.core.types import NurbsCurve, NurbsSurface, Plane
from ghserver import convert


class ParamError(ValueError):
    """An input item cannot be read as its declared kind (message without the input name).

    ``status`` is the HTTP code: 400, or 413 when the item declares more than the server's limits allow.
    """

    status = 400

    def __init__(self, message: str, status: int = 400):
        super().__init__(message)
        self.status = status


def _geometry_error(exc: convert.DecodeError) -> ParamError:
    return ParamError(str(exc), getattr(exc, "status", 400))


# .NET type names written for outputs (hops-protocol.md §3, the "Output type Hops can decode" column)
OUTPUT_TYPES = {
    "Number": "System.Double",
    "Integer": "System.Int32",
    "Boolean": "System.Boolean",
    "Text": "System.String",
    "Point": "Rhino.Geometry.Point3d",
    "Vector": "Rhino.Geometry.Vector3d",
    "Plane": "Rhino.Geometry.Plane",
    "Line": "Rhino.Geometry.Line",
    "Curve": "Rhino.Geometry.Curve",
    "Mesh": "Rhino.Geometry.Mesh",
}


# ----------------------------------------------------------------------------------------------
# decoding


def _scalar_text(data) -> Any:
    """The scalar inside ``data``: Hops sends text ("2.5", "\\"abc\\""), other clients raw JSON values."""
    if isinstance(data, str):
        s = data.strip()
        try:
            return json.loads(s)
        except (ValueError, RecursionError):  # not JSON, or an integer of more than 4300 digits
            return s
    return data


def _finite(x: float) -> float:
    if not math.isfinite(x):
        raise ParamError(f"value {x!r} is not a finite number")
    return x


def decode_number(data) -> float:
    v = _scalar_text(data)
    if isinstance(v, bool):
        raise ParamError(f"expected a number, got the boolean {v!r}")
    if isinstance(v, (int, float)):
        return _finite(float(v))
    if isinstance(v, str):
        try:
            return _finite(float(v.replace(",", ".") if v.count(",") == 1 and "." not in v else v))
        except ValueError:
            pass
    raise ParamError(f"expected a number, got {_short(data)}")


def decode_integer(data) -> int:
    v = _scalar_text(data)
    if isinstance(v, bool):
        raise ParamError(f"expected an integer, got the boolean {v!r}")
    if isinstance(v, int):
        return v
    if isinstance(v, float) and math.isfinite(v) and v == int(v):
        return int(v)
    if isinstance(v, str):
        try:
            return int(v)
        except ValueError:
            pass
    raise ParamError(f"expected an integer, got {_short(data)}")


def decode_boolean(data) -> bool:
    v = _scalar_text(data)
    if isinstance(v, bool):
        return v
    if isinstance(v, str) and v.strip().lower() in ("true", "false"):
        return v.strip().lower() == "true"
    if isinstance(v, (int, float)) and v in (0, 1):
        return bool(v)
    raise ParamError(f"expected true or false, got {_short(data)}")


def decode_text(data) -> str:
    if isinstance(data, str):
        try:
            v = json.loads(data)
        except (ValueError, RecursionError):  # not JSON, an integer of more than 4300 digits, deep nesting
            return data
        return v if isinstance(v, str) else data
    if isinstance(data, (int, float, bool)):
        return json.dumps(data)
    raise ParamError(f"expected text, got {_short(data)}")


def _xyz(d, what: str) -> np.ndarray:
    if isinstance(d, dict):
        low = {str(k).lower(): v for k, v in d.items()}
        try:
            vals = [low["x"], low["y"], low["z"]]
        except KeyError:
            raise ParamError(f"expected a {what} with X, Y, Z, got {_short(d)}") from None
    elif isinstance(d, (list, tuple)) and len(d) == 3:
        vals = list(d)
    else:
        raise ParamError(f"expected a {what} with X, Y, Z, got {_short(d)}")
    try:
        arr = np.array([float(v) for v in vals], dtype=np.float64)
    except (TypeError, ValueError):
        raise ParamError(f"{what} coordinates must be numbers, got {_short(d)}") from None
    if not np.all(np.isfinite(arr)):
        raise ParamError(f"{what} has a NaN or infinite coordinate")
    return arr


def _json_value(data):
    if isinstance(data, str):
        try:
            return json.loads(data)
        except (ValueError, RecursionError):  # JSONDecodeError, an integer of more than 4300 digits, deep nesting
            raise ParamError(f"expected JSON, got {_short(data)}") from None
    return data


def decode_point(data, limits: dict | None = None) -> np.ndarray:
    v = _json_value(data)
    if isinstance(v, dict) and "archive3dm" in v:
        try:
            return convert.decode_point_object(v, limits)
        except convert.DecodeError as exc:
            raise _geometry_error(exc) from None
    return _xyz(v, "point")


def decode_vector(data) -> np.ndarray:
    return _xyz(_json_value(data), "vector")


def decode_plane(data) -> Plane:
    v = _json_value(data)
    if not isinstance(v, dict):
        raise ParamError(f"expected a plane, got {_short(data)}")
    low = {str(k).lower(): val for k, val in v.items()}
    if "origin" not in low:
        raise ParamError("plane has no Origin")
    origin = _xyz(low["origin"], "plane origin")
    if "xaxis" in low and "yaxis" in low:
        x = _xyz(low["xaxis"], "plane x axis")
        y = _xyz(low["yaxis"], "plane y axis")
    elif "normal" in low or "zaxis" in low:
        z = _xyz(low.get("zaxis", low.get("normal")), "plane normal")
        a = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 * np.linalg.norm(z) else np.array([0, 1.0, 0])
        x = np.cross(a, z)
        y = np.cross(z, x)
    else:
        raise ParamError("plane needs XAxis and YAxis (or a Normal)")
    nx = np.linalg.norm(x)
    if nx == 0:
        raise ParamError("plane x axis has zero length")
    x = x / nx
    y = y - x * np.dot(x, y)
    ny = np.linalg.norm(y)
    if ny < 1e-12:
        raise ParamError("plane axes are parallel")
    y = y / ny
    return Plane(origin, x, y, np.cross(x, y))


def decode_line(data, limits: dict | None = None) -> np.ndarray:
    v = _json_value(data)
    if isinstance(v, dict):
        low = {str(k).lower(): val for k, val in v.items()}
        if "from" in low and "to" in low:
            return np.stack([_xyz(low["from"], "line start"), _xyz(low["to"], "line end")])
        if "archive3dm" in low:
            curve = decode_curve(v, limits)
            if isinstance(curve, np.ndarray) and len(curve) == 2:
                return curve
            raise ParamError("expected a line, got a curve that is not a single segment")
    if isinstance(v, (list, tuple)) and len(v) == 2:
        return np.stack([_xyz(v[0], "line start"), _xyz(v[1], "line end")])
    raise ParamError(f"expected a line with From and To, got {_short(data)}")


def decode_curve(data, limits: dict | None = None):
    try:
        value = convert.decode_curve(data, limits)
    except convert.DecodeError as exc:
        raise _geometry_error(exc) from None
    P = value.points if isinstance(value, NurbsCurve) else value
    if not np.all(np.isfinite(P)):
        raise ParamError("curve has a NaN or infinite control point")
    return value


def decode_surface(data, limits: dict | None = None) -> NurbsSurface:
    try:
        value = convert.decode_surface(data, limits)
    except convert.DecodeError as exc:
        raise _geometry_error(exc) from None
    if not np.all(np.isfinite(value.points)):
        raise ParamError("surface has a NaN or infinite control point")
    return value


def decode_mesh(data, limits: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    try:
        V, F = convert.decode_mesh(data, limits)
    except convert.DecodeError as exc:
        raise _geometry_error(exc) from None
    bad = ~np.isfinite(V).all(axis=1)
    if bad.any():
        raise ParamError(f"mesh vertex {int(np.argmax(bad))} has a NaN or infinite coordinate")
    out = (F < 0) | (F >= len(V))
    if out.any():
        i = int(np.argmax(out.any(axis=1)))
        raise ParamError(f"mesh face {i} has a vertex index out of range 0..{len(V) - 1}: {F[i].tolist()}")
    return V, F


DECODERS = {
    "Number": decode_number,
    "Integer": decode_integer,
    "Boolean": decode_boolean,
    "Text": decode_text,
    "Point": decode_point,
    "Vector": decode_vector,
    "Plane": decode_plane,
    "Line": decode_line,
    "Curve": decode_curve,
    "Surface": decode_surface,
    "Mesh": decode_mesh,
}


GEOMETRY_KINDS = ("Point", "Line", "Curve", "Surface", "Mesh")  # decoders that take the server's size limits


def item_data(item):
    """The ``data`` of a tree item (``{"type", "data"}``), or the item itself when a client sent a bare value."""
    return item.get("data") if isinstance(item, dict) and "data" in item else item


def decode_item(kind: str, item, limits: dict | None = None) -> Any:
    """Decode one tree item (``{"type", "data"}`` or a bare value) as ``kind``.

    ``limits`` (``max_vertices``, ``max_faces``, ``max_inflated_mb``) bound what geometry may decode to; an item
    beyond them raises :class:`ParamError` with status 413 before it is decoded.
    """
    data = item_data(item)
    if data is None:
        raise ParamError("item has no data")
    if kind in GEOMETRY_KINDS:
        return DECODERS[kind](data, limits)
    return DECODERS[kind](data)


# ----------------------------------------------------------------------------------------------
# encoding


class OutputError(TypeError):
    """A component returned a value that cannot be sent as its declared kind (a bug, answered with 500)."""


def _num(x) -> float:
    try:
        f = float(x)
    except (TypeError, ValueError):
        raise OutputError(f"expected a number, got {type(x).__name__}") from None
    if not math.isfinite(f):
        raise OutputError("value is NaN or infinite")
    return f


def _xyz_json(p) -> dict:
    a = np.asarray(p, dtype=np.float64).reshape(-1)
    if a.shape != (3,):
        raise OutputError(f"expected 3 coordinates, got shape {np.shape(p)}")
    return {"X": _num(a[0]), "Y": _num(a[1]), "Z": _num(a[2])}


def encode_scalar(kind: str, value) -> str:
    if kind == "Number":
        if isinstance(value, (bool, np.bool_)):
            raise OutputError("expected a number, got a boolean")
        return repr(_num(value))
    if kind == "Integer":
        if isinstance(value, (float, np.floating)):
            if not (math.isfinite(value) and value == int(value)):
                raise OutputError(f"expected an integer, got {value!r}")
        try:
            return str(int(value))
        except (TypeError, ValueError):
            raise OutputError(f"expected an integer, got {type(value).__name__}") from None
    if kind == "Boolean":
        return "true" if bool(value) else "false"
    if kind == "Text":
        return json.dumps(str(value), ensure_ascii=False)
    raise AssertionError(kind)


def encode_item(kind: str, value) -> dict:
    """One output item ``{"type", "data"}`` for a value of ``kind``."""
    if kind in ("Number", "Integer", "Boolean", "Text"):
        data = encode_scalar(kind, value)
    elif kind in ("Point", "Vector"):
        data = json.dumps(_xyz_json(value))
    elif kind == "Plane":
        pl = value if isinstance(value, Plane) else Plane(*value)
        data = json.dumps({"Origin": _xyz_json(pl.origin), "XAxis": _xyz_json(pl.xaxis),
                           "YAxis": _xyz_json(pl.yaxis), "ZAxis": _xyz_json(pl.zaxis)})
    elif kind == "Line":
        a = np.asarray(value, dtype=np.float64)
        if a.shape != (2, 3):
            raise OutputError(f"a line must have shape (2, 3), got {a.shape}")
        data = json.dumps({"From": _xyz_json(a[0]), "To": _xyz_json(a[1])})
    elif kind == "Curve":
        pts = value.points if isinstance(value, NurbsCurve) else np.asarray(value, dtype=np.float64)
        if not np.all(np.isfinite(pts)):
            raise OutputError("curve has NaN or infinite points")
        data = convert.encode_curve(value)
    elif kind == "Mesh":
        if not isinstance(value, (tuple, list)) or len(value) not in (2, 3):
            raise OutputError(f"a mesh must be (V, F) or (V, F, colors), got {type(value).__name__}")
        V = np.asarray(value[0], dtype=np.float64)
        F = np.asarray(value[1], dtype=np.int64)
        if V.ndim != 2 or V.shape[1] != 3 or (len(F) and (F.ndim != 2 or F.shape[1] < 3)):
            raise OutputError(f"a mesh needs V (n, 3) and F (m, k>=3), got {V.shape} and {F.shape}")
        if not np.all(np.isfinite(V)):
            raise OutputError("mesh has NaN or infinite vertices")
        if len(F) and (F.min() < 0 or F.max() >= len(V)):
            raise OutputError("mesh face index out of range")
        colors = value[2] if len(value) == 3 else None
        data = convert.encode_mesh(V, F.reshape(-1, max(F.shape[1] if F.ndim == 2 else 4, 3)), colors)
    else:
        raise OutputError(f"unsupported output kind {kind}")
    return {"type": OUTPUT_TYPES[kind], "data": data}


def output_items(kind: str, access: str, value) -> list:
    """The values of one output for one iteration, as a list (item → 1 element, list → all)."""
    if access == "item":
        return [value]
    if value is None:
        return []
    if kind in ("Point", "Vector") and isinstance(value, np.ndarray) and value.ndim == 2:
        return list(value)
    if kind == "Line" and isinstance(value, np.ndarray) and value.ndim == 3:
        return list(value)
    if isinstance(value, np.ndarray):
        return value.tolist() if value.ndim == 1 else list(value)
    return list(value)


def _short(data, n: int = 60) -> str:
    s = data if isinstance(data, str) else repr(data)
    return repr(s[:n] + "…") if len(s) > n else repr(s)

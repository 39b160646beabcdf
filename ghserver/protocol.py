"""Hops JSON ⇄ component calls: data trees, tolerances, units, errors.

:func:`solve` is the whole solve path: request body (already parsed JSON) in, ``(status, response dict)`` out.
It never raises. It is a plain function of picklable arguments so it can run in a worker process with a time
limit without reshaping it.

Grasshopper semantics (hops-protocol.md §2): item and list inputs given several branches are solved branch by
branch with longest-list matching (the last branch / item repeats); within a branch, item inputs given several
items are solved item by item. Outputs keep the branch path of the input with the most branches; when a branch
is solved more than once, item outputs collect one value per iteration in that branch and list outputs get a
sub-branch per iteration (``{path;i}``), as Grasshopper does.
"""
from __future__ import annotations

import json
import logging
import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from components.core.errors import InputError
from ghserver import convert
from ghserver import params as P
from ghserver.registry import Component, Registry

log = logging.getLogger(__name__)

BAD_INPUTS = "Bad inputs"  # errors[0] that makes Hops re-fetch the metadata (hops-protocol.md §4.1)
MAX_TREE_DEPTH = 32


class RequestError(Exception):
    """A bad request; ``status`` is the HTTP code, the message names the input."""

    def __init__(self, message: str, status: int = 400, errors: list[str] | None = None):
        super().__init__(message)
        self.status = status
        self.errors = errors or [message]


@dataclass
class SolveRequest:
    pointer: str
    values: list = field(default_factory=list)
    absolutetolerance: float | None = None
    angletolerance: float | None = None  # degrees, as Hops sends it
    modelunits: str | None = None
    cachesolve: bool = True


# ----------------------------------------------------------------------------------------------
# request parsing


def pointer_uri(pointer: str) -> str:
    """Component URI of a ``pointer``: "foo", "/foo", "foo/", "http://host:5000/foo?x" and %-encoding."""
    from urllib.parse import unquote, urlsplit

    p = str(pointer).strip()
    if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*://", p):
        p = urlsplit(p).path
    p = p.split("?", 1)[0]
    return unquote(p).strip("/")


def parse_request(body: Any, uri: str | None = None) -> SolveRequest:
    """Validate the top level of a solve body; ``uri`` (direct POST) overrides ``pointer``."""
    if not isinstance(body, dict):
        raise RequestError(f"request body must be a JSON object, got {type(body).__name__}")
    pointer = uri if uri is not None else body.get("pointer")
    if not pointer:
        if body.get("algo"):
            raise RequestError("this server runs its own components; send 'pointer' (a component URI), not 'algo'")
        raise RequestError("request has no 'pointer' naming the component")
    if not isinstance(pointer, str):
        raise RequestError("'pointer' must be a string")
    values = body.get("values", [])
    if values is None:
        values = []
    if not isinstance(values, list):
        raise RequestError("'values' must be a list of data trees")
    tol = body.get("absolutetolerance")
    ang = body.get("angletolerance")
    for name, v in (("absolutetolerance", tol), ("angletolerance", ang)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0):
            raise RequestError(f"'{name}' must be a non-negative number, got {v!r}")
    units = body.get("modelunits")
    if units is not None and not isinstance(units, str):
        raise RequestError("'modelunits' must be a string")
    return SolveRequest(
        pointer=pointer_uri(pointer), values=values, absolutetolerance=float(tol) if tol else None,
        angletolerance=float(ang) if ang else None, modelunits=units, cachesolve=bool(body.get("cachesolve", True)),
    )


def parse_path(key) -> tuple[int, ...]:
    """Branch path of a tree key: ``{0;1}``, ``0;1``, ``{ 0; 1; }``, ``0`` → ``(0, 1)`` / ``(0,)``."""
    if not isinstance(key, str):
        raise ValueError(f"tree key {key!r} is not a string")
    s = key.strip().strip("{}").replace(" ", "")
    parts = [t for t in s.split(";") if t != ""]
    if not parts:
        raise ValueError(f"tree key {key!r} has no path")
    if len(parts) > MAX_TREE_DEPTH:
        raise ValueError(f"tree key {key[:40]!r} is deeper than {MAX_TREE_DEPTH} levels")
    try:
        path = tuple(int(t) for t in parts)
    except ValueError:
        raise ValueError(f"tree key {key!r} is not a path like {{0;1}}") from None
    if any(i < 0 or i > 2**31 - 1 for i in path):
        raise ValueError(f"tree key {key!r} has an index out of range")
    return path


def format_path(path: tuple[int, ...]) -> str:
    return "{" + ";".join(str(i) for i in path) + "}"


def _input_trees(component: Component, req: SolveRequest) -> dict[str, dict[tuple, list]]:
    """``{input name: {path: [items]}}`` (paths sorted) for every input present in the request."""
    known = {p.name for p in component.inputs}
    trees: dict[str, dict[tuple, list]] = {}
    unknown = []
    for i, tree in enumerate(req.values):
        if not isinstance(tree, dict):
            raise RequestError(f"values[{i}] must be an object with ParamName and InnerTree")
        name = tree.get("ParamName")
        if not isinstance(name, str):
            raise RequestError(f"values[{i}] has no ParamName")
        name = name[6:] if name.startswith("RH_IN:") else name
        if name not in known:
            unknown.append(name)
            continue
        inner = tree.get("InnerTree", {})
        if inner is None:
            inner = {}
        if not isinstance(inner, dict):
            raise RequestError(f"{name}: InnerTree must be an object mapping branch paths to item lists")
        branches: dict[tuple, list] = {}
        for key, items in inner.items():
            try:
                path = parse_path(key)
            except ValueError as exc:
                raise RequestError(f"{name}: {exc}") from None
            if items is None:
                items = []
            if not isinstance(items, list):
                raise RequestError(f"{name}: branch {key!r} must be a list of items")
            branches.setdefault(path, []).extend(items)
        if name in trees:
            raise RequestError(f"{name}: given twice")
        trees[name] = dict(sorted(branches.items()))
    if unknown:
        expected = ", ".join(p.name for p in component.inputs)
        msg = f"unknown input(s) {', '.join(map(repr, unknown))} for {component.uri} (inputs: {expected})"
        # Hops re-fetches the metadata on 500 "Bad inputs": the component changed since it was loaded
        raise RequestError(msg, status=500, errors=[BAD_INPUTS, msg])
    return trees


# ----------------------------------------------------------------------------------------------
# values of one input


DEFAULT_LIMITS = {
    "max_vertices": 5_000_000,  # per mesh
    "max_faces": 5_000_000,
    "max_request_vertices": 5_000_000,  # all meshes of one request together
    "max_request_faces": 5_000_000,
    "max_json_mb": 512,  # estimated size of the request's JSON once parsed
    "max_response_mb": 256,  # the answer's JSON
}
LIMIT_FLAGS = {key: "--" + key.replace("_", "-") for key in DEFAULT_LIMITS}
#: memory of one parsed JSON token (``{``, ``[``, ``,`` or ``:``) at most, in bytes: an empty dict in a list takes
#: 72 bytes for its 2 tokens, a one-key dict 67 per token, a dict's key and value 77 (measured on CPython 3.11)
JSON_BYTES_PER_TOKEN = 80


def resolve_limits(limits: dict | None) -> dict:
    """``limits`` completed with :data:`DEFAULT_LIMITS` and the derived ``max_inflated_mb`` (the compressed
    buffers a request's geometry may inflate to: 100 bytes per vertex of ``max_request_vertices``)."""
    out = dict(DEFAULT_LIMITS)
    out.update({k: v for k, v in (limits or {}).items() if v is not None})
    if "max_inflated_mb" not in (limits or {}):
        per_request = out.get("max_request_vertices") or out.get("max_vertices")
        out["max_inflated_mb"] = per_request * convert.INFLATED_BYTES_PER_VERTEX / 2**20 if per_request else None
    return out


def too_large(message: str, key: str, limit) -> RequestError:
    """A 413 that names the limit and the ``ghserver serve`` option changing it."""
    value = f"{limit:g} MB" if key.endswith("_mb") else f"{int(limit)}"
    return RequestError(f"{message} the server's limit of {value} (ghserver serve {LIMIT_FLAGS.get(key, key)})",
                        status=413)


def json_tokens(raw: bytes) -> int:
    """Structural tokens of a JSON text: ``{``, ``[``, ``,`` and ``:`` (those inside strings count too: an upper
    bound of the containers and items ``json.loads`` builds)."""
    return raw.count(b"{") + raw.count(b"[") + raw.count(b",") + raw.count(b":")


def check_json_size(raw: bytes, limits: dict | None = None) -> None:
    """Refuse (413) a body whose parsed JSON would take more than ``max_json_mb``, before parsing it.

    ``json.loads`` needs about its text's size for strings (Hops' geometry) but up to 26 times the text for small
    containers (``[{},{},…]``); the estimate is the text's size plus :data:`JSON_BYTES_PER_TOKEN` per structural
    token, counted at C speed.
    """
    limit = resolve_limits(limits).get("max_json_mb")
    if not limit:
        return
    estimate = len(raw) + JSON_BYTES_PER_TOKEN * json_tokens(raw)
    if estimate > limit * 2**20:
        raise too_large(f"the request's JSON would take about {estimate / 2**20:.0f} MB once parsed, more than",
                        "max_json_mb", limit)


def _check_declared_sizes(component: Component, trees: dict[str, dict[tuple, list]], limits: dict) -> None:
    """Refuse (413) meshes over the per-mesh limits, and requests whose meshes add up past the per-request
    budget, from the counts each archive declares in its first bytes, before any item is decoded."""
    totals = [0, 0]
    for p in component.inputs:
        if p.kind != "Mesh" or p.name not in trees:
            continue
        for path, items in trees[p.name].items():
            for j, item in enumerate(items):
                counts = convert.mesh_counts(P.item_data(item))
                if counts is None:
                    continue  # not readable cheaply: the decoder checks it (and refuses it) before decoding
                where = f" item {j}" if len(items) > 1 else ""
                branch = f" branch {format_path(path)}" if len(trees[p.name]) > 1 else ""
                for count, what, key in ((counts[0], "vertices", "max_vertices"), (counts[1], "faces", "max_faces")):
                    limit = limits.get(key)
                    if limit and count > limit:
                        raise too_large(f"{p.name}{branch}{where}: {count} {what} is more than", key, limit)
                totals[0] += counts[0]
                totals[1] += counts[1]
    for total, what, key in ((totals[0], "vertices", "max_request_vertices"),
                             (totals[1], "faces", "max_request_faces")):
        limit = limits.get(key)
        if limit and total > limit:
            raise too_large(f"the request's meshes have {total} {what} together, more than", key, limit)


def _check_size(param, value, limits: dict) -> None:
    """Refuse meshes beyond the server's limits before any component work (413, naming the input and limit)."""
    if param.kind != "Mesh":
        return
    V, F = value
    for count, what, key in ((len(V), "vertices", "max_vertices"), (len(F), "faces", "max_faces")):
        limit = limits.get(key)
        if limit and count > limit:
            flag = key.replace("_", "-")
            raise RequestError(f"{param.name}: {count} {what} is more than the server's limit of {limit} "
                               f"(ghserver serve --{flag})", status=413)


def _decode_items(param, items: list, limits: dict | None = None) -> list:
    limits = DEFAULT_LIMITS if limits is None else limits
    out = []
    for j, item in enumerate(items):
        try:
            out.append(P.decode_item(param.kind, item, limits))
            _check_size(param, out[-1], limits)
        except P.ParamError as exc:
            where = f" item {j}" if len(items) > 1 else ""
            raise RequestError(f"{param.name}{where}: {exc}", status=exc.status) from None
        except RecursionError:
            raise RequestError(f"{param.name}: item {j} is nested too deeply") from None
    return out


def _list_value(param, values: list):
    kind = param.kind
    if kind == "Number":
        return np.asarray(values, dtype=np.float64).reshape(-1)
    if kind == "Integer":
        return np.asarray(values, dtype=np.int64).reshape(-1)
    if kind == "Boolean":
        return np.asarray(values, dtype=bool).reshape(-1)
    if kind in ("Point", "Vector"):
        return np.asarray(values, dtype=np.float64).reshape(-1, 3)
    if kind == "Line":
        return np.asarray(values, dtype=np.float64).reshape(-1, 2, 3)
    return list(values)


# ----------------------------------------------------------------------------------------------
# the solve


def _context(component: Component, req: SolveRequest) -> dict:
    ctx = {}
    if "absolute_tolerance" in component.context and req.absolutetolerance:
        ctx["absolute_tolerance"] = req.absolutetolerance
    if "angle_tolerance" in component.context and req.angletolerance:
        ctx["angle_tolerance"] = math.radians(req.angletolerance)
    if "model_units" in component.context and req.modelunits:
        ctx["model_units"] = req.modelunits
    return ctx


def _iterations(component: Component, trees: dict[str, dict[tuple, list]], limits: dict | None = None):
    """Yield ``(path, iteration index, iteration count in branch, kwargs)`` following Grasshopper's matching."""
    inputs = component.inputs
    branched = [p for p in inputs if p.access != "tree"]
    # decoded tree inputs are passed whole to every call
    tree_values = {}
    for p in inputs:
        if p.access == "tree":
            t = trees.get(p.name, {})
            if not t and not p.optional and not p.has_default:
                raise RequestError(f"{p.name}: missing required input (the tree is empty)")
            if t:
                tree_values[p.name] = {path: _decode_items(p, items, limits) for path, items in t.items()}
            elif p.has_default:
                tree_values[p.name] = p.default
            else:
                tree_values[p.name] = None
    # branch lists per non-tree input (only non-empty branches count, as in Grasshopper)
    branch_lists = {p.name: [(path, items) for path, items in trees.get(p.name, {}).items() if items]
                    for p in branched}
    n_branches = max([len(b) for b in branch_lists.values()] + [1])
    master = max(branched, key=lambda p: len(branch_lists[p.name]), default=None)
    memo: dict[tuple[str, int], Any] = {}  # a repeated (last) branch is decoded once, not once per iteration

    def decoded_branch(p, k: int):
        if (p.name, k) not in memo:
            items = branch_lists[p.name][k][1]
            values = _decode_items(p, items, limits)
            memo[(p.name, k)] = _list_value(p, values) if p.access == "list" else values
        return memo[(p.name, k)]

    for b in range(n_branches):
        if master is not None and branch_lists[master.name]:
            bl = branch_lists[master.name]
            path = bl[min(b, len(bl) - 1)][0]
        else:
            path = (b,)
        decoded = {}
        for p in branched:
            bl = branch_lists[p.name]
            if not bl:
                if p.has_default or p.optional:
                    continue  # use the default
                raise RequestError(f"{p.name}: missing required input (no value given)")
            decoded[p.name] = decoded_branch(p, min(b, len(bl) - 1))
        counts = [len(decoded[p.name]) for p in branched if p.access == "item" and p.name in decoded]
        n_iter = max(counts + [1])
        for i in range(n_iter):
            kwargs = dict(tree_values)
            for p in branched:
                if p.name not in decoded:
                    continue  # default
                v = decoded[p.name]
                kwargs[p.name] = v[min(i, len(v) - 1)] if p.access == "item" else v
            yield path, i, n_iter, kwargs


def _check_list_lengths(component: Component, kwargs: dict):
    for p in component.inputs:
        if p.access == "list" and p.name in kwargs and not p.optional and len(kwargs[p.name]) == 0:
            raise RequestError(f"{p.name}: needs at least one item")


def _estimated_size(kind: str, value) -> int:
    """Bytes a Mesh output will take in the answer's JSON (raw buffers in base64), before it is encoded."""
    if kind == "Mesh" and isinstance(value, (tuple, list)) and len(value) >= 2:
        return (36 * len(value[0]) + 16 * len(value[1])) * 4 // 3
    return 0


def _unwelded_inputs(component: Component, kwargs: dict, said: list[str], seen: set) -> list[str]:
    """A warning for every mesh input with vertices at exactly the same position as others (a mesh not welded, e.g.
    a soup of faces with their own corners, as an exploded or joined-without-welding Rhino mesh is): every result
    that follows its edges (curvature, valence, joints, subdivision, remeshing) treats it as separate pieces, and a
    component that does not weld its input would say nothing. None where the component's own warnings speak of
    welding already. ``seen``: ids of the meshes checked before in this request (a mesh repeated over the iterations
    is decoded once and checked once)."""
    if any("weld" in w for w in said):
        return []
    out = []
    for p in component.inputs:
        value = kwargs.get(p.name)
        if (p.kind != "Mesh" or p.access != "item" or not isinstance(value, tuple) or len(value) != 2
                or id(value) in seen):
            continue
        seen.add(id(value))
        V, F = value
        used = np.unique(np.asarray(F, dtype=np.int64))
        used = used[(used >= 0) & (used < len(V))]
        if len(used) < 2:
            continue
        rows = np.ascontiguousarray(np.asarray(V, dtype=np.float64)[used]).view(np.dtype((np.void, 24))).ravel()
        n = len(used) - len(np.unique(rows))  # rows as 24-byte keys: 0.2 s at a million vertices (axis=0: 0.8 s)
        if n:
            what = "1 vertex lies" if n == 1 else f"{n} vertices lie"
            out.append(f"{p.name}: {what} exactly on other vertices (the mesh is not welded): results that follow its "
                       "edges treat it as separate pieces; weld it (Rhino: _Weld) and send it again")
    return out


def run(component: Component, req: SolveRequest, limits: dict | None = None) -> dict:
    """Solve a parsed request; raises :class:`RequestError` for bad input. Returns the response dict.

    Sizes are checked before the work: declared mesh counts per mesh and per request before any item is decoded,
    the answer's size while it is encoded (413 naming the limit).
    """
    limits = resolve_limits(limits)
    trees = _input_trees(component, req)
    _check_declared_sizes(component, trees, limits)
    max_response = (limits.get("max_response_mb") or 0) * 2**20
    out_bytes = 0
    ctx = _context(component, req)
    out_trees: list[dict[str, list]] = [{} for _ in component.outputs]
    warnings: list[str] = []
    checked: set = set()  # meshes checked for welding (_unwelded_inputs)
    for path, i, n_iter, kwargs in _iterations(component, trees, limits):
        _check_list_lengths(component, kwargs)
        try:
            result = component.function(**kwargs, **ctx)
        except InputError as exc:
            raise RequestError(str(exc)) from None
        fields = result._asdict() if hasattr(result, "_asdict") else None
        if fields is None:
            raise TypeError(f"{component.name} returned {type(result).__name__}, not its NamedTuple")
        if component.warnings_field and fields.get("warnings"):
            for w in fields["warnings"]:
                if w not in warnings:
                    warnings.append(str(w))
        for w in _unwelded_inputs(component, kwargs, warnings, checked):
            if w not in warnings:
                warnings.append(w)
        for k, p in enumerate(component.outputs):
            value = fields[p.name]
            if value is None:  # nothing to send for this output (an empty tree)
                continue
            try:
                items = []
                for v in P.output_items(p.kind, p.access, value):
                    out_bytes += _estimated_size(p.kind, v)
                    if max_response and out_bytes > max_response:
                        break
                    items.append(P.encode_item(p.kind, v))
                    out_bytes += len(items[-1]["data"]) + 40 - _estimated_size(p.kind, v)
                    if max_response and out_bytes > max_response:
                        break
            except P.OutputError as exc:
                raise P.OutputError(f"output {p.name!r} of {component.uri}: {exc}") from None
            if max_response and out_bytes > max_response:
                raise too_large(f"the answer of {component.uri} would be more than", "max_response_mb",
                                limits["max_response_mb"])
            if n_iter > 1 and p.access != "item":
                key = format_path(path + (i,))
            else:
                key = format_path(path)
            out_trees[k].setdefault(key, []).extend(items)
    return {
        "values": [{"ParamName": p.name, "InnerTree": t} for p, t in zip(component.outputs, out_trees)],
        "warnings": warnings,
        "errors": [],
    }


def error_body(errors: list[str], warnings: list[str] | None = None) -> dict:
    return {"values": [], "warnings": warnings or [], "errors": errors}


def solve(registry: Registry, body: Any, uri: str | None = None, limits: dict | None = None) -> tuple[int, dict, str]:
    """The whole solve path. Returns ``(status, response, component uri)``; never raises.

    400 bad input (named), 404-free: an unknown component is a 400 too, 500 "Bad inputs" when the client's
    inputs do not match the component (so Hops refreshes), 500 with one line on an unexpected failure.
    """
    comp_uri = ""
    try:
        req = parse_request(body, uri)
        comp_uri = req.pointer
        component = registry.get(req.pointer)
        if component is None:
            raise RequestError(f"unknown component {req.pointer!r}; GET / lists the components")
        return 200, run(component, req, limits), comp_uri
    except RequestError as exc:
        return exc.status, error_body(exc.errors), comp_uri
    except MemoryError:
        log.exception("out of memory in %s", comp_uri)
        return 500, error_body([f"{comp_uri}: out of memory: the solve needed more memory than a solver process may "
                                "use (ghserver serve --memory-limit-mb), send a smaller input"]), comp_uri
    except Exception as exc:  # unexpected: one line to the client, traceback to the log
        log.exception("solve of %s failed", comp_uri or "?")
        msg = str(exc).splitlines()[0] if str(exc) else ""
        return 500, error_body([f"internal error in {comp_uri or 'solve'}: {type(exc).__name__}: {msg}"[:500]]), comp_uri


def solve_bytes(registry: Registry, raw: bytes, uri: str | None = None,
                limits: dict | None = None) -> tuple[int, bytes, str, dict]:
    """:func:`solve` on a raw request body: ``(status, response JSON bytes, uri, info)``; never raises.

    ``info`` has ``cachesolve`` (the request's flag) and ``inputs`` (a one-line size summary for the access log).
    """
    try:
        check_json_size(raw, limits)
        body = json.loads(raw)
    except RequestError as exc:
        return exc.status, json.dumps(error_body(exc.errors)).encode("utf-8"), uri or "", {"cachesolve": False,
                                                                                            "inputs": ""}
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, UnicodeDecodeError, integers of > 4300 digits
        msg = getattr(exc, "msg", None) or str(exc).splitlines()[0][:200] or type(exc).__name__
        resp = error_body([f"request body is not valid JSON: {msg}"])
        return 400, json.dumps(resp).encode("utf-8"), uri or "", {"cachesolve": False, "inputs": ""}
    status, resp, comp_uri = solve(registry, body, uri, limits=limits)
    try:
        info = {"cachesolve": bool(body.get("cachesolve", True)) if isinstance(body, dict) else False,
                "inputs": describe_inputs(body)}
        del body
        return status, json.dumps(resp, ensure_ascii=False, allow_nan=False).encode("utf-8"), comp_uri, info
    except Exception as exc:  # MemoryError, a NaN that slipped through: still one JSON line, never a crash
        log.exception("encoding the answer of %s failed", comp_uri or "?")
        resp = error_body([f"internal error in {comp_uri or 'solve'}: the answer could not be encoded "
                           f"({type(exc).__name__})"])
        return 500, json.dumps(resp).encode("utf-8"), comp_uri, {"cachesolve": False, "inputs": ""}


def describe_inputs(body: Any) -> str:
    """Short summary of a request's inputs for the access log: ``mesh=1/4kB reference=empty`` (items/bytes)."""
    if not isinstance(body, dict) or not isinstance(body.get("values"), list):
        return ""
    parts = []
    for tree in body["values"][:20]:
        if not isinstance(tree, dict):
            continue
        inner = tree.get("InnerTree") or {}
        if not isinstance(inner, dict):
            continue
        n = sum(len(v) for v in inner.values() if isinstance(v, list))
        size = sum(len(str(it.get("data", ""))) for v in inner.values() if isinstance(v, list)
                   for it in v if isinstance(it, dict))
        name = tree.get("ParamName")
        parts.append(f"{name}=empty" if n == 0 else f"{name}={n}/{_human(size)}")
    return " ".join(parts)


def first_error(response: bytes | str | None) -> str:
    """The first error line of a JSON answer (for the access log of a refused solve), or ``''``."""
    try:
        errors = json.loads(response or b"{}").get("errors") or []
        return str(errors[0]).splitlines()[0][:200] if errors else ""
    except (ValueError, AttributeError, TypeError):
        return ""


def _human(n: int) -> str:
    for unit in ("B", "kB", "MB"):
        if n < 1024:
            return f"{n}{unit}"
        n //= 1024
    return f"{n}GB"



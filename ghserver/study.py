"""Parametric studies: every strategy × surface × parameter variant of a study file, run on a Dask cluster.

A designer choosing a panelling runs tens to thousands of variants: design surfaces (built-in samples or mesh /
.3dm files) × strategies × panel sizes (× optimization budgets). ``ghserver study STUDY.toml`` and
:func:`run` expand the product, run each variant as an independent task of :func:`run_variant` (a pure function of
the variant and the surface mesh) on Dask distributed, and return one table row per variant: the harness's status
and panel health (:func:`components.harness.run_strategy`), the panel count, planarity, closeness, and the number
of panel types (:func:`components.fabrication.congruence.panel_types`). The table goes to ``study.csv``,
``study.json`` and ``study.html`` (charts of panel count against planarity, closeness, coverage and panel types;
:mod:`ghserver.study_report`).

The study file (TOML or JSON; every list may also be a single value)::

    title = "Roof options"
    samples = ["dome", "saddle", "wave", "canopy"]   # built-in surfaces (components.surfaces.samples)
    meshes = ["roof.3dm"]                            # .3dm/.stl/.obj/.off/.ply, relative to the study file
    strategies = ["translation", "curvature_network"]  # or "all"
    divisions = [6, 8, 10]       # panels across the larger extent, or panel_size = [1.5, 2.0] (model units)
    resolution = 20              # sample mesh resolution (edge lengths across the larger extent)
    time_budget = 10             # seconds an optimization may take (a list makes it a study parameter)

A mesh entry may also be a table ``{path = "site.3dm", layer = "Roof", object = "shell", name = "roof"}``.

Execution. ``cluster=ADDRESS`` (``--cluster``) connects to a running scheduler (``dask scheduler`` and
``dask worker ADDRESS`` on the machines); otherwise a local ``LocalCluster(processes=True, threads_per_worker=1)``
of ``workers`` processes (``--workers``, default one per core) runs the same tasks, so both modes share one code
path. Every design surface is one task (recomputed by the scheduler if the worker holding it dies) and every
variant one task depending on it, submitted with ``retries``; a worker lost mid-study has its tasks rerun
elsewhere. Results stream back with ``as_completed``.

Cache. Every finished variant is written to a content-hash cache on disk as it arrives (atomic rename, so an
interrupt loses nothing finished): ``CACHE/<k[:2]>/<k>.json`` (the row) and ``<k>.npz`` (the final mesh), where
``k`` is the SHA-256 of the canonical JSON of the variant: the surface mesh's content hash, the strategy, the
panel size in model units and the other parameters, the package version, :data:`CACHE_FORMAT` and the hash of the
algorithm sources (:func:`code_version`; any change to ``components/`` computes afresh). A rerun, an interrupted
run or an extended study (more sizes, another surface) computes only what is new, and a study found complete in the
cache starts no cluster at all. A variant lost to the cluster (its worker died more often than the scheduler
allows) is a ``"not run"`` row and is not cached, so the next run retries it.

Errors. A study file is validated before anything runs: unknown keys, strategies or samples, a missing mesh file,
an empty list or a bad number raise :class:`components.core.errors.InputError` naming the key and what to do. A
strategy's own failure, or a typed InputError/MeshError while running a variant, is a ``"failed"`` row with the
error, never a crash of the study.
"""
from __future__ import annotations

import argparse
import hashlib
import itertools
import json
import logging
import math
import os
import sys
import tempfile
import time
from functools import lru_cache
from pathlib import Path
from typing import Callable, NamedTuple

import numpy as np

from components.core.checks import check_choice, check_int, check_number, validate_mesh
from components.core.errors import InputError, MeshError
from components.core.mesh import remove_unreferenced, triangulate
from ghserver.report import STRATEGY_NAMES, Progress

try:  # Python 3.11+
    import tomllib
except ModuleNotFoundError:  # Python 3.10: the tomli backport, when installed
    try:
        import tomli as tomllib
    except ModuleNotFoundError:
        tomllib = None

log = logging.getLogger(__name__)

__all__ = [
    "CACHE_FORMAT",
    "STATUS_NOT_RUN",
    "DEFAULT_OUT",
    "SAMPLE_NAMES",
    "Study",
    "MeshSource",
    "Variant",
    "DesignSurface",
    "StudyTable",
    "COLUMNS",
    "load_study",
    "variants",
    "design_surfaces",
    "variant_key",
    "code_version",
    "run_variant",
    "design_surface",
    "sample_surface",
    "run",
    "add_study_parser",
    "study_command",
]

#: version of the cache entries' layout and of :func:`run_variant`'s row; bump when either changes
CACHE_FORMAT = 1
DEFAULT_OUT = "ghserver-study"
#: the built-in design surfaces (:data:`components.surfaces.samples.SAMPLE_NAMES`, repeated so that reading a study
#: file does not import scipy; ``tests/ghserver/test_study.py`` keeps them equal)
SAMPLE_NAMES = ("dome", "saddle", "wave", "canopy")
#: seconds to wait for a scheduler named by ``cluster``
CONNECT_TIMEOUT = 20.0
#: retries of a variant whose task raised (a lost worker's tasks are rescheduled by the scheduler anyway)
RETRIES = 2

_KEYS = ("title", "samples", "meshes", "strategies", "panel_size", "divisions", "resolution", "time_budget")
_MESH_KEYS = ("path", "layer", "object", "name")
_MESH_SUFFIXES = (".3dm", ".stl", ".obj", ".off", ".ply")

#: relative cost of the strategies (submission order: the likely longest first)
_COST = {"translation": 1, "curvature_network": 2, "conjugate_field": 3, "subdivision": 3}

#: status of a variant the cluster could not finish (not cached: the next run retries it)
STATUS_NOT_RUN = "not run"

#: the table's columns, in order (``closeness_*`` in model units, planarity scale-free, angles in degrees)
COLUMNS = ("id", "surface", "strategy", "panel_size", "divisions", "time_budget", "status", "panels", "vertices",
           "planarity_max", "planarity_mean", "closeness_max", "closeness_mean", "healthy", "coverage",
           "worst_corner", "shortest_edge_ratio", "panel_types", "panel_type_tolerance", "time", "cached",
           "detail", "violations", "warnings", "error", "key")


# ----------------------------------------------------------------------------------------------
# the study file


class MeshSource(NamedTuple):
    """A design surface read from a file."""

    path: Path
    name: str
    layer: str | None = None
    object: str | None = None


class Study(NamedTuple):
    """A validated study: what to run (see the module docstring for the file format)."""

    title: str
    samples: tuple  # built-in sample names
    meshes: tuple  # MeshSource
    strategies: tuple
    panel_sizes: tuple  # model units; empty when ``divisions`` is given
    divisions: tuple  # panels across the larger extent; empty when ``panel_sizes`` is given
    resolution: int
    time_budgets: tuple
    source: str = ""  # the study file, or "" for a dict


def _as_list(value, key: str) -> list:
    items = list(value) if isinstance(value, (list, tuple)) else [value]
    if not items:
        raise InputError(key, "is an empty list: give at least one value, or leave the key out for its default")
    return items


def _read_file(path: Path) -> dict:
    if not path.is_file():
        raise InputError("study", f"{path}: no such file")
    suffix = path.suffix.lower()
    text = path.read_text(encoding="utf-8")
    if suffix == ".toml":
        if tomllib is None:
            raise InputError("study", f"{path.name}: reading TOML needs Python 3.11 or the tomli package on Python "
                                      "3.10 (pip install tomli); or write the study as JSON")
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise InputError("study", f"{path.name} is not valid TOML: {exc}") from None
    elif suffix == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError("study", f"{path.name} is not valid JSON: {exc}") from None
    else:
        raise InputError("study", f"{path.name}: a study file is .toml or .json, got {suffix or 'no suffix'!r}")
    if not isinstance(data, dict):
        raise InputError("study", f"{path.name}: the study must be a table (a JSON object) of keys {', '.join(_KEYS)}")
    return data


def _mesh_source(entry, base: Path, taken: set) -> MeshSource:
    if isinstance(entry, str):
        entry = {"path": entry}
    if not isinstance(entry, dict) or "path" not in entry:
        raise InputError("meshes", f"each entry is a file path or a table with a 'path' (and optional layer, object, "
                                   f"name), got {entry!r}")
    unknown = sorted(set(entry) - set(_MESH_KEYS))
    if unknown:
        raise InputError("meshes", f"unknown key {unknown[0]!r} in {entry!r}; a mesh entry has {', '.join(_MESH_KEYS)}")
    for k in _MESH_KEYS:
        if entry.get(k) is not None and not isinstance(entry[k], str):
            raise InputError("meshes", f"{k} must be text, got {entry[k]!r}")
    path = Path(entry["path"]).expanduser()
    path = path if path.is_absolute() else base / path
    if path.suffix.lower() not in _MESH_SUFFIXES:
        raise InputError("meshes", f"{entry['path']}: a design surface is a {', '.join(_MESH_SUFFIXES)} file")
    if not path.is_file():
        raise InputError("meshes", f"{entry['path']}: no such file (paths are relative to the study file's folder, "
                                   f"{base}); fix the path or remove the entry")
    if path.suffix.lower() != ".3dm" and (entry.get("layer") or entry.get("object")):
        raise InputError("meshes", f"{entry['path']}: layer and object only apply to .3dm files")
    name = entry.get("name") or path.stem
    stem, k = name, 2
    while name in taken:
        name = f"{stem}-{k}"
        k += 1
    taken.add(name)
    return MeshSource(path.resolve(), name, entry.get("layer"), entry.get("object"))


def load_study(study, base=None) -> Study:
    """A validated :class:`Study` from a study file (``.toml`` / ``.json``), a dict of the same keys, or a Study.

    Relative mesh paths are relative to the study file's folder (to ``base`` or the current folder for a dict).

    Raises
    ------
    InputError
        Named after the offending key: ``study`` (unreadable file, unknown key), ``samples``, ``meshes``,
        ``strategies``, ``panel_size``, ``divisions``, ``resolution``, ``time_budget``.

    Examples
    --------
    >>> s = load_study({"samples": ["dome", "wave"], "strategies": "translation", "divisions": [6, 8]})
    >>> s.samples, s.strategies, s.divisions, s.time_budgets
    (('dome', 'wave'), ('translation',), (6, 8), (10.0,))
    >>> load_study({"samples": ["dom"]})
    Traceback (most recent call last):
    ...
    components.core.errors.InputError: samples: must be one of 'dome', 'saddle', 'wave', 'canopy', got 'dom'
    >>> load_study({"samples": "dome", "strategies": []})
    Traceback (most recent call last):
    ...
    components.core.errors.InputError: strategies: is an empty list: give at least one value, or leave the key out for its default
    """
    if isinstance(study, Study):
        return study
    source = ""
    if isinstance(study, (str, os.PathLike)):
        path = Path(study).expanduser()
        data = _read_file(path)
        base = path.resolve().parent
        source = str(path)
    elif isinstance(study, dict):
        data = dict(study)
        base = Path(base) if base is not None else Path.cwd()
    else:
        raise InputError("study", f"must be a study file path, a dict or a Study, got {type(study).__name__}")
    unknown = sorted(set(data) - set(_KEYS))
    if unknown:
        raise InputError("study", f"unknown key {unknown[0]!r}; a study has the keys {', '.join(_KEYS)}")
    title = data.get("title", Path(source).stem if source else "study")
    if not isinstance(title, str):
        raise InputError("title", f"must be text, got {title!r}")
    samples = tuple(check_choice(s, "samples", SAMPLE_NAMES) for s in _as_list(data.get("samples", ()), "samples")) \
        if "samples" in data else ()
    taken = set(samples)
    meshes = tuple(_mesh_source(m, base, taken) for m in _as_list(data["meshes"], "meshes")) \
        if "meshes" in data else ()
    if not samples and not meshes:
        raise InputError("samples", f"the study has no design surface: list built-in samples "
                                    f"({', '.join(SAMPLE_NAMES)}) under 'samples' or files under 'meshes'")
    if len(set(samples)) != len(samples):
        raise InputError("samples", f"lists a surface twice: {list(samples)}")
    strategies = data.get("strategies", "all")
    if strategies == "all" or strategies == ["all"]:
        strategies = STRATEGY_NAMES
    strategies = tuple(dict.fromkeys(check_choice(s, "strategies", STRATEGY_NAMES)
                                     for s in _as_list(strategies, "strategies")))
    if "panel_size" in data and "divisions" in data:
        raise InputError("panel_size", "give either panel_size (model units) or divisions (panels across the "
                                       "larger extent), not both")
    panel_sizes = tuple(dict.fromkeys(check_number(v, "panel_size", 0, above=True)
                                      for v in _as_list(data["panel_size"], "panel_size"))) \
        if "panel_size" in data else ()
    divisions = tuple(dict.fromkeys(check_int(v, "divisions", 1, 10_000)
                                    for v in _as_list(data.get("divisions", 16), "divisions"))) \
        if not panel_sizes else ()
    resolution = check_int(data.get("resolution", 32), "resolution", 4, 1000)
    budgets = tuple(dict.fromkeys(check_number(v, "time_budget", 0, above=True)
                                  for v in _as_list(data.get("time_budget", 10.0), "time_budget")))
    return Study(title, samples, meshes, strategies, panel_sizes, divisions, resolution, budgets, source)


# ----------------------------------------------------------------------------------------------
# design surfaces and variants


class DesignSurface(NamedTuple):
    """A design surface of a study: its content hash and size, and how a worker builds its mesh."""

    name: str
    digest: str  # SHA-256 of the design mesh's content (vertices and triangles)
    extent: float  # the larger plan extent (what ``divisions`` divide)
    vertices: int
    triangles: int
    description: str
    task: tuple  # (function, *args) building the mesh on a worker: a sample's recipe, or the mesh itself


def _mesh_digest(V: np.ndarray, T: np.ndarray) -> str:
    h = hashlib.sha256()
    for a in (np.ascontiguousarray(V, dtype="<f8"), np.ascontiguousarray(T, dtype="<i8")):
        h.update(repr(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


def _extent(V: np.ndarray) -> float:
    """The larger plan extent, as :func:`components.harness.default_panel_size` measures it (without importing
    every strategy, 1 s, on a cached rerun)."""
    return float(np.sort(V.max(axis=0) - V.min(axis=0))[-1])


def design_surface(V, F) -> tuple[np.ndarray, np.ndarray]:
    """A design surface as the strategies take it: validated, unreferenced vertices dropped, triangulated.

    The surface task of a study (a plain function of the mesh, so that the scheduler can recompute it when the
    worker holding it dies).
    """
    V, F = validate_mesh(V, F, name="surface")
    V, F, _ = remove_unreferenced(V, F)
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    return np.ascontiguousarray(V, dtype=np.float64), np.ascontiguousarray(T, dtype=np.int64)


def sample_surface(name: str, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """The design mesh of a built-in sample (deterministic); a study's surface task for a sample."""
    from components.surfaces.samples import sample_mesh  # deferred import: scipy, 0.5 s

    V, T, _ = sample_mesh(name, resolution)
    return design_surface(V, T)


def _sample_recipe(name: str, resolution: int) -> str:
    """What a sample's mesh is a function of: name, resolution, the algorithm sources, numpy and scipy."""
    from importlib import metadata  # deferred import: only for the key

    spec = {"sample": name, "resolution": resolution, "code": code_version(), "numpy": np.__version__,
            "scipy": metadata.version("scipy")}
    return hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()


def design_surfaces(study: Study, store: "_Cache | None" = None) -> list[DesignSurface]:
    """The study's design surfaces: samples (their hash and size memoized in the cache, so that a rerun needs no
    mesh) and mesh files (read, validated and hashed)."""
    store = store if store is not None else _Cache(None)
    out = []
    for name in study.samples:
        recipe = _sample_recipe(name, study.resolution)
        info = store.get_surface(recipe)  # digest, extent, counts, description: no scipy on a cached rerun
        if info is None:
            from components.surfaces.samples import sample_surface_function  # deferred import: scipy, 0.5 s

            V, T = sample_surface(name, study.resolution)
            desc = f"{sample_surface_function(name).description} (sample, resolution {study.resolution})"
            info = {"digest": _mesh_digest(V, T), "extent": _extent(V), "vertices": int(len(V)),
                    "triangles": int(len(T)), "description": desc}
            store.put_surface(recipe, info)
        out.append(DesignSurface(name, info["digest"], info["extent"], info["vertices"], info["triangles"],
                                 info["description"], (sample_surface, name, study.resolution)))
    for m in study.meshes:
        from ghserver.convert import read_model  # deferred import: rhino3dm, only for mesh files

        try:
            V, F, notes, _ = read_model(m.path, layer=m.layer, name=m.object)
            V, T = design_surface(V, F)
        except (InputError, MeshError) as exc:
            raise InputError("meshes", f"{m.path.name}: {exc}") from None
        except OSError as exc:
            raise InputError("meshes", f"{m.path.name}: cannot read it: {exc}") from None
        desc = f"mesh file {m.path.name}" + "".join(f"; {n}" for n in notes)
        out.append(DesignSurface(m.name, _mesh_digest(V, T), _extent(V), int(len(V)), int(len(T)), desc,
                                 (design_surface, V, T)))
    return out


class Variant(NamedTuple):
    """One task of a study: a strategy on a design surface with its parameters, and its cache key."""

    index: int
    surface: str
    strategy: str
    panel_size: float  # model units
    divisions: int | None  # when the panel size came from divisions
    time_budget: float
    surface_digest: str
    key: str

    @property
    def id(self) -> str:
        """Short id of the variant's result (the first 12 hex digits of its key)."""
        return self.key[:12]

    def spec(self) -> dict:
        """What :func:`run_variant` needs besides the surface mesh."""
        return {"strategy": self.strategy, "panel_size": self.panel_size, "time_budget": self.time_budget,
                "surface": self.surface}


@lru_cache(maxsize=1)
def code_version() -> str:
    """SHA-256 of the algorithm sources (``components/**.py`` and this module), computed once per process.

    Part of every cache key, so that a changed strategy or metric never serves a stale result.
    """
    import components  # deferred import: only its location is needed

    h = hashlib.sha256()
    root = Path(components.__file__).resolve().parent
    for p in sorted(root.rglob("*.py")) + [Path(__file__).resolve()]:
        h.update(str(p.relative_to(root.parent)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


@lru_cache(maxsize=1)
def _package_version() -> str:
    from importlib import metadata  # deferred import: only for the cache key

    try:
        return metadata.version("pq-ghserver")
    except metadata.PackageNotFoundError:
        return "unknown"


def variant_key(surface_digest: str, strategy: str, panel_size: float, time_budget: float) -> str:
    """SHA-256 of the canonical JSON of a variant: the surface content, strategy and parameters, the package
    version, :data:`CACHE_FORMAT` and :func:`code_version`."""
    spec = {"surface": surface_digest, "strategy": strategy, "panel_size": float(panel_size),
            "time_budget": float(time_budget), "package": _package_version(), "format": CACHE_FORMAT,
            "code": code_version()}
    return hashlib.sha256(json.dumps(spec, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def variants(study, surfaces: list[DesignSurface] | None = None) -> list[Variant]:
    """The product surfaces × strategies × panel sizes (or divisions) × time budgets, in that order.

    ``study``: anything :func:`load_study` takes; ``surfaces``: its :func:`design_surfaces` (computed when None).
    """
    study = load_study(study)
    surfaces = design_surfaces(study) if surfaces is None else surfaces
    out = []
    for surf in surfaces:
        if study.divisions:
            sizes = [(surf.extent / d, d) for d in study.divisions]
        else:
            sizes = [(h, None) for h in study.panel_sizes]
        for strategy, (h, d), budget in itertools.product(study.strategies, sizes, study.time_budgets):
            key = variant_key(surf.digest, strategy, h, budget)
            out.append(Variant(len(out), surf.name, strategy, h, d, budget, surf.digest, key))
    return out


# ----------------------------------------------------------------------------------------------
# the task


def _finite(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def run_variant(spec: dict, surface: tuple) -> dict:
    """Run one variant: a pure function of ``spec`` (strategy, panel_size, time_budget, surface name) and the
    design ``surface`` ``(V, T)``; what a study's task computes on a worker.

    Returns ``{"row": {...}, "metrics": final metrics or None, "mesh": (V, F) of the final mesh or None}``; the row
    holds the computed columns of :data:`COLUMNS`. Never raises for a strategy's failure or a typed
    InputError/MeshError: the row's status is ``"failed"`` and ``error`` says why.
    """
    from components.fabrication.congruence import panel_types  # deferred import: loaded on the workers only
    from components.harness import run_strategy  # deferred import: as above (every strategy, 1 s)

    V, T = surface
    t0 = time.perf_counter()
    try:
        res = run_strategy(spec["strategy"], V, T, spec["panel_size"], surface=spec.get("surface", "surface"),
                           time_budget=spec["time_budget"])
    except (InputError, MeshError) as exc:
        row = {"status": "failed", "detail": str(exc), "error": f"{type(exc).__name__}: {exc}",
               "time": time.perf_counter() - t0, "violations": [], "warnings": []}
        return {"row": row, "metrics": None, "mesh": None}
    final = res.final
    m = res.metrics_after or res.metrics_before
    row = {"status": res.status, "detail": res.detail,
           "violations": list(res.violations), "warnings": list(res.warnings),
           "error": res.detail if res.status == "failed" else None}
    if m is not None:
        row.update(panels=int(m["faces"]), vertices=int(m["vertices"]), planarity_max=_finite(m["planarity_max"]),
                   planarity_mean=_finite(m["planarity_mean"]), closeness_max=_finite(m["closeness_max"]),
                   closeness_mean=_finite(m["closeness_mean"]))
    h = res.health
    if h is not None:
        row.update(healthy=bool(res.healthy), coverage=_finite(h.coverage), worst_corner=_finite(h.worst_corner),
                   shortest_edge_ratio=_finite(h.shortest_edge_ratio))
    if final is not None:
        try:
            types = panel_types(tuple(final[:2]))
            row.update(panel_types=int(types.type_count), panel_type_tolerance=float(types.tolerance))
        except (InputError, MeshError) as exc:  # e.g. a collapsed panel: say why instead of a count
            row["warnings"].append(f"panel types: {exc}")
    row["time"] = time.perf_counter() - t0  # the whole variant: strategy, measures, panel types
    mesh = None if final is None else (np.asarray(final[0], np.float64), np.asarray(final[1], np.int64))
    metrics = None if m is None else {k: _finite(v) for k, v in m.items()}
    return {"row": row, "metrics": metrics, "mesh": mesh}


def _warm_up() -> str:
    """Import the strategies on a worker before the first task (so a throughput measure is not an import)."""
    import components.fabrication.congruence as congruence  # deferred import: this is the warm-up
    import components.harness as harness  # deferred import: this is the warm-up

    return f"{harness.__name__}, {congruence.__name__}"


# ----------------------------------------------------------------------------------------------
# the cache


class _Cache:
    """Finished variants on disk, one JSON row (+ an .npz final mesh) per key, written atomically."""

    def __init__(self, root):
        self.root = None if root is None else Path(root)

    def _path(self, key: str, suffix: str) -> Path:
        return self.root / key[:2] / f"{key}{suffix}"

    def get(self, key: str) -> dict | None:
        if self.root is None:
            return None
        try:
            entry = json.loads(self._path(key, ".json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        return entry if entry.get("format") == CACHE_FORMAT and entry.get("key") == key else None

    def _atomic(self, path: Path, write: Callable) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
        try:
            with os.fdopen(fd, "wb") as fh:
                write(fh)
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise

    def put(self, key: str, spec: dict, result: dict) -> None:
        if self.root is None:
            return
        if result.get("mesh") is not None:  # the mesh first: a row in the cache always has its mesh
            V, F = result["mesh"]
            self._atomic(self._path(key, ".npz"), lambda fh: np.savez_compressed(fh, V=V, F=F))
        entry = {"format": CACHE_FORMAT, "key": key, "spec": spec, "row": result["row"], "metrics": result["metrics"],
                 "mesh": result.get("mesh") is not None}
        text = json.dumps(entry, sort_keys=True, allow_nan=False).encode("utf-8")
        self._atomic(self._path(key, ".json"), lambda fh: fh.write(text))

    def get_surface(self, recipe: str) -> dict | None:
        if self.root is None:
            return None
        try:
            return json.loads((self.root / "surfaces" / f"{recipe}.json").read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None

    def put_surface(self, recipe: str, info: dict) -> None:
        if self.root is not None:
            text = json.dumps(info, sort_keys=True).encode("utf-8")
            self._atomic(self.root / "surfaces" / f"{recipe}.json", lambda fh: fh.write(text))

    def mesh(self, key: str):
        if self.root is None:
            return None
        try:
            with np.load(self._path(key, ".npz")) as z:
                return z["V"], z["F"]
        except OSError:
            return None


# ----------------------------------------------------------------------------------------------
# the table


class StudyTable:
    """What :func:`run` returns: one row (a dict of :data:`COLUMNS`) per variant, in the study's order.

    ``table["planarity_max"]`` is a column (a list), ``table[3]`` a row; ``len(table)`` the number of variants.
    ``computed`` / ``cached`` / ``not_run`` count how the rows were obtained in this run, ``elapsed`` and
    ``timings`` (``prepare``, ``cluster``, ``compute``, ``report`` seconds) say where the time went, and
    ``html`` / ``csv`` / ``json`` are the written files (None when ``out=None``).
    """

    def __init__(self, rows: list[dict], study: Study, surfaces: list, cache_dir, metrics: dict):
        self.rows = rows
        self.columns = COLUMNS
        self.study = study
        self.surfaces = surfaces  # [{"name", "description", "vertices", "triangles", "digest"}]
        self.cache_dir = None if cache_dir is None else Path(cache_dir)
        self.metrics = metrics  # key -> final metrics dict
        self.computed = sum(1 for r in rows if r["status"] != STATUS_NOT_RUN and not r["cached"])
        self.cached = sum(1 for r in rows if r["cached"])
        self.not_run = sum(1 for r in rows if r["status"] == STATUS_NOT_RUN)
        self.elapsed = 0.0
        self.timings: dict = {}
        self.workers = 0
        self.out_dir = self.html = self.csv = self.json = None

    def __len__(self) -> int:
        return len(self.rows)

    def __iter__(self):
        return iter(self.rows)

    def __getitem__(self, item):
        if isinstance(item, str):
            return self.column(item)
        return self.rows[item]

    def column(self, name: str) -> list:
        """The values of one column, in row order."""
        if name not in self.columns:
            raise KeyError(f"{name!r} is not a column; columns: {', '.join(self.columns)}")
        return [r.get(name) for r in self.rows]

    def counts(self) -> dict:
        """Rows per status."""
        out: dict = {}
        for r in self.rows:
            out[r["status"]] = out.get(r["status"], 0) + 1
        return out

    def mesh(self, row) -> tuple | None:
        """The final mesh ``(V, F)`` of a row (or row index) from the cache, or None (failed, or no cache)."""
        row = self.rows[row] if isinstance(row, int) else row
        return None if self.cache_dir is None else _Cache(self.cache_dir).mesh(row["key"])

    def to_pandas(self):
        """The table as a pandas DataFrame (needs pandas)."""
        import pandas as pd  # deferred import: optional dependency

        return pd.DataFrame(self.rows, columns=list(self.columns))

    def summary(self) -> str:
        """One line: rows per status, computed / cached, time."""
        counts = ", ".join(f"{n} {s}" for s, n in self.counts().items())
        return (f"{len(self)} variants ({counts}); {self.computed} computed, {self.cached} from the cache"
                + (f", {self.not_run} not run (rerun to retry them)" if self.not_run else "")
                + f", in {self.elapsed:.1f} s")


def _row(v: Variant, computed: dict | None, cached: bool) -> dict:
    row = {c: None for c in COLUMNS}
    row.update(id=v.id, surface=v.surface, strategy=v.strategy, panel_size=v.panel_size, divisions=v.divisions,
               time_budget=v.time_budget, key=v.key, cached=cached, violations=[], warnings=[])
    if computed is None:
        row.update(status=STATUS_NOT_RUN)
    else:
        row.update({k: computed[k] for k in computed if k in row and k not in ("id", "key")})
    return row


# ----------------------------------------------------------------------------------------------
# running a study


def _client(cluster, workers: int | None):
    """A Dask client on ``cluster`` (an address or a Client), else on a new LocalCluster; the things to close."""
    from distributed import Client, LocalCluster  # deferred import: distributed costs 0.6-1.2 s at start

    if cluster is not None and not isinstance(cluster, str):  # a Client (or anything with submit) given
        return cluster, []
    if cluster is not None:
        try:
            client = Client(cluster, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise InputError("cluster", f"cannot reach the Dask scheduler at {cluster}: {exc}; start one with "
                                        "`dask scheduler` and workers with `dask worker ADDRESS`, or run locally "
                                        "with --workers N") from None
        return client, [client]
    n = workers if workers is not None else (os.cpu_count() or 1)
    try:
        lc = LocalCluster(n_workers=n, processes=True, threads_per_worker=1, dashboard_address=None,
                          silence_logs=logging.ERROR)
    except RuntimeError as exc:  # most often: a script without the __main__ guard, re-imported by each worker
        raise RuntimeError(f"could not start {n} local worker processes ({exc}); in a script, call "
                           "ghserver.study.run under `if __name__ == \"__main__\":` (the workers re-import the "
                           "script, as with multiprocessing)") from exc
    client = Client(lc)
    return client, [client, lc]


def run(study, *, cluster=None, workers: int | None = None, out=DEFAULT_OUT, cache=None, progress: bool = True,
        callback: Callable | None = None) -> StudyTable:
    """Run a parametric study and return its table (see the module docstring).

    Parameters
    ----------
    study : path-like, dict or Study
        A ``.toml`` / ``.json`` study file, or a dict of the same keys (:func:`load_study`).
    cluster : str or distributed.Client, optional
        Scheduler address (``tcp://host:8786``) or a connected client; default: a local cluster.
    workers : int, optional
        Processes of the local cluster (default: one per core); ignored with ``cluster``.
    out : path-like or None
        Folder for ``study.html``, ``study.csv`` and ``study.json`` (None: write no report).
    cache : path-like, False or None
        The result cache folder (default ``<out>/cache``, or ``./ghserver-study/cache`` when ``out`` is None);
        False: no cache.
    progress : bool
        A progress bar on stderr (when it is a terminal).
    callback : callable, optional
        Called with every newly computed row as it arrives.

    Returns
    -------
    StudyTable
        One row per variant, in the study's order.

    Raises
    ------
    InputError
        A bad study file (named after its key) or an unreachable ``cluster``.
    """
    t0 = time.perf_counter()
    study = load_study(study)
    if cache is None:
        cache = Path(out if out is not None else DEFAULT_OUT) / "cache"
    store = _Cache(None if cache is False else cache)
    surfaces = design_surfaces(study, store)
    todo = variants(study, surfaces)
    timings = {"prepare": time.perf_counter() - t0, "cluster": 0.0, "compute": 0.0, "report": 0.0}
    results: dict = {}  # key -> (row dict, cached)
    metrics: dict = {}
    for v in todo:
        if v.key not in results:
            entry = store.get(v.key)
            if entry is not None:
                results[v.key] = (entry["row"], True)
                metrics[v.key] = entry.get("metrics")
    missing = {v.key: v for v in todo if v.key not in results}
    bar = Progress(len(todo), enabled=progress)
    bar.step("from the cache", n=sum(1 for v in todo if v.key in results))
    n_workers = 0
    try:
        if missing:
            n_workers, timings["cluster"], timings["compute"] = _compute(
                list(missing.values()), surfaces, cluster, workers, store, results, metrics, bar, callback, todo)
    finally:
        bar.close()
    rows = [_row(v, *(results.get(v.key) or (None, False))) for v in todo]
    surf_info = [{"name": s.name, "description": s.description, "vertices": s.vertices, "triangles": s.triangles,
                  "digest": s.digest} for s in surfaces]
    table = StudyTable(rows, study, surf_info, store.root, metrics)
    table.workers = n_workers
    table.elapsed = time.perf_counter() - t0
    if out is not None:
        from ghserver.study_report import write_report  # deferred import: only when a report is written

        t = time.perf_counter()
        table.out_dir = Path(out)
        table.html, table.csv, table.json = write_report(table, out)
        timings["report"] = time.perf_counter() - t
    table.timings = timings
    table.elapsed = time.perf_counter() - t0
    log.debug("study %s: %s", study.title, table.summary())
    return table


def _compute(missing: list[Variant], surfaces: list[DesignSurface], cluster, workers, store: _Cache, results: dict,
             metrics: dict, bar: Progress, callback, todo) -> tuple[int, float, float]:
    """Submit the missing variants, stream their results into ``results`` and the cache."""
    from distributed import as_completed  # deferred import: distributed costs 0.6-1.2 s at start

    t = time.perf_counter()
    dask_log = logging.getLogger("distributed")
    level = dask_log.level
    dask_log.setLevel(max(level, logging.WARNING))  # not its INFO lines about every worker and client
    bar.show(f"connecting to {cluster}" if isinstance(cluster, str) else
             "starting the local workers" if cluster is None else "")
    client, owned = _client(cluster, workers)
    try:
        client.run(_warm_up)  # every worker imports the strategies now, in parallel
        n_workers = len(client.scheduler_info().get("workers", {}))
        t_cluster = time.perf_counter() - t
        t = time.perf_counter()
        by_digest = {s.digest: s for s in surfaces}
        surf_futures = {}
        for d in {v.surface_digest for v in missing}:
            s = by_digest[d]
            surf_futures[d] = client.submit(*s.task, key=f"pq-surface-{d}", pure=False, retries=RETRIES)
        futures = {}
        extent = {s.digest: s.extent for s in surfaces}
        for v in missing:
            # the likely longest first (strategy, then panels), so that no long variant is left for the end
            priority = _COST.get(v.strategy, 1) * 1000 + min(int((extent[v.surface_digest] / v.panel_size) ** 2), 999)
            fut = client.submit(run_variant, v.spec(), surf_futures[v.surface_digest], key=f"pq-variant-{v.key}",
                                pure=False, retries=RETRIES, priority=priority)
            futures[fut] = v
        names: dict = {}  # key -> the variants sharing it (the same surface listed under two names)
        for u in todo:
            names.setdefault(u.key, []).append(u)
        pending = set(futures)
        try:
            for fut in as_completed(list(futures)):
                v = futures[fut]
                pending.discard(fut)
                try:
                    result = fut.result()
                except Exception as exc:  # noqa: BLE001 - a lost or crashed task is a row, not the study's end
                    why = f"{type(exc).__name__}: {exc}"
                    log.warning("variant %s (%s on %s) not run: %s", v.id, v.strategy, v.surface, why)
                    results[v.key] = ({"status": STATUS_NOT_RUN, "error": why,
                                       "detail": "its task raised or its workers died; not cached, a rerun retries it"}, False)
                    bar.step(f"{v.surface} {v.strategy}: not run", n=len(names[v.key]))
                    continue
                finally:
                    fut.release()  # the result leaves the cluster's memory once it is here
                store.put(v.key, v.spec() | {"surface_digest": v.surface_digest}, result)
                results[v.key] = (result["row"], False)
                metrics[v.key] = result["metrics"]
                bar.step(f"{v.surface} {v.strategy} panel {v.panel_size:.3g}: {result['row']['status']}",
                         n=len(names[v.key]))
                if callback is not None:
                    for u in names[v.key]:
                        callback(_row(u, result["row"], False))
        finally:
            if pending:  # interrupted: finished results are in the cache, drop the rest
                client.cancel(list(pending))
            client.cancel(list(surf_futures.values()))
        return n_workers, t_cluster, time.perf_counter() - t
    finally:
        for thing in owned:
            thing.close()
        dask_log.setLevel(level)


# ----------------------------------------------------------------------------------------------
# command line


def add_study_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``ghserver study`` to the command line's subparsers."""
    p = subparsers.add_parser("study", help="a parametric study (surfaces × strategies × panel sizes) on a Dask "
                                            "cluster or local processes: CSV, JSON and HTML report",
                              description="Run every variant of a study file (TOML or JSON) as an independent task; "
                                          "finished variants are cached, so a rerun computes only what is new.")
    p.add_argument("study", help="the study file (.toml or .json)")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--cluster", default=None, metavar="ADDR",
                       help="Dask scheduler address, e.g. tcp://10.0.0.5:8786 (default: a local cluster)")
    where.add_argument("--workers", type=int, default=None, metavar="N",
                       help="processes of the local cluster (default: one per core)")
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default ./{DEFAULT_OUT})")
    p.add_argument("--cache", default=None, metavar="DIR", help="result cache folder (default OUT/cache)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=study_command)
    return p


def study_command(args) -> int:
    """``ghserver study``: run :func:`run` from parsed arguments; prints the summary and where the report is."""
    if args.workers is not None and args.workers < 1:
        print("ghserver study: --workers: must be 1 or more", file=sys.stderr)
        return 2
    try:
        table = run(args.study, cluster=args.cluster, workers=args.workers, out=args.out, cache=args.cache,
                    progress=not args.quiet)
    except (ValueError, OSError) as exc:  # InputError / MeshError are ValueErrors: a bad study file or option
        print(f"ghserver study: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ghserver study: interrupted; finished variants are in the cache, rerun to continue", file=sys.stderr)
        return 130
    print(table.summary())
    print(f"report written to {table.html} (table: {table.csv}, {table.json})")
    return 1 if table.not_run else 0

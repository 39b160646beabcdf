"""Issue #16, "fabricable or it says why": the acceptance sweep.

Every input (the sample surfaces, the real open meshes copied into ``tests/data``, six procedural surfaces) is
run through the three meshing strategies (``components.harness.run_strategy``) and through ``planarize`` (on the
conjugate-field candidate, against the input surface). Whatever a result claims, an independent checker
(``tests/fabricable.py``, no code shared with ``components.metrics``) looks at it:

* ``test_claim_holds``: no result that claims success (its ``healthy`` field when the result has one, else harness
  status ``"ok"``; ``converged`` or ``healthy`` for ``planarize``) has an edge under 0.2 × the median, a corner
  under 20°, a fold, a self-intersection or under 85 % coverage of the input (planarity is not a criterion here:
  a harness status ``"tolerance missed"`` with ``healthy`` true is a claim of health, and is checked);
* ``test_healthy_or_typed_error``: on the sample surfaces and the shared disks every strategy returns a healthy
  result (its ``healthy`` field true where it has one, and the independent check clean) or fails with a typed
  error (a class of ``components.core.errors``) that says why; a result reported ``"unhealthy"`` is neither;
* ``test_unit_scale``: the free-form ``wave`` sample at ×0.001, ×1, ×1000 and moved by +5e6 gives the same face
  counts and max planarity within 2× for every strategy and ``planarize``.

Runs are cached for the whole module (each input × method is computed once, the ×1 unit case reuses the sweep's
``wave`` runs). Panels are about 1/8 of the surface's extent (a third of the width for the twisted strip); no run
stops on its time budget, so the verdicts do not depend on the machine's load. The file takes about 4 CPU minutes
(6–8 minutes on a loaded 2-core machine), nearly all of it inside the strategies. ``FABRICABLE_REPORT=<path>``
writes the table of every run (input × method → claimed status / independent verdict) to ``<path>``.

Cases that fail today are (non-strict) xfails, listed in :data:`XFAIL` with the measured defect: when a fix lands they
show as XPASS in the summary and the entry should be removed. The claim test (nothing reported healthy or converged
that the independent check finds defective) has no xfail.
"""
from __future__ import annotations

import functools
import inspect
import os
from pathlib import Path

import numpy as np
import pytest

import components.core.errors as core_errors
from components.core.mesh import boundary_loops
from components.harness import run_strategy, strategy_names
from components.planarize import planarizer
from tests.fabricable import (
    PROCEDURAL,
    REAL_MESHES,
    SAMPLE_NAMES,
    independent_defects,
    panel_size,
    planarity,
    procedural_surface,
    real_surface,
    sample_surface,
)

# ----------------------------------------------------------------------------------------------
# Known failures, measured on this tree: (input, method) -> the defect. A reason applies to test_claim_holds and,
# on the sample surfaces and shared disks, to test_healthy_or_typed_error; a reason that starts with "reported"
# (the run reports itself unhealthy, or failed without a typed error: it claims nothing) applies to
# test_healthy_or_typed_error only. The input "wave_units" is test_unit_scale. Remove an entry when it XPASSes.
XFAIL: dict[tuple[str, str], str] = {}  # every case of issue 16 passes (session 5)

STRATEGIES = ("conjugate_field", "curvature_network", "subdivision")
METHODS = STRATEGIES + ("planarize",)
PLANARIZE_FROM = ("conjugate_field", "subdivision", "curvature_network")  # the first candidate found is planarized
SAMPLES = tuple(SAMPLE_NAMES)
DISKS = tuple(REAL_MESHES)  # every copied real mesh is an open disk
INPUTS = SAMPLES + DISKS + tuple(PROCEDURAL)
UNIT_VARIANTS = (("x0.001", 1e-3, 0.0), ("x1", 1.0, 0.0), ("x1000", 1e3, 0.0), ("+5e6", 1.0, 5e6))
TIME_BUDGET = 600.0  # seconds: no run stops on time, so the results do not depend on the machine's load
PLANARITY_FLOOR = 1e-6  # planarities below this (1 % of the default tolerance) count as equal in the unit test
TYPED_ERRORS = tuple(name for name, obj in vars(core_errors).items()
                     if inspect.isclass(obj) and issubclass(obj, Exception) and obj.__module__ == core_errors.__name__)


def test_strategy_names_cover_the_sweep():
    """The swept strategies are registered under these names (translation is exact by construction: not swept)."""
    assert set(STRATEGIES) <= set(strategy_names())


# ----------------------------------------------------------------------------------------------
# cached runs


@functools.lru_cache(maxsize=None)
def surface(name: str, scale: float = 1.0, offset: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    if name in SAMPLES:
        V, T = sample_surface(name)
    elif name in REAL_MESHES:
        V, T = real_surface(name)
    else:
        V, T = procedural_surface(name)
    return V * scale + offset, T


def _size(name: str, scale: float = 1.0) -> float:
    return panel_size(surface(name)[0], name) * scale


@functools.lru_cache(maxsize=None)
def strategy_run(name: str, strategy: str, scale: float = 1.0, offset: float = 0.0):
    V, T = surface(name, scale, offset)
    return run_strategy(strategy, V, T, _size(name, scale), surface=name, time_budget=TIME_BUDGET)


@functools.lru_cache(maxsize=None)
def planarize_run(name: str, scale: float = 1.0, offset: float = 0.0):
    """``(result or the exception raised, which candidate)``; the candidate is the ×1 one, moved like the input."""
    source = next((s for s in PLANARIZE_FROM if strategy_run(name, s).candidate is not None), None)
    if source is None:
        return None, None
    Vc, Fc = strategy_run(name, source).candidate
    try:
        res = planarizer.planarize((Vc * scale + offset, Fc), reference=surface(name, scale, offset),
                                   time_budget=TIME_BUDGET)
    except Exception as exc:  # noqa: BLE001 - the test judges the exception
        return exc, source
    return res, source


def _remembered(fn):
    """``functools.lru_cache`` that also lists its entries (``cache_items()``) in call order."""
    store: dict = {}

    @functools.wraps(fn)
    def wrapper(*args):
        if args not in store:
            store[args] = fn(*args)
        return store[args]

    wrapper.cache_items = lambda: list(store.items())
    return wrapper


@_remembered
def verdict(name: str, method: str) -> dict:
    """What a run claims and what the independent checker finds (``checked`` is None without a result mesh)."""
    V, T = surface(name)
    if method == "planarize":
        res, source = planarize_run(name)
        if res is None or isinstance(res, Exception):
            return dict(claimed=False, status="raised" if res is not None else "no candidate", mesh=None,
                        detail=f"{type(res).__name__}: {res}" if res is not None else "no strategy built a candidate",
                        error=type(res).__name__ if res is not None else None, checked=None, healthy=None)
        claimed = bool(res.converged) or bool(getattr(res, "healthy", False))
        status = f"converged={res.converged}"
        mesh, detail, error = res.mesh, f"planarized the {source} candidate: {res.stop_reason}", None
    else:
        res = strategy_run(name, method)
        if hasattr(res, "healthy"):
            claimed = bool(res.healthy)
        elif hasattr(res, "converged"):
            claimed = bool(res.converged)
        else:
            claimed = res.status == "ok"
        status, mesh, detail = res.status, res.final, res.detail
        error = detail.split(":", 1)[0] if res.status == "failed" else None
    checked = None if mesh is None else independent_defects(mesh[0], mesh[1], reference=(V, T))
    return dict(claimed=claimed, status=status, mesh=mesh, detail=detail, error=error, checked=checked,
                healthy=getattr(res, "healthy", None))


@pytest.fixture(scope="module", autouse=True)
def _report():
    """With ``FABRICABLE_REPORT=<path>`` set, write the table of every run of this module to ``<path>`` (Markdown)."""
    yield
    path = os.environ.get("FABRICABLE_REPORT")
    if path:
        Path(path).write_text(report_table())


def report_table() -> str:
    """Input × method → claimed status / independent verdict, for the runs made so far (Markdown)."""
    lines = ["| input | method | claimed status | independent check | coverage | worst corner | shortest edge / median "
             "| folds | crossings | max planarity |", "|---|---|---|---|---|---|---|---|---|---|"]
    for (name, method), v in verdict.cache_items():
        c = v["checked"]
        status = v["status"] if v.get("healthy") is None else f"{v['status']}, healthy={v['healthy']}"
        if not c:
            lines.append(f"| {name} | {method} | {status}: {v['detail'][:90]} | — | | | | | | |")
            continue
        check = "clean" if not c["defects"] else ("DEFECTS: " if v["claimed"] else "(not claimed) ") + "; ".join(
            c["defects"])
        lines.append(f"| {name} | {method} | {status} | {check} | {100 * c['coverage']:.1f}% | {c['min_corner']:.1f}° "
                     f"| {c['min_edge_ratio']:.3f} | {c['folded_faces'] + c['folded_edges']} "
                     f"| {c['intersecting_pairs']} | {c['max_planarity']:.2g} |")
    lines += ["", "| method | " + " | ".join(label for label, _, _ in UNIT_VARIANTS) + " |",
              "|---|" + "---|" * len(UNIT_VARIANTS)]
    for method in METHODS:
        got = [_UNITS.get((method, label)) for label, _, _ in UNIT_VARIANTS]
        if any(g is not None for g in got):
            cells = [("—" if g is None else g[:60] if isinstance(g, str) else f"{g[0]} faces, {g[1]:.2g}")
                     for g in got]
            lines.append(f"| {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _case(name: str, method: str, test: str):
    reason = XFAIL.get((name, method))
    applies = reason is not None and (test == "healthy" or not reason.startswith("reported"))
    # not strict: several of these sit at a bound (an edge of 0.197–0.198 × median against 0.2), so a change far away
    # can flip them either way; the table written with FABRICABLE_REPORT is the record
    marks = [pytest.mark.xfail(strict=False, reason=reason)] if applies else []
    return pytest.param(name, method, marks=marks, id=f"{name}-{method}")


# ----------------------------------------------------------------------------------------------
# the checker and the inputs


def test_checker_finds_known_defects():
    """The independent checker flags each defect kind on a small hand-made mesh and passes a clean grid."""
    V = np.array([[x, y, 0.0] for y in range(4) for x in range(4)])
    F = np.array([[i + 4 * j, i + 1 + 4 * j, i + 5 + 4 * j, i + 4 + 4 * j] for j in range(3) for i in range(3)])
    clean = independent_defects(V, F, (V, F))
    assert clean["defects"] == [] and clean["coverage"] == pytest.approx(1.0) and clean["min_corner"] == 90.0
    short = V.copy()
    short[5] = short[6] - [0.05, 0, 0]  # edge 5-6 is 0.05 of the median
    r = independent_defects(short, F)
    assert r["short_edges"] == 1 and r["min_edge_ratio"] == pytest.approx(0.05)
    slim = np.array([[0.0, 0, 0], [10, 0, 0], [10, 1, 0], [0, 1, 0]])
    sliver = independent_defects(slim, np.array([[0, 1, 2, 2], [0, 2, 3, 3]]))  # two 5.7° corners
    assert sliver["small_corners"] == 2 and sliver["min_corner"] == pytest.approx(np.degrees(np.arctan(0.1)))
    bow = V.copy()
    bow[[5, 6]] = bow[[6, 5]]  # swap two vertices: the middle quads become bow-ties
    assert independent_defects(bow, F)["folded_faces"] >= 1
    flip = V.copy()
    flip[15] = [1.5, 1.5, 0.0]  # the corner vertex folds back over the middle quad
    r = independent_defects(flip, F)
    assert r["folded_edges"] + r["intersecting_pairs"] >= 1
    # a second grid layer piercing the first one (no shared vertex): self-intersection
    W = np.vstack([V, V[:, [0, 2, 1]] + [0.25, 1.5, -1.5]])
    r = independent_defects(W, np.vstack([F, F + 16]))
    assert r["intersecting_pairs"] > 0
    # half the reference covered
    half = independent_defects(V, F[:3], (V, F))  # one row of three out of three rows
    assert half["coverage"] == pytest.approx(1 / 3, abs=0.02)
    # triangles as padded quads: (a, b, c, c)
    T = np.array([[0, 1, 5, 5], [0, 5, 4, 4]])
    assert independent_defects(V, T)["min_corner"] == pytest.approx(45.0)


@pytest.mark.parametrize("name", INPUTS)
def test_inputs_are_clean_open_surfaces(name):
    """Every input is an open surface the checker passes (corners aside: two real triangulations have slivers)."""
    V, T = surface(name)
    assert T.shape[1] == 3 and len(T) >= 150
    assert len(boundary_loops(T)) >= 1
    r = independent_defects(V, T, (V, T))
    assert r["folded_faces"] == r["folded_edges"] == r["intersecting_pairs"] == r["nonmanifold_edges"] == 0, r
    assert r["coverage"] == pytest.approx(1.0)
    if name not in ("igloo", "botanic_bubble"):
        assert r["defects"] == [], r["defects"]


# ----------------------------------------------------------------------------------------------
# the sweep


@pytest.mark.parametrize("name, method", [_case(n, m, "claim") for n in INPUTS for m in METHODS])
def test_claim_holds(name, method):
    """A result that claims success is fabricable by the independent check."""
    v = verdict(name, method)
    if method == "planarize" and v["status"] == "raised":
        assert v["error"] in TYPED_ERRORS, f"planarize raised an untyped error: {v['detail']}"
        return
    if not v["claimed"] or v["checked"] is None:
        return
    assert v["checked"]["defects"] == [], (
        f"{name} / {method} reports {v['status']} ({v['detail'][:120]}) but the independent check finds: "
        + "; ".join(v["checked"]["defects"]))


@pytest.mark.parametrize("name, method", [_case(n, m, "healthy") for n in SAMPLES + DISKS for m in STRATEGIES])
def test_healthy_or_typed_error(name, method):
    """On the sample surfaces and the shared disks: a healthy result, or a typed error that says why."""
    v = verdict(name, method)
    if v["status"] == "failed" or v["checked"] is None:
        assert v["error"] in TYPED_ERRORS, f"{name} / {method} failed without a typed error: {v['detail']}"
        assert len(v["detail"]) > len(v["error"]) + 10, "the error does not say why"
        return
    if v["healthy"] is not None:
        assert v["healthy"], f"{name} / {method} returned a result it reports {v['status']}: {v['detail']}"
    assert v["checked"]["defects"] == [], (
        f"{name} / {method} returned an unhealthy result: " + "; ".join(v["checked"]["defects"]))


# ----------------------------------------------------------------------------------------------
# units


def _unit_variant(method: str, scale: float, offset: float):
    """``(face count, max planarity)`` of one variant, or the failure as text."""
    if method == "planarize":
        res, _ = planarize_run("wave", scale, offset)
        if res is None or isinstance(res, Exception):
            return f"{type(res).__name__}: {res}"
        V, F = res.mesh
    else:
        res = strategy_run("wave", method, scale, offset)
        if res.final is None:
            return res.detail
        V, F = res.final
    V = (np.asarray(V) - offset) / scale  # measure in the ×1 frame
    return len(F), float(planarity(V, F).max())


_UNITS: dict = {}


@pytest.mark.parametrize("name, method", [_case("wave_units", m, "units") for m in METHODS])
def test_unit_scale(name, method):
    """The free-form sample at ×0.001, ×1, ×1000 and +5e6: same face counts, max planarity within 2×."""
    got = {label: _unit_variant(method, s, o) for label, s, o in UNIT_VARIANTS}
    _UNITS.update({(method, label): g for label, g in got.items()})
    failed = {k: v for k, v in got.items() if isinstance(v, str)}
    assert not failed, f"{method} failed at {failed}"
    counts = {k: v[0] for k, v in got.items()}
    assert len(set(counts.values())) == 1, f"{method}: face counts differ with the units: {counts}"
    pl = np.array([max(v[1], PLANARITY_FLOOR) for v in got.values()])
    assert pl.max() <= 2 * pl.min(), (
        f"{method}: max planarity differs by {pl.max() / pl.min():.3g}× with the units: "
        + ", ".join(f"{k} {v[1]:.2g}" for k, v in got.items()))

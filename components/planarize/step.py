"""One step of the planarization solver: solve the face-sized system, search along the step, accept or not.

Every iteration solves one sparse SPD system with one row per hard row, ``(J G Jᵀ) λ = rhs`` with ``G`` the
inverse metric of the soft goals (:func:`components.planarize.rows.inverse_metric`), for two right-hand sides: the
feasibility step ``Δf`` (the minimum-norm correction of the hard rows in the metric) and, in the optimize phase,
the optimality step ``Δo`` (the soft goals' step projected on the linearized constraints). :func:`solve_step`
then tries ``X + β Δf + t Δo`` (β ≤ 1 capped so that no vertex moves more than one mean edge, then halved; in the
optimize phase ``t`` is halved instead) until a trial is healthy (:mod:`components.planarize.guard`) and makes
progress: a lower planarity score (or the same worst face and a lower total excess over the tolerance, so that a
face held by the guard does not stop the others), or in the optimize phase a lower soft objective with planarity
within ``κ ×`` the tolerance. An unhealthy trial adds guard rows for the corners, edges, faces, hinges and face
normals it pushed toward their bounds and solves again (later in the iteration: takes a shorter healthy step first);
a trial that only crosses faces is shortened.

Damping (Levenberg–Marquardt): the system is solved as ``(J G Jᵀ + μ d I) λ = rhs`` with ``d`` its mean diagonal (of the
system factored; guard rows released from it keep its ``d``, see :class:`_Reduced`) and ``μ = 0.03 ×`` the RMS residual
of the planarity rows (:func:`damping`; at least 1e-10, which only keeps an exactly singular system factorable). Where
the linearized planarity and guard rows nearly contradict each other, the undamped system's multipliers reach 1e10 and
its step moves a few vertices tens of edges, so the step scaled to the trust region crawls; damped, such rows are met
only in part while the residual is large, and as it vanishes near the tolerance the step becomes the Gauss-Newton step
again (μ proportional to the residual keeps its fast final convergence). Measured on the saved conjugate-field
candidates (``benchmarks/convergence.py --saved``, 8k and 20k triangles, seeds 0-7, ×1, ×1000, +5e6, and the 20k
benchmark's candidate: 41 runs; CPU seconds): damped, with the flip rows of :mod:`components.planarize.guard`, 41
converge in 48 CPU s; undamped, 39 in 90 s without the flip rows and 40 in 110 s with them. The damped results' mean
closeness is 0.71× the undamped ones' (geometric mean). Also tried: 0.01 × the RMS (41, without flip rows), a fixed μ of
1e-4 (40; 1e-3 stalls near the tolerance), damping only the planarity rows (39), Marquardt's ``μ diag`` scaling (41, no
faster). Where the damped step finds no acceptable trial, the caller solves the iteration again undamped
(``damped=False``, :mod:`components.planarize.phases`): on the dos K-net ``obj_anet__knet1.obj`` the damped step could
not lower the worst face at its first iteration, the undamped one converges in 42.

Far moves: where the linearized planarity and guard rows of a few vertices nearly contradict each other, the
minimum-norm step moves those vertices tens of edges (up to 150 on the 200k-triangle benchmark patch, seed 1, where
the 99th percentile of the moves was under one edge), and the step, scaled so that no vertex moves more than one
edge, crawls everywhere (β 0.001-0.04: 100 iterations to 1.8e-3). When the caller asks for it
(``release_far``: the restore phase held at its closeness floor, see :mod:`components.planarize.phases`),
the guard rows of the vertices moving more than ``_FAR`` × the 99th percentile and more than one edge are released
(once per iteration, at its first solve that moves vertices that far) and the system solved again; the trials stay
health-checked.

An accepted trial still above the tolerance gets up to ``_CHORDS`` chord corrections: the feasibility step of its
residual solved with the same factorization (one back-substitution each, no new factor), kept while healthy and
lowering the planarity score (and, in the optimize phase, keeping the soft objective under the current one; not in
the optimize phase with a reference, where the objective costs a closest-point query).

Example
-------
A planar grid needs no correction: the feasibility step is zero.

>>> from components.core.mesh import quad_grid
>>> from components.planarize.guard import evaluate, panel_guard
>>> from components.planarize.problem import checked_options, setup_problem
>>> from components.planarize.rows import soft_terms
>>> V, F = quad_grid(3, 3, 3.0, 3.0)
>>> prob = setup_problem(V, F, None, checked_options(len(V)))
>>> guard = panel_guard(prob)
>>> cur = evaluate(prob, guard, prob.X0, np.zeros((0, 3)))
>>> step = solve_step(prob, guard, cur, soft_terms(prob, cur.X), np.zeros(guard.n_items, bool), 0.0)
>>> float(np.abs(step.df).max()), step.accepted is None
(0.0, True)
"""
from __future__ import annotations

import logging
from typing import NamedTuple

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

try:  # the face-sized systems' LDLᵀ (factor_spd); SuperLU where it is missing
    import qdldl
except ImportError:  # pragma: no cover - a core dependency
    qdldl = None

from components.planarize.guard import State, crossing_checked, evaluate, log_unhealthy, rows_to_guard, watched_rows
from components.planarize.rows import hard_residual, hard_rows, inverse_metric, soft_terms, times_blocks

log = logging.getLogger(__name__)

__all__ = ["KAPPA", "Factorization", "Step", "solve_step", "predicted_gain", "factor_spd", "damping"]

KAPPA = 30.0  # optimize phase: planarity may rise to κ × tolerance while the soft objective is lowered
_TRUST = 1.0  # no vertex moves more than this (mean edges) in one iteration
_GUARD_ATTEMPTS = 6  # re-solves per iteration that add guard rows
_RESOLVE_FIRST = 2  # attempts that solve again at once when a trial is unhealthy (later ones search on first)
_RELEASES = 3  # re-solves per iteration after releasing guard rows that hold their item down
_BACKTRACKS = 10  # step halvings per solve
_MIN_T = 1.0 / 64  # optimize phase: the smallest fraction of the optimality step tried
_FAR = 10.0  # a vertex moving this many times the 99th percentile of the moves (and over _TRUST) moves far
_DAMPING = 0.03  # damping of the system: this × the RMS residual of the planarity rows (relative to its diagonal)
_DAMP_FLOOR = 1e-10  # ... and at least this (an exactly singular system still factors)
_REDUCE = 64  # guard rows released from a factored system that are solved with its factor (_Reduced), not anew
_REDUCED_RES = 1e-8  # ... when the reduced solve's residual is within this share of the right-hand side's
_CHORDS = 2  # chord corrections (same factorization) of an accepted step still above the tolerance


class Factorization(NamedTuple):
    """One solve's system: hard rows ``J``, ``J G``, the factor of ``J G Jᵀ``, ``G`` blocks, rows before the guard."""

    J: object
    JG: object
    lu: object
    Gb: np.ndarray
    n_hard: int


class Directions(NamedTuple):
    """The feasibility and optimality steps of one solve and their multipliers."""

    fact: Factorization
    lam_f: np.ndarray
    df: np.ndarray  # (n, 3)
    lam_o: np.ndarray
    do: np.ndarray  # (n, 3), zero outside the optimize phase


class Step(NamedTuple):
    """What :func:`solve_step` did."""

    accepted: State | None  # the accepted trial, or None
    singular: bool  # the system could not be factored
    fact: Factorization | None  # of the last solve
    guard_sel: np.ndarray  # (2c + e + m + i + m,) bool, guard items with a row in the last solve
    t: float  # fraction of the optimality step taken
    beta: float  # fraction of the feasibility step taken
    df: np.ndarray | None
    do: np.ndarray | None
    f_new: float | None  # soft objective of the accepted optimize trial
    failed: tuple = ()  # the guards the last rejected trial failed


class _LDL:
    """The sparse LDLᵀ factor of an SPD system (``qdldl``: approximate minimum-degree ordering, no pivoting), with
    SuperLU's ``shape`` and ``solve`` (one or several right-hand sides)."""

    def __init__(self, S):
        self.shape = S.shape
        self._f = qdldl.Solver(S)

    def solve(self, b):
        b = np.asarray(b, dtype=np.float64)
        if b.ndim == 1:
            return self._f.solve(b)
        out = np.empty_like(b)
        for j in range(b.shape[1]):
            out[:, j] = self._f.solve(np.ascontiguousarray(b[:, j]))
        return out


def factor_spd(S):
    """Factor the SPD face-sized system: ``qdldl``'s sparse LDLᵀ where it is installed (a core dependency, wheels on
    Windows, macOS and Linux), else SuperLU in symmetric mode on the symmetric minimum-degree ordering (the orderings
    were benchmarked: COLAMD is 2–10× slower on these systems). Both factor without pivoting; on the 200k-triangle
    benchmark's systems (12.5-14.5k rows) LDLᵀ takes 27-38 ms per factorization against SuperLU's 36-66 ms and
    0.8 ms per solve against 1.3 (``benchmarks/solvers.py``). Raises ``RuntimeError`` on an exactly singular system
    that stays singular when damped."""
    S = S.tocsc()
    factor = _LDL if qdldl is not None and S.shape[0] else _superlu
    try:
        return factor(S)
    except RuntimeError:  # a zero pivot: exactly singular, damp
        d = S.diagonal()
        return factor(S + sp.identity(S.shape[0], format="csc") * (1e-9 * max(float(np.abs(d).max()), 1e-300)))


def _superlu(S):
    """SuperLU of the SPD system ``S`` (CSC) without pivoting, on the symmetric minimum-degree ordering."""
    return spla.splu(S, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))


def damping(r: np.ndarray) -> float:
    """Levenberg–Marquardt damping of the system, relative to its mean diagonal, from the residuals ``r`` of the
    planarity (and conical) rows: :data:`_DAMPING` × their RMS, at least :data:`_DAMP_FLOOR`.

    >>> damping(np.zeros(4)), damping(np.full(4, 0.02))
    (1e-10, 0.0006)
    """
    rms = float(np.sqrt(np.mean(r * r))) if len(r) else 0.0
    return max(_DAMP_FLOOR, _DAMPING * rms)


class _Reduced:
    """The factor of a factored system ``S λ = b`` with some of its rows and columns ``drop`` left out, without a new
    factorization (the guard rows found loose are released from the system just solved).

    The reduced system ``S_KK λ_K = b_K`` (``K``: the kept rows) is the full one with ``λ_D = 0`` held by
    multipliers ``z``: ``S λ + E z = b``, ``Eᵀ λ = 0`` (``E``: the unit columns of ``D``), so
    ``z = (Eᵀ S⁻¹ E)⁻¹ Eᵀ S⁻¹ b`` and ``λ = S⁻¹ (b − E z)`` (``b_D`` is arbitrary, it only changes ``z``). Costs
    ``|D|`` back-substitutions once and two per right-hand side.

    Its round-off grows with the condition of the full ``S``, which is far worse than the reduced one's where the
    dropped rows nearly depend on the kept ones (1e9 against 1e4 measured near the tolerance): every solve takes two
    steps of iterative refinement on the reduced system ``S_KK = J_K G J_Kᵀ + ε I`` (``JG, J``: its rows), which
    bring the error back to a fresh factor's. Unrefined, the optimize phase's step (a small difference of large terms)
    of the same noisy grid at ×1 and ×0.001 differed by 1e-3 of itself, and the results by 1e-4 of an edge; with one
    step by 8e-7 of an edge, with two by 1e-13, as with a new factor each time. :func:`_directions` also checks the
    residual.

    Measured (``benchmarks/convergence.py --saved``): half the factorizations (the 40 saved candidates 6813 → 3431),
    CPU 38.6 → 32.6 s, the same ones converged, closeness alike; the 200k benchmark candidate 214 → 106
    factorizations, 14.4 → 10.8 CPU s.
    """

    def __init__(self, lu, keep: np.ndarray, drop: np.ndarray, J, JG, eps: float):
        self.lu, self.keep, self.drop, self.J, self.JG, self.eps = lu, keep, drop, J, JG, eps
        E = np.zeros((lu.shape[0], len(drop)))
        E[drop, np.arange(len(drop))] = 1.0
        self.Z = lu.solve(E)  # S⁻¹ E
        self.C = sla.cho_factor(self.Z[drop], check_finite=False)  # Eᵀ S⁻¹ E, a principal block of S⁻¹: SPD

    def _solve(self, b):
        full = np.zeros(self.lu.shape[0])
        full[self.keep] = b
        x = self.lu.solve(full)
        x -= self.Z @ sla.cho_solve(self.C, x[self.drop], check_finite=False)
        return x[self.keep]

    def residual(self, x, b):
        """``S_KK x − b``."""
        return self.JG @ (self.J.T @ x) + self.eps * x - b

    def solve(self, b):
        x = self._solve(b)
        for _ in range(2):  # iterative refinement (see above)
            x = x - self._solve(self.residual(x, b))
        return x


class _Base(NamedTuple):
    """The last system of this step factored in full: its guard items, factorization, damping and rows' residuals."""

    sel: np.ndarray
    fact: Factorization
    eps: float
    r: np.ndarray


def _reduced(base: _Base, sel) -> tuple[Factorization, np.ndarray] | None:
    """The system of the guard items ``sel`` (a subset of the base's, fewer by 1 to :data:`_REDUCE`) solved with the
    base's factor (:class:`_Reduced`): ``(factorization, residuals)``, or None when it does not apply or its residual
    is not small."""
    in_base = np.isin(base.sel, sel, assume_unique=True)
    n_drop = len(base.sel) - int(in_base.sum())
    if not 0 < n_drop <= _REDUCE or int(in_base.sum()) != len(sel):
        return None
    f = base.fact
    keep = np.concatenate([np.arange(f.n_hard), f.n_hard + np.flatnonzero(in_base)])
    drop = f.n_hard + np.flatnonzero(~in_base)
    J, JG = f.J[keep], f.JG[keep]
    try:
        red = _Reduced(f.lu, keep, drop, J, JG, base.eps)
    except (np.linalg.LinAlgError, ValueError):
        return None
    return Factorization(J, JG, red, f.Gb, f.n_hard), base.r[keep]


def _directions(prob, guard, X, sel, Gb, gf, Ggf, optimize, damped=True, base: _Base | None = None):
    """Solve the system with guard rows at the corners ``sel`` (``None`` when it is singular even damped).

    With ``base`` (this step's last full factorization, at the same ``X``) a system whose guard rows are the base's
    less a few is solved with the base's factor (:class:`_Reduced`) when the residual of that solve is small.
    Returns ``(directions, base)``: the full factorization in use after this solve."""
    if base is not None:
        got = _reduced(base, sel)
        if got is not None:
            fact, r = got
            lam_f = fact.lu.solve(-r)
            res = fact.lu.residual(lam_f, -r)
            if np.isfinite(lam_f).all() and float(np.abs(res).max()) <= _REDUCED_RES * float(np.abs(r).max()):
                return _finish(fact, lam_f, gf, Ggf, optimize), base
    J, r, n_hard = hard_rows(prob, X, sel, guard.item_tgt[sel], guard.flip_normals)
    JG = times_blocks(J, Gb)
    S = (JG @ J.T).tocsc()
    mu = damping(r[:n_hard]) if damped else _DAMP_FLOOR
    eps = mu * max(float(S.diagonal().mean()), 1e-300)  # relative (the rows are scale-free); kept for released rows
    try:
        lu = factor_spd(S + sp.identity(S.shape[0], format="csc") * eps)
    except RuntimeError:  # singular even when damped (coincident vertices, collapsed faces)
        return None, base
    fact = Factorization(J, JG, lu, Gb, n_hard)
    return _finish(fact, lu.solve(-r), gf, Ggf, optimize), _Base(np.asarray(sel), fact, eps, r)


def _finish(fact: Factorization, lam_f, gf, Ggf, optimize) -> Directions:
    """The steps of the feasibility multipliers ``lam_f`` and, optimizing, the optimality solve."""
    lu, JG = fact.lu, fact.JG
    df = (JG.T @ lam_f).reshape(-1, 3)
    if optimize:
        lam_o = lu.solve(JG @ gf)
        do = (JG.T @ lam_o - Ggf).reshape(-1, 3)
    else:
        lam_o, do = np.zeros_like(lam_f), np.zeros_like(df)
    return Directions(fact, lam_f, df, lam_o, do)


def solve_step(prob, guard, cur: State, soft, sticky, t, optimize=False, release_far=False, damped=True) -> Step:
    """One iteration's step from ``cur`` (soft terms ``soft = (g, H, f)`` at ``cur.X``).

    ``t`` is the fraction of the optimality step to try first (0 outside the optimize phase). ``sticky``
    ``(2c + e + m + i + m,) bool`` holds the guard items whose rows are kept from step to step; it is updated in
    place (items added after an unhealthy trial, rows found loose released). ``release_far``: release the guard
    rows of vertices the step would move far; ``damped``: damp the system (:func:`damping`; see the module
    docstring).
    """
    X = cur.X
    g, H, f_cur = soft
    Gb = inverse_metric(prob, H, cur.tangents)
    gf = g.ravel()
    Ggf = np.einsum("nij,nj->ni", Gb, g).ravel()
    guard_sel = watched_rows(guard, cur.values, sticky)
    accepted, fact, beta, d, f_new, failed = None, None, 1.0, None, None, ()
    attempt = releases = 0
    far_checked = not release_far
    base = None
    while attempt < _GUARD_ATTEMPTS:
        sel = np.nonzero(guard_sel)[0]
        d, base = _directions(prob, guard, X, sel, Gb, gf, Ggf, optimize, damped, base)
        if d is None:
            return Step(None, True, fact, guard_sel, t, beta, None, None, None, failed)
        fact = d.fact
        if not (np.all(np.isfinite(d.df)) and np.all(np.isfinite(d.do))):
            break
        if not far_checked and len(sel):
            far = _far_vertices(d.df)
            far_checked = len(far) > 0  # once per iteration, at the first solve that moves vertices far
            held = _rows_at(fact, far)
            if len(held):
                guard_sel[sel[held]] = False
                sticky[sel[held]] = False
                continue
        if len(sel) and releases < _RELEASES:
            # the guard rows are inequalities: a row whose multiplier pushes its item down is not binding
            # (a row lifting its item to the target is kept: released, the item was pushed under its bound at
            # first order and the guard refused every step, e.g. an edge at 0.2 × the median on 20k seed 1)
            loose = d.lam_f[fact.n_hard:] + t * d.lam_o[fact.n_hard:] < 0
            if prob.lift_rows:
                loose &= cur.values[sel] >= guard.item_tgt[sel]
            if loose.any():
                guard_sel[sel[loose]] = False
                sticky[sel[loose]] = False
                releases += 1
                continue
        attempt += 1
        accepted, resolve, t, beta, f_new, failed = _line_search(
            prob, guard, cur, d, t, optimize, f_cur, guard_sel, sticky, attempt)
        if accepted is not None or not resolve:
            break
    return Step(accepted, False, fact, guard_sel, t, beta, d.df, d.do, f_new, failed)


def _far_vertices(df: np.ndarray) -> np.ndarray:
    """The vertices the step ``df`` (n, 3) moves more than ``_FAR`` × the 99th percentile of the moves and more
    than ``_TRUST`` mean edges."""
    move = np.linalg.norm(df, axis=1)
    if not len(move):
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero((move > _FAR * float(np.percentile(move, 99))) & (move > _TRUST))


def _rows_at(fact: Factorization, vertices: np.ndarray) -> np.ndarray:
    """Indices (among the guard rows of ``fact``) of the guard rows that involve any of ``vertices``."""
    if not len(vertices):
        return np.zeros(0, dtype=np.int64)
    Jg = fact.J[fact.n_hard:].tocsr()
    at = np.zeros(Jg.shape[1], dtype=bool)
    at[(3 * vertices[:, None] + np.arange(3)).ravel()] = True
    rows = np.repeat(np.arange(Jg.shape[0]), np.diff(Jg.indptr))
    return np.unique(rows[at[Jg.indices]])


def _line_search(prob, guard, cur, d, t, optimize, f_cur, guard_sel, sticky, attempt):
    """Try ``X + β Δf + t Δo`` with shrinking β (or t in the optimize phase).

    An unhealthy trial marks the items it pushed toward their bounds. In the first ``_RESOLVE_FIRST`` attempts the
    system is solved again at once with rows for them (a full step that respects the guard keeps Gauss-Newton's
    fast convergence); later the search goes on, a shorter healthy step is taken and the marked rows are kept for
    the next iteration (``sticky``), and only when no step is found is the system solved again with them.

    Returns ``(accepted or None, resolve, t, β, f_new, failed)``; ``resolve``: guard rows were added (``guard_sel``
    and ``sticky`` updated in place) and the system is to be solved again; ``failed``: the guards the last
    unhealthy trial failed.
    """
    X, df, do = cur.X, d.df, d.do
    move = float(np.linalg.norm(df, axis=1).max())
    beta = min(1.0, _TRUST / move) if move > 0 else 1.0
    f_new, failed = None, ()
    pending = np.zeros_like(guard_sel)
    last_attempt = attempt >= _GUARD_ATTEMPTS
    for _ in range(_BACKTRACKS):
        Xt, tt = prob.project_slide(X + beta * df + t * do)
        trial = evaluate(prob, guard, Xt, tt, crossings=False)
        accepted = None
        if not trial.healthy:
            log_unhealthy(guard, trial, beta, t)
            failed = trial.failed
            pending |= rows_to_guard(guard, trial, guard_sel | pending)
            if pending.any() and attempt <= _RESOLVE_FIRST and not last_attempt:
                break
        elif optimize:
            f_new = soft_terms(prob, trial.X, value_only=True)
            log.debug("   optimize trial t %.3g: score %.3g f %.6g -> %.6g", t, trial.score, f_cur, f_new)
            if trial.score <= KAPPA and f_new < f_cur:
                accepted = trial
        elif trial.score < cur.score or (trial.score <= cur.score and trial.excess < cur.excess):
            accepted = trial
        if accepted is not None:
            # chord corrections first: when one is taken (crossing-checked itself), the trial it corrects need not be
            corrected, f_chord = _chord(prob, guard, d.fact, accepted, optimize, f_cur, f_new)
            if corrected is not accepted:
                sticky |= pending
                return corrected, False, t, beta, f_chord, failed
            accepted = crossing_checked(prob, guard, accepted)  # the costly test, on the one trial to take
            if accepted.healthy:
                sticky |= pending
                return accepted, False, t, beta, f_new, failed
            failed = accepted.failed
            log_unhealthy(guard, accepted, beta, t)
        if optimize:
            t *= 0.5
            if t < _MIN_T:
                break
        else:
            beta *= 0.5
    if pending.any() and not last_attempt:
        guard_sel |= pending
        sticky |= pending
        return None, True, t, beta, f_new, failed
    return None, False, t, beta, f_new, failed


def _chord(prob, guard, fact: Factorization, st: State, optimize, f_cur, f_new):
    """Up to ``_CHORDS`` chord corrections of a trial ``st`` the line search would take (healthy but not yet tested
    for crossings) that is still above the tolerance: the feasibility step of the residual at ``st`` solved with
    this iteration's factorization (no new factor; the guard rows keep their items where they are to first order).
    A correction is kept while it is healthy (crossings included) and lowers the planarity score (in the optimize
    phase also keeps the soft objective under ``f_cur``): it removes most of the Gauss-Newton step's quadratic
    error, so the tolerance is often met without another iteration.

    Returns ``(state, f_new)``: ``st`` itself (still to be tested for crossings) when no correction was kept."""
    if fact is None:  # a search along given directions
        return st, f_new
    if optimize and prob.XR is not None:  # each correction would cost a closest-point query on the reference for its
        return st, f_new  # objective: more than the factorizations it saves (60² noisy grid on itself: 6.8 → 8.7 s)
    for _ in range(_CHORDS):
        if st.score <= 1.0:
            break
        rr = hard_residual(prob, st.X, fact.J.shape[0], fact.n_hard)
        dx = (fact.JG.T @ fact.lu.solve(-rr)).reshape(-1, 3)
        if not np.all(np.isfinite(dx)):
            break
        Xt, tt = prob.project_slide(st.X + dx)
        trial = evaluate(prob, guard, Xt, tt, crossings=False)
        if not (trial.healthy and trial.score < st.score):
            break
        f_t = soft_terms(prob, trial.X, value_only=True) if optimize else f_new
        if optimize and not f_t < f_cur:
            break
        trial = crossing_checked(prob, guard, trial)
        if not trial.healthy:
            break
        log.debug("   chord correction: score %.3g -> %.3g", st.score, trial.score)
        st, f_new = trial, f_t
    return st, f_new


def predicted_gain(prob, X, soft, fact: Factorization) -> tuple[float, float]:
    """Decrease of the soft objective that the next optimize step promises, from the quadratic model at ``X``
    with the previous iteration's factorization (one more solve, no new factor): ``f − m(Δf + Δo)``, and ``f``."""
    g, H, f = soft
    rr = hard_residual(prob, X, fact.J.shape[0], fact.n_hard)
    lam = fact.lu.solve(fact.JG @ g.ravel() - rr)
    step = (fact.JG.T @ lam).reshape(-1, 3) - np.einsum("nij,nj->ni", fact.Gb, g)
    gain = -float(np.einsum("ij,ij->", g, step)) - 0.5 * float(np.einsum("ni,nij,nj->", step, H, step))
    return gain, f

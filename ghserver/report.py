"""The comparison report: every PQ strategy on the built-in surfaces (and on mesh files), with pictures.

``ghserver report`` and ``ghserver demo`` call :func:`run_report` / :func:`run_demo` (wired in
:mod:`ghserver.cli` by :func:`add_report_arguments` / :func:`report_command` and :func:`add_demo_arguments` /
:func:`demo_command`). The output folder holds:

* ``report.html``: self-contained (inline CSS, no scripts, no fonts, no network) apart from the PNGs next to it,
  linked relatively as ``img/...``; valid HTML5;
* ``img/*.png``: every candidate and optimized mesh rendered and coloured per face by planarity, closeness and
  area (matplotlib, Agg backend, fixed size and camera per surface, a colour bar whose limits are the min/max of
  the plotted values), histograms of planarity / warping height / area before and after optimization, and the
  comparison plots (panel area against panel count per strategy and surface, planarity before/after);
* ``report.csv`` and ``report.json``: one row per (strategy, surface) with every metric and timing, the panel
  health of the candidate and of the final mesh (healthy, coverage, worst corner, shortest edge ÷ median, holes,
  violations) and the status; the JSON also records every image with the range of its colour bar;
* ``meshes/*.obj``: the candidate and optimized meshes;
* ``results.3dm``: the same meshes in one Rhino file, one layer per strategy, each object named
  ``"<surface> <stage>"``.

Every result with a mesh also gets a small fabrication section (:func:`fabrication_summary` of its final mesh,
``"fabrication"`` in the JSON): the number of panel types at 1, 2, 5 and 10 × 1e-3 of the median edge length, a
histogram of the kink angles at the joints, and the node axes' torsion.

A row's status is the harness's verdict (:func:`components.harness.judge` on
:func:`components.metrics.health.face_health` of the final mesh against the design surface): ``"ok"`` only for a
healthy result within the planarity tolerance; ``"unhealthy"`` and ``"tolerance missed"`` name the defect in the
status cell, and their meshes are pictured like the others; ``"failed"`` rows have no mesh.

matplotlib is imported inside the functions that draw (``matplotlib.use("Agg")`` there), never at import.
"""
from __future__ import annotations

import argparse
import csv
import datetime as _dt
import html
import json
import logging
import math
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

log = logging.getLogger(__name__)

DEFAULT_OUT = "ghserver-report"
IMAGE_SIZE = (900, 700)  # PNG width, height in pixels for the mesh pictures
_DPI = 100
HIST_SIZE = (1200, 420)
COMPARE_SIZE = (1200, 520)

#: measure key -> (title, unit) of the per-face colourings
MEASURES = {
    "planarity": ("planarity", "scale-free: diagonal distance / mean diagonal"),
    "closeness": ("closeness", "largest corner distance to the design surface, model units"),
    "area": ("panel area", "model units²"),
}

#: fixed camera (elevation, azimuth in degrees) per built-in surface; mesh files use the default
CAMERAS = {"dome": (32.0, -58.0), "saddle": (28.0, -50.0), "wave": (38.0, -70.0), "canopy": (42.0, -60.0)}
DEFAULT_CAMERA = (35.0, -60.0)


class Settings(NamedTuple):
    """Sizes of a report run."""

    resolution: int  # sample mesh resolution (edge lengths across the larger plan extent)
    divisions: int  # panels across the larger extent (panel size = extent / divisions)
    time_budget: float  # seconds per optimization


#: the strategies of :func:`components.harness.strategy_names`, for the command-line help (importing the harness
#: costs about a second at start, so the names are repeated here; keep them equal)
STRATEGY_NAMES = ("translation", "conjugate_field", "curvature_network", "subdivision")

QUICK = Settings(resolution=20, divisions=8, time_budget=10.0)
DEMO = Settings(resolution=48, divisions=20, time_budget=20.0)
FULL = Settings(resolution=80, divisions=32, time_budget=60.0)


class ReportSummary(NamedTuple):
    """What :func:`run_report` wrote."""

    out_dir: Path
    html: Path
    csv: Path
    json: Path
    rows: int
    images: int
    elapsed: float
    statuses: tuple = ()  # (surface, strategy, status, detail) per row



# ----------------------------------------------------------------------------------------------
# progress bar


class Progress:
    """A one-line progress bar on a stream (stderr), redrawn in place; silent when disabled or not a TTY."""

    def __init__(self, total: int, enabled: bool = True, stream=None, width: int = 28):
        self.stream = stream if stream is not None else sys.stderr
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = bool(enabled) and bool(isatty and isatty())
        self.total = max(int(total), 1)
        self.done = 0
        self.width = width
        self.t0 = time.perf_counter()
        self._last = 0

    def step(self, label: str = "", n: int = 1) -> None:
        self.done = min(self.done + n, self.total)
        self.show(label)

    def show(self, label: str = "") -> None:
        if not self.enabled:
            return
        frac = self.done / self.total
        fill = int(round(frac * self.width))
        el = time.perf_counter() - self.t0
        line = f"\r[{'#' * fill}{'.' * (self.width - fill)}] {self.done}/{self.total} {el:5.1f}s {label}"
        pad = max(self._last - len(line), 0)
        self._last = len(line)
        self.stream.write(line[:160] + " " * pad)
        self.stream.flush()

    def close(self) -> None:
        if self.enabled:
            self.stream.write("\n")
            self.stream.flush()


# ----------------------------------------------------------------------------------------------
# design surfaces


class Surface(NamedTuple):
    name: str
    V: np.ndarray
    T: np.ndarray
    description: str
    panel_size: float
    camera: tuple


def _builtin_surfaces(names, settings: Settings) -> list[Surface]:
    from components.surfaces.samples import sample_mesh, sample_surface_function
    from components.harness import default_panel_size

    out = []
    for name in names:
        V, T, _ = sample_mesh(name, settings.resolution)
        s = sample_surface_function(name)
        out.append(Surface(name, V, T, s.description, default_panel_size(V, settings.divisions),
                           CAMERAS.get(name, DEFAULT_CAMERA)))
    return out


def _file_surface(path, settings: Settings, taken: set, layer: str | None = None,
                  object_name: str | None = None) -> Surface:
    from components.core.checks import validate_mesh
    from components.core.mesh import remove_unreferenced, triangulate
    from components.harness import default_panel_size
    from ghserver.convert import read_model

    path = Path(path)
    V, F, notes = read_model(path, layer=layer, name=object_name)
    for note in notes:
        log.info("%s", note)
    V, F = validate_mesh(V, F, name=path.name)
    V, F, _ = remove_unreferenced(V, F)
    T = F if F.shape[1] == 3 else triangulate(F)[0]
    name = path.stem
    k = 2
    while name in taken:
        name = f"{path.stem}-{k}"
        k += 1
    desc = f"mesh file {path.name}: {len(V):,} vertices, {len(F):,} faces" + "".join(f"; {n}" for n in notes)
    return Surface(name, V, T, desc, default_panel_size(V, settings.divisions), DEFAULT_CAMERA)


# ----------------------------------------------------------------------------------------------
# per-face values


def face_values(V, F, measure: str, reference) -> np.ndarray:
    """Per-face values of a colouring measure.

    ``"planarity"`` (:func:`components.metrics.quality.quad_planarity`), ``"area"``
    (:func:`components.metrics.quality.polygon_areas`) or ``"closeness"``: the largest distance of the face's corners to the
    reference surface ``(V, T)``, so that the largest face value is the mesh's ``closeness_max`` metric.
    """
    from components.core.mesh import face_sizes
    from components.metrics.quality import polygon_areas, quad_planarity, vertex_distances

    if measure == "planarity":
        return quad_planarity(V, F)
    if measure == "area":
        return polygon_areas(V, F)
    if measure == "closeness":
        d, _ = vertex_distances(V, reference[0], reference[1], signed=False)
        d = np.abs(d)
        sizes = face_sizes(F)
        valid = np.arange(F.shape[1])[None, :] < sizes[:, None]
        return np.where(valid, d[F], -np.inf).max(axis=1)
    raise ValueError(f"unknown measure {measure!r}")



# ----------------------------------------------------------------------------------------------
# drawing (matplotlib, Agg)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt

    return plt


def _polygons(V, F):
    from components.core.mesh import face_sizes

    sizes = face_sizes(F)
    if np.all(sizes == F.shape[1]):
        return V[F]
    return [V[f[:s]] for f, s in zip(F, sizes)]


def _bbox(V):
    lo, hi = V.min(axis=0), V.max(axis=0)
    return lo, hi


def render_mesh(path, V, F, values, title: str, label: str, box, camera=DEFAULT_CAMERA,
                size=IMAGE_SIZE) -> tuple[float, float]:
    """Draw a mesh coloured per face by ``values`` and save it as a PNG of exactly ``size`` pixels.

    Parameters
    ----------
    path : path-like
        Output PNG.
    V : (n, 3) float64
    F : (m, k) int64
    values : (m,) float64
        Per-face values; the colour bar runs from their min to their max.
    title, label : str
        Figure title and colour-bar label.
    box : (lo, hi) pair of (3,) arrays
        Scene bounds (the same for every mesh of a surface, so pictures compare).
    camera : (elevation, azimuth)
        View angles in degrees.
    size : (width, height)
        Pixels.

    Returns
    -------
    vmin, vmax : float
        The colour-bar limits (= min and max of ``values``).
    """
    plt = _pyplot()
    from matplotlib import colors as mcolors
    from matplotlib.cm import ScalarMappable
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    values = np.asarray(values, dtype=np.float64)
    vmin, vmax = float(values.min()), float(values.max())
    lo_draw, hi_draw = vmin, vmax
    if not hi_draw > lo_draw:  # constant field: widen the drawn bar only, the reported limits stay exact
        pad = max(abs(vmin) * 1e-6, 1e-300)
        lo_draw, hi_draw = vmin - pad, vmax + pad
    norm = mcolors.Normalize(vmin=lo_draw, vmax=hi_draw)
    cmap = plt.get_cmap("viridis")
    fig = plt.figure(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
    try:
        ax = fig.add_axes([0.0, 0.02, 0.84, 0.9], projection="3d")
        coll = Poly3DCollection(_polygons(V, F), facecolors=cmap(norm(values)), edgecolors=(0.1, 0.1, 0.1, 0.6),
                                linewidths=0.3)
        ax.add_collection3d(coll)
        lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
        ext = np.maximum(hi - lo, 1e-9 * max(float(np.max(hi - lo)), 1.0))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(tuple(ext / ext.max()), zoom=1.15)
        ax.view_init(elev=camera[0], azim=camera[1])
        ax.set_axis_off()
        fig.suptitle(title, fontsize=12)
        cax = fig.add_axes([0.86, 0.15, 0.025, 0.7])
        sm = ScalarMappable(norm=norm, cmap=cmap)
        sm.set_array(values)
        cb = fig.colorbar(sm, cax=cax)
        cb.set_label(label, fontsize=9)
        cb.ax.tick_params(labelsize=8)
        fig.savefig(path, dpi=_DPI, format="png")
    finally:
        plt.close(fig)
    return vmin, vmax


def _log_values(x, floor=1e-12):
    return np.log10(np.maximum(np.asarray(x, dtype=np.float64), floor))


def render_histograms(path, before: dict, after: dict | None, title: str, size=HIST_SIZE) -> None:
    """Histograms of planarity, warping height (log10 scales) and area, before and after optimization.

    ``before`` / ``after`` map ``"planarity"``, ``"warping"``, ``"area"`` to per-face arrays.
    """
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
    try:
        spec = (("planarity", "log10 planarity", True), ("warping", "log10 warping height", True),
                ("area", "panel area", False))
        for ax, (key, xlabel, logscale) in zip(axes, spec):
            b = _log_values(before[key]) if logscale else np.asarray(before[key], float)
            a = None
            if after is not None:
                a = _log_values(after[key]) if logscale else np.asarray(after[key], float)
            allv = b if a is None else np.r_[b, a]
            lo, hi = float(allv.min()), float(allv.max())
            if not hi > lo:
                lo, hi = lo - 0.5, hi + 0.5
            bins = np.linspace(lo, hi, 31)
            ax.hist(b, bins=bins, histtype="stepfilled", alpha=0.45, color="#d95f02", label="candidate")
            if a is not None:
                ax.hist(a, bins=bins, histtype="stepfilled", alpha=0.45, color="#1b9e77", label="optimized")
            ax.set_xlabel(xlabel, fontsize=9)
            ax.set_ylabel("panels", fontsize=9)
            ax.tick_params(labelsize=8)
            ax.legend(fontsize=8)
        fig.suptitle(title + ("" if after is not None else " (no optimization step)"), fontsize=11)
        fig.subplots_adjust(left=0.05, right=0.98, bottom=0.15, top=0.86, wspace=0.25)
        fig.savefig(path, dpi=_DPI, format="png")
    finally:
        plt.close(fig)


_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
_COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666")


def render_area_vs_count(path, rows: list[dict], strategies: list[str], surfaces: list[str],
                         size=COMPARE_SIZE) -> None:
    """Panel area (mean ± std, min–max whiskers) against panel count, marker per strategy, colour per surface."""
    plt = _pyplot()
    from matplotlib.lines import Line2D

    fig, ax = plt.subplots(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
    try:
        for r in rows:
            m = r["final_metrics"]
            si, ti = surfaces.index(r["surface"]), strategies.index(r["strategy"])
            x, mean, std = m["faces"], m["area_mean"], m["area_std"]
            c = _COLORS[si % len(_COLORS)]
            ax.vlines(x, m["area_min"], m["area_max"], color=c, alpha=0.35, linewidth=1)
            ax.errorbar(x, mean, yerr=std, fmt=_MARKERS[ti % len(_MARKERS)], color=c, markersize=8, capsize=4)
        ax.set_xscale("log")
        ax.set_xlabel("panel count (faces)")
        ax.set_ylabel("panel area (model units²): mean ± std, line = min…max")
        ax.grid(True, alpha=0.3)
        handles = [Line2D([], [], color="k", marker=_MARKERS[i % len(_MARKERS)], linestyle="", label=s)
                   for i, s in enumerate(strategies)]
        handles += [Line2D([], [], color=_COLORS[i % len(_COLORS)], marker="s", linestyle="", label=s)
                    for i, s in enumerate(surfaces)]
        ax.legend(handles=handles, fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
        ax.set_title("Panel area against panel count, per strategy (marker) and surface (colour)")
        fig.subplots_adjust(left=0.08, right=0.8, bottom=0.12, top=0.9)
        fig.savefig(path, dpi=_DPI, format="png")
    finally:
        plt.close(fig)


def render_area_boxes(path, groups: list[tuple[str, np.ndarray]], title: str, size=COMPARE_SIZE) -> None:
    """Box plots of panel areas, one box per (label, areas) group."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
    try:
        ax.boxplot([g[1] for g in groups], showmeans=True)
        ax.set_xticks(range(1, len(groups) + 1), [g[0] for g in groups], fontsize=8)
        ax.set_ylabel("panel area (model units²)")
        ax.grid(True, axis="y", alpha=0.3)
        ax.set_title(title)
        fig.subplots_adjust(left=0.08, right=0.98, bottom=0.15, top=0.9)
        fig.savefig(path, dpi=_DPI, format="png")
    finally:
        plt.close(fig)


def render_planarity_bars(path, rows: list[dict], strategies: list[str], surfaces: list[str],
                          size=COMPARE_SIZE) -> None:
    """Max planarity before (hatched) and after optimization, per strategy and surface (log scale)."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
    try:
        width = 0.8 / max(len(strategies), 1)
        for r in rows:
            si, ti = surfaces.index(r["surface"]), strategies.index(r["strategy"])
            x = si + (ti - (len(strategies) - 1) / 2) * width
            b = max(r["metrics_before"]["planarity_max"], 1e-16)
            c = _COLORS[ti % len(_COLORS)]
            ax.bar(x, b, width=width * 0.9, color="none", edgecolor=c, hatch="//")
            if r["metrics_after"] is not None:
                ax.bar(x, max(r["metrics_after"]["planarity_max"], 1e-16), width=width * 0.9, color=c, alpha=0.8)
        ax.set_yscale("log")
        ax.set_xticks(range(len(surfaces)), surfaces)
        ax.set_ylabel("max planarity (scale-free)")
        from matplotlib.patches import Patch

        handles = [Patch(color=_COLORS[i % len(_COLORS)], label=s) for i, s in enumerate(strategies)]
        handles.append(Patch(facecolor="none", edgecolor="k", hatch="//", label="candidate (before)"))
        ax.legend(handles=handles, fontsize=8, loc="center left", bbox_to_anchor=(1.01, 0.5))
        ax.set_title("Max planarity of the candidate (hatched) and of the optimized mesh (filled)")
        ax.grid(True, axis="y", alpha=0.3)
        fig.subplots_adjust(left=0.08, right=0.8, bottom=0.1, top=0.9)
        fig.savefig(path, dpi=_DPI, format="png")
    finally:
        plt.close(fig)


# ----------------------------------------------------------------------------------------------
# HTML


_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0 auto;max-width:1600px;
padding:1em 2em;color:#222;background:#fff;line-height:1.4}
h1{margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0;font-size:.85em}
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right;vertical-align:top}
th{background:#f3f3f3}td.l,th.l{text-align:left}
tr.na td{color:#888;font-style:italic}tr.failed td{color:#a00}tr.unhealthy td.status{color:#a00}
tr.tolerance td.status{color:#8a5a00}td.status{min-width:12em;max-width:26em}td.warnings{min-width:5em;max-width:36em;font-size:.9em}
.bad{color:#a00;font-size:.9em}
.grid{display:flex;flex-wrap:wrap;gap:.8em}
figure{margin:0;flex:0 1 450px}figure img{width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.8em;color:#555}
.wide img{max-width:100%;height:auto}
.note{color:#555;font-size:.9em}.warn{color:#8a5a00;font-size:.85em}
details{margin:.4em 0}summary{cursor:pointer}
code{background:#f5f5f5;padding:0 .2em}
"""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _fmt(x, digits: int = 3) -> str:
    if x is None:
        return "–"
    if isinstance(x, str):
        return _e(x)
    x = float(x)
    if not math.isfinite(x):
        return _e(x)
    if x == 0:
        return "0"
    if x.is_integer() and abs(x) < 1e9:
        return f"{int(x):,}"
    if 1e-3 <= abs(x) < 1e5:
        return f"{x:.{digits}g}"
    return f"{x:.{digits - 1}e}"


def _img(src: str, alt: str, size) -> str:
    return f'<img src="{_e(src)}" alt="{_e(alt)}" width="{size[0]}" height="{size[1]}">'


_SUMMARY_COLUMNS = (
    ("faces", "panels", "before"),
    ("planarity_max", "max planarity before", "before"),
    ("planarity_max", "max planarity after", "after"),
    ("planarity_mean", "mean planarity after", "final"),
    ("warping_max", "max warping after", "final"),
    ("closeness_max", "max closeness after", "final"),
    ("area_mean", "mean area", "final"),
    ("area_std", "area std", "final"),
    ("corner_angle_min", "min corner angle (°)", "final"),
)


#: row class per status (colours the status cell)
_STATUS_CLASS = {"ok": "", "unhealthy": "unhealthy", "tolerance missed": "tolerance", "failed": "failed"}

#: the panel-health columns of the summary: row key, title
_HEALTH_COLUMNS = (
    ("healthy", "healthy"),
    ("coverage", "coverage"),
    ("worst_corner", "worst corner (°)"),
    ("shortest_edge_ratio", "shortest edge ÷ median"),
)


def status_text(r: dict) -> str:
    """The status cell: ``"ok"``, or the status and the defect (``"unhealthy: 3 edges shorter than …"``)."""
    return r["status"] if r["status"] == "ok" else f'{r["status"]}: {r["detail"]}'


def _health_cell(key: str, v) -> str:
    if v is None:
        return "<td>–</td>"
    if key == "healthy":
        return f"<td>{'yes' if v else 'no'}</td>"
    if key == "coverage":
        return f"<td>{_e(format(float(v), '.1%'))}</td>" if math.isfinite(float(v)) else "<td>–</td>"
    return f"<td>{_fmt(v)}</td>"


def _notes_cell(r: dict) -> str:
    """The warnings cell: the strategy's warnings and the panel-health violations, folded under their count."""
    notes = list(r["warnings"]) + list(r.get("violations") or ())
    if not notes:
        return '<td class="l warnings"></td>'
    lines = "<br>".join(_e(w) for w in notes)
    return (f'<td class="l warnings"><details><summary>{len(notes)} note{"" if len(notes) == 1 else "s"}</summary>'
            f"{lines}</details></td>")


def _summary_table(rows: list[dict]) -> str:
    head = "".join(f"<th>{_e(t)}</th>" for _, t in _HEALTH_COLUMNS) + '<th class="l">warnings</th>'
    head += "".join(f"<th>{_e(t)}</th>" for _, t, _ in _SUMMARY_COLUMNS)
    out = [f'<table><thead><tr><th class="l">surface</th><th class="l">strategy</th><th class="l">status</th>'
           f'{head}<th>time (s)</th></tr></thead><tbody>']
    for r in rows:
        cls = _STATUS_CLASS[r["status"]]
        cls = f' class="{cls}"' if cls else ""
        cells = [_health_cell(key, r.get(key)) for key, _ in _HEALTH_COLUMNS]
        cells.append(_notes_cell(r))
        for key, _, stage in _SUMMARY_COLUMNS:
            m = r["metrics_before"] if stage == "before" else (
                r["metrics_after"] if stage == "after" else r.get("final_metrics"))
            v = None if m is None else m.get(key)
            if v is not None and key == "corner_angle_min":
                v = math.degrees(v)
            cells.append(f"<td>{_fmt(v)}</td>")
        total = r["timings"].get("total")
        out.append(f'<tr{cls}><td class="l">{_e(r["surface"])}</td><td class="l">{_e(r["strategy"])}</td>'
                   f'<td class="l status">{_e(status_text(r))}</td>{"".join(cells)}<td>{_fmt(total)}</td></tr>')
    out.append("</tbody></table>")
    return "\n".join(out)


def _metrics_table(r: dict) -> str:
    b, a = r["metrics_before"], r["metrics_after"]
    keys = list(b)
    out = ['<table><thead><tr><th class="l">metric</th><th>candidate</th>'
           + ("<th>optimized</th>" if a is not None else "") + "</tr></thead><tbody>"]
    for k in keys:
        out.append(f'<tr><td class="l">{_e(k)}</td><td>{_fmt(b[k], 6)}</td>'
                   + (f"<td>{_fmt(a.get(k), 6)}</td>" if a is not None else "") + "</tr>")
    cand, final = r.get("candidate_health") or {}, r.get("final_health") or {}
    for key, title in _HEALTH_COLUMNS + (("holes", "holes"),):
        out.append(f'<tr><td class="l">health: {_e(title)}</td>{_health_cell(key, cand.get(key))}'
                   + (_health_cell(key, final.get(key)) if a is not None else "") + "</tr>")
    for k, v in r["timings"].items():
        out.append(f'<tr><td class="l">time: {_e(k)} (s)</td><td>{_fmt(v, 4)}</td>'
                   + ("<td></td>" if a is not None else "") + "</tr>")
    out.append("</tbody></table>")
    return "".join(out)


def _html(report: dict, titles: dict) -> str:
    rows = report["results"]
    s = report["settings"]
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en">',
        "<head>",
        '<meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        "<title>PQ strategies: comparison report</title>",
        '<link rel="icon" href="data:,">',  # no favicon request (a 404 would be a console error when served)
        f"<style>{_CSS}</style>",
        "</head>",
        "<body>",
        "<h1>Planar-quad meshing strategies: comparison report</h1>",
        f'<p class="note">Generated {_e(report["generated"])} in {report["elapsed"]:.1f} s; mode '
        f'<code>{_e(s["mode"])}</code>, sample resolution {s["resolution"]}, {s["divisions"]} panels across the '
        f'larger extent, optimization budget {s["time_budget"]:g} s per run. The same numbers: '
        '<a href="report.csv">report.csv</a>, <a href="report.json">report.json</a>; meshes in '
        "<code>meshes/</code>.</p>",
        "<h2>Strategies</h2><ul>",
    ]
    for name, (title, desc) in titles.items():
        parts.append(f"<li><b>{_e(title)}</b> (<code>{_e(name)}</code>): {_e(desc)}</li>")
    parts.append("</ul>")
    parts.append('<p class="note">Planarity is scale-free (distance between the diagonals / mean diagonal); '
                 "warping height and closeness (distance to the design surface) are in model units. Pictures are "
                 "coloured per face; every colour bar runs from the smallest to the largest plotted value.</p>")
    parts.append("<h2>Summary</h2>")
    parts.append(_summary_table(rows))
    for img in report["comparisons"]:
        size = img["size"]
        parts.append(f'<figure class="wide">{_img(img["file"], img["title"], size)}'
                     f'<figcaption>{_e(img["title"])}</figcaption></figure>')
    for surf in report["surfaces"]:
        sname = surf["name"]
        parts.append(f'<h2 id="surface-{_e(sname)}">Surface: {_e(sname)}</h2>')
        parts.append(f'<p class="note">{_e(surf["description"])}; design mesh {surf["vertices"]:,} vertices, '
                     f'{surf["triangles"]:,} triangles; panel size {surf["panel_size"]:.3g}.</p>')
        for r in (r for r in rows if r["surface"] == sname):
            title = titles[r["strategy"]][0]
            parts.append(f"<h3>{_e(title)} on {_e(sname)}</h3>")
            if not r["images"]:  # failed: no mesh to show
                parts.append(f'<p class="bad">{_e(status_text(r))}</p>')
                continue
            if r["status"] != "ok":
                parts.append(f'<p class="bad">{_e(status_text(r))}</p>')
            parts.append(f'<p class="note">{_e(r["description"])}</p>')
            for w in list(r["warnings"]) + [f"panel health: {v}" for v in r["violations"]]:
                parts.append(f'<p class="warn">⚠ {_e(w)}</p>')
            parts.append('<div class="grid">')
            for img in r["images"]:
                if img["kind"] != "mesh":
                    continue
                cap = (f'{img["stage"]}, {MEASURES[img["measure"]][0]}: {_fmt(img["vmin"])} … '
                       f'{_fmt(img["vmax"])}')
                parts.append(f'<figure>{_img(img["file"], cap, img["size"])}<figcaption>{_e(cap)}</figcaption>'
                             "</figure>")
            parts.append("</div>")
            for img in r["images"]:
                if img["kind"] == "histogram":
                    parts.append(f'<figure class="wide">{_img(img["file"], img["title"], img["size"])}'
                                 f'<figcaption>{_e(img["title"])}</figcaption></figure>')
            parts.append(_fabrication_html(r.get("fabrication")))
            files = " ".join(f'<a href="{_e(f)}">{_e(Path(f).name)}</a>' for f in r["meshes"].values())
            parts.append(f'<details><summary>All metrics and timings ({_e(r["strategy"])}, {_e(sname)})</summary>'
                         f'{_metrics_table(r)}<p class="note">Meshes: {files}</p></details>')
    parts.append("</body>")
    parts.append("</html>")
    return "\n".join(parts) + "\n"


# ----------------------------------------------------------------------------------------------
# CSV / JSON


#: panel-health fields of a row, as CSV columns (``candidate_*`` for the candidate's verdict)
_HEALTH_FIELDS = ("healthy", "coverage", "holes", "worst_corner", "shortest_edge_ratio")


def _csv_value(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v))


def _csv_rows(rows: list[dict]) -> tuple[list[str], list[dict]]:
    fixed = ["strategy", "surface", "status", "detail", "description", "panel_size", "tolerance",
             *_HEALTH_FIELDS, "violations", "warnings", *(f"candidate_{k}" for k in _HEALTH_FIELDS),
             "candidate_violations"]
    timing_keys, metric_keys = [], []
    for r in rows:
        for k in r["timings"]:
            if k not in timing_keys:
                timing_keys.append(k)
        for m in (r["metrics_before"], r["metrics_after"]):
            for k in (m or {}):
                if k not in metric_keys:
                    metric_keys.append(k)
    header = fixed + [f"time_{k}" for k in timing_keys] + [f"before_{k}" for k in metric_keys] + \
        [f"after_{k}" for k in metric_keys]
    out = []
    for r in rows:
        d = {"strategy": r["strategy"], "surface": r["surface"], "status": r["status"], "detail": r["detail"],
             "description": r["description"], "panel_size": repr(r["panel_size"]),
             "tolerance": repr(r["tolerance"]), "violations": " | ".join(r["violations"]),
             "warnings": " | ".join(r["warnings"])}
        cand = r["candidate_health"] or {}
        for k in _HEALTH_FIELDS:
            d[k] = _csv_value(r[k])
            d[f"candidate_{k}"] = _csv_value(cand.get(k))
        d["candidate_violations"] = " | ".join(cand.get("violations", ()))
        for k in timing_keys:
            d[f"time_{k}"] = repr(r["timings"][k]) if k in r["timings"] else ""
        for stage in ("before", "after"):
            m = r[f"metrics_{stage}"] or {}
            for k in metric_keys:
                d[f"{stage}_{k}"] = repr(float(m[k])) if k in m else ""
        out.append(d)
    return header, out


def _json_default(x):
    if isinstance(x, (np.floating, np.integer)):
        return x.item()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON serializable: {type(x).__name__}")


def _finite_json(x):
    """Replace non-finite floats (invalid JSON) by strings."""
    if isinstance(x, dict):
        return {k: _finite_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite_json(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return str(x)
    return x


# ----------------------------------------------------------------------------------------------
# the report


def _clean(out: Path) -> None:
    (out / "results.3dm").unlink(missing_ok=True)
    for sub, pattern in (("img", "*.png"), ("meshes", "*.obj")):
        d = out / sub
        d.mkdir(parents=True, exist_ok=True)
        for f in d.glob(pattern):
            f.unlink()


def _slug(*parts: str) -> str:
    keep = "-_."
    return "_".join("".join(c if c.isalnum() or c in keep else "-" for c in p) for p in parts)


def run_report(out_dir=DEFAULT_OUT, surfaces=None, mesh_files=(), progress: bool = True, quick: bool = False,
               strategies=None, settings: Settings | None = None, layer: str | None = None,
               object_name: str | None = None, mode: str | None = None) -> ReportSummary:
    """Run every strategy on the built-in surfaces (and mesh files) and write the comparison report.

    Parameters
    ----------
    out_dir : path-like
        Output folder (created; previous ``img/*.png`` and ``meshes/*.obj`` in it are removed).
    surfaces : iterable of str, optional
        Built-in surfaces to use (default: all of :data:`components.surfaces.samples.SAMPLE_NAMES`); ``()`` for none.
    mesh_files : iterable of path-like
        Extra design surfaces read from .3dm (a mesh, a NURBS surface or a one-face Brep), STL (welded), OBJ, OFF
        or PLY files (triangulated); see :func:`ghserver.convert.read_model`.
    progress : bool
        Show a progress bar on stderr (only when stderr is a terminal).
    quick : bool
        Small meshes and few panels (a test-sized run); ignored when ``settings`` is given.
    strategies : iterable of str, optional
        Strategy keys (default: all of :func:`components.harness.strategy_names`).
    settings : Settings, optional
        Explicit sizes (resolution, divisions, time budget).
    layer, object_name : str, optional
        Pick the object of a .3dm mesh file that holds several (by layer name or object name).
    mode : str, optional
        Label of the run in the report (default: "quick", "standard" or "full" after the settings, "custom" for
        others; :func:`run_demo` passes "demo").

    Returns
    -------
    ReportSummary
        Paths written, number of rows and images, elapsed seconds.
    """
    from components.core.errors import InputError
    from components.core.mesh import write_obj
    from components.surfaces.samples import SAMPLE_NAMES
    from components.harness import get_strategy, run_strategy, strategy_names

    t0 = time.perf_counter()
    settings = settings or (QUICK if quick else DEMO)
    if mode is None:
        mode = ("custom" if settings not in (QUICK, DEMO, FULL)
                else {QUICK: "quick", DEMO: "standard", FULL: "full"}[settings])
    names = list(SAMPLE_NAMES if surfaces is None else surfaces)
    unknown = [n for n in names if n not in SAMPLE_NAMES]
    if unknown:
        raise InputError("surfaces", f"unknown built-in surface(s) {', '.join(map(repr, unknown))}; valid: "
                         f"{', '.join(SAMPLE_NAMES)}")
    strat_names = list(strategies or strategy_names())
    titles = {n: (get_strategy(n).title, get_strategy(n).description) for n in strat_names}
    surfs = _builtin_surfaces(names, settings)
    taken = set(names)
    for f in mesh_files or ():
        s = _file_surface(f, settings, taken, layer=layer, object_name=object_name)
        taken.add(s.name)
        surfs.append(s)
    if not surfs:
        raise InputError("surfaces", "nothing to report on: no built-in surface and no mesh file")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    _clean(out)
    # progress units: one per strategy run, one per picture (estimated: 3 per mesh + 1 histogram)
    bar = Progress(len(surfs) * len(strat_names) * 8 + 3, enabled=progress)
    rows: list[dict] = []
    surf_info = []
    n_images = 0
    model_meshes = []  # (layer = strategy, name, V, F) of every result mesh, for results.3dm
    try:
        for surf in surfs:
            lo, hi = _bbox(surf.V)
            pad = 0.03 * float(np.max(hi - lo))
            surf_info.append({"name": surf.name, "description": surf.description, "vertices": int(len(surf.V)),
                              "triangles": int(len(surf.T)), "panel_size": surf.panel_size,
                              "camera": list(surf.camera)})
            for sname in strat_names:
                bar.show(f"{surf.name}: {sname}")
                res = run_strategy(sname, surf.V, surf.T, surf.panel_size, surface=surf.name,
                                   time_budget=settings.time_budget)
                bar.step(f"{surf.name}: {sname} {res.status}")
                row = {"strategy": sname, "surface": surf.name, "status": res.status, "detail": res.detail,
                       "description": res.description, "panel_size": res.panel_size, "tolerance": res.tolerance,
                       **_health_fields(res.health), "violations": list(res.violations),
                       "candidate_health": _health_summary(res.candidate_health),
                       "timings": dict(res.timings),
                       "metrics_before": res.metrics_before, "metrics_after": res.metrics_after,
                       "final_metrics": res.metrics_after or res.metrics_before,
                       "warnings": list(res.warnings), "images": [], "meshes": {}}
                row["final_health"] = _health_summary(res.health)
                rows.append(row)
                if row["final_metrics"] is None:  # failed: nothing to draw
                    bar.step(n=7)
                    continue
                # the meshes and their pictures; the scene box covers the design surface and every result
                stages = [("candidate", res.candidate)] + ([("optimized", res.optimized)]
                                                           if res.optimized is not None else [])
                allV = np.vstack([surf.V] + [m[0] for _, m in stages])
                box = (allV.min(axis=0) - pad, allV.max(axis=0) + pad)
                per_stage = {}
                for stage, (Vm, Fm) in stages:
                    mesh_file = f"meshes/{_slug(surf.name, sname, stage)}.obj"
                    write_obj(out / mesh_file, Vm, Fm)
                    model_meshes.append((sname, f"{surf.name} {stage}", Vm, Fm))
                    row["meshes"][stage] = mesh_file
                    from components.metrics.quality import warping_height

                    per_stage[stage] = {"warping": warping_height(Vm, Fm)}
                    for measure, (mtitle, unit) in MEASURES.items():
                        vals = face_values(Vm, Fm, measure, (surf.V, surf.T))
                        per_stage[stage][measure] = vals
                        fname = f"img/{_slug(surf.name, sname, stage, measure)}.png"
                        title = f"{titles[sname][0]} on {surf.name}: {stage}, {mtitle} ({len(Fm):,} panels)"
                        vmin, vmax = render_mesh(out / fname, Vm, Fm, vals, title, f"{mtitle} ({unit})", box,
                                                 surf.camera)
                        n_images += 1
                        row["images"].append({"kind": "mesh", "file": fname, "stage": stage, "measure": measure,
                                              "vmin": vmin, "vmax": vmax, "faces": int(len(Fm)),
                                              "vertices": int(len(Vm)), "size": list(IMAGE_SIZE)})
                        bar.step(f"{surf.name}: {sname} {stage} {measure}")
                row["fabrication"] = fabrication_summary(*stages[-1][1][:2])
                fname = f"img/{_slug(surf.name, sname, 'histograms')}.png"
                htitle = f"{titles[sname][0]} on {surf.name}: candidate vs optimized"
                render_histograms(out / fname, per_stage["candidate"], per_stage.get("optimized"), htitle)
                n_images += 1
                row["images"].append({"kind": "histogram", "file": fname, "title": htitle, "size": list(HIST_SIZE)})
                bar.step(f"{surf.name}: {sname} histograms", n=8 - 1 - 3 * len(stages))
        # comparison plots over every measured run (unhealthy ones included: their panels are the point)
        ok = [r for r in rows if r["final_metrics"] is not None]
        comparisons = []
        surf_names = [s.name for s in surfs]
        if ok:
            f = "img/compare_area_vs_count.png"
            render_area_vs_count(out / f, ok, strat_names, surf_names)
            comparisons.append({"kind": "comparison", "file": f, "size": list(COMPARE_SIZE),
                                "title": "Panel area against panel count per strategy and surface"})
            f = "img/compare_planarity.png"
            render_planarity_bars(out / f, ok, strat_names, surf_names)
            comparisons.append({"kind": "comparison", "file": f, "size": list(COMPARE_SIZE),
                                "title": "Max planarity before and after optimization per strategy and surface"})
            groups = []
            for r in ok:
                mesh_file = r["meshes"].get("optimized") or r["meshes"]["candidate"]
                stage = "optimized" if "optimized" in r["meshes"] else "candidate"
                areas = _areas_of(out / mesh_file)
                groups.append((f"{r['surface']}\n{r['strategy']}\n({stage})", areas))
            f = "img/compare_area_boxes.png"
            render_area_boxes(out / f, groups, "Panel area distribution of the final mesh per surface and strategy")
            comparisons.append({"kind": "comparison", "file": f, "size": list(COMPARE_SIZE),
                                "title": "Panel area distribution (box: quartiles, line: median, triangle: mean)"})
            n_images += len(comparisons)
        bar.step("comparison plots", n=3)
        if model_meshes:
            from ghserver.convert import write_meshes_3dm

            write_meshes_3dm(out / "results.3dm", model_meshes)
        elapsed = time.perf_counter() - t0
        report = {
            "generated": _dt.datetime.now().isoformat(timespec="seconds"),
            "elapsed": elapsed,
            "settings": {"mode": mode, **settings._asdict(), "image_size": list(IMAGE_SIZE)},
            "strategies": [{"name": n, "title": titles[n][0], "description": titles[n][1]} for n in strat_names],
            "surfaces": surf_info,
            "results": [{k: v for k, v in r.items() if k not in ("final_metrics", "final_health")} for r in rows],
            "comparisons": comparisons,
        }
        html_path, csv_path, json_path = out / "report.html", out / "report.csv", out / "report.json"
        json_path.write_text(json.dumps(_finite_json(report), indent=1, default=_json_default), encoding="utf-8")
        header, crow = _csv_rows(rows)
        with open(csv_path, "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=header)
            w.writeheader()
            w.writerows(crow)
        report["results"] = rows  # keep final_metrics for the HTML
        html_path.write_text(_html(report, titles), encoding="utf-8")
    finally:
        bar.close()
    log.info("report: %d rows, %d images in %.1f s -> %s", len(rows), n_images, elapsed, html_path)
    statuses = tuple((r["surface"], r["strategy"], r["status"], r["detail"]) for r in rows)
    return ReportSummary(out, html_path, csv_path, json_path, len(rows), n_images, elapsed, statuses)


def _health_fields(h) -> dict:
    """The summary's health values of a :class:`components.metrics.health.PanelHealth` (all None without one)."""
    from components.harness import shape_healthy

    if h is None:
        return {k: None for k in _HEALTH_FIELDS}
    return {"healthy": shape_healthy(h), "coverage": None if math.isnan(h.coverage) else float(h.coverage),
            "holes": int(h.holes), "worst_corner": float(h.worst_corner),
            "shortest_edge_ratio": float(h.shortest_edge_ratio)}


def _health_summary(h) -> dict | None:
    """:func:`_health_fields` and the violation lines, or None without a verdict."""
    if h is None:
        return None
    return {**_health_fields(h), "violations": list(h.violations)}


def _areas_of(path: Path) -> np.ndarray:
    from components.core.mesh import read_mesh
    from components.metrics.quality import polygon_areas

    V, F = read_mesh(path)
    return polygon_areas(V, F)


#: kink-angle histogram bins of the fabrication section (degrees)
KINK_BINS = (0.0, 1.0, 2.0, 5.0, 10.0, 20.0, 180.0)


def fabrication_summary(V, F) -> dict:
    """Panel types against the tolerance, the kink histogram and the torsion of a final mesh (the report's
    fabrication section); ``{"error": message}`` when the mesh cannot be fabricated as it is (e.g. a collapsed
    face).

    The tolerances are 1, 2, 5 and 10 × 1e-3 of the median edge length (the default of
    :func:`components.fabrication.export.fabrication`), so surfaces of any size compare.
    """
    from components.fabrication.export import fabrication

    try:
        fab = fabrication(V, F)
    except ValueError as exc:  # InputError / MeshError: say why instead of a section
        return {"error": str(exc)}
    dh = fab.dihedrals
    kinks = dh.angle[dh.interior]
    tors = np.abs(fab.frames.torsion)
    return {
        "panels": int(len(F)),
        "tolerances": [float(t) for t in fab.types.tolerances],
        "type_counts": [int(c) for c in fab.types.type_counts],
        "kink_bins": list(KINK_BINS),
        "kink_counts": [int(c) for c in np.histogram(kinks, bins=KINK_BINS)[0]],
        "max_kink": float(kinks.max()) if len(kinks) else 0.0,
        "mean_kink": float(kinks.mean()) if len(kinks) else 0.0,
        "axes": fab.supports.method,
        "conical": bool(fab.supports.conical),
        "max_torsion": float(tors.max(initial=0.0)),
        "mean_torsion": float(tors.mean()) if len(tors) else 0.0,
        "max_length_error": float(fab.flat.length_error.max(initial=0.0)),
    }


def _fabrication_html(fab: dict | None) -> str:
    if not fab:
        return ""
    if "error" in fab:
        return f'<p class="note">Fabrication: {_e(fab["error"])}</p>'
    tol = "".join(f"<th>{_fmt(t)}</th>" for t in fab["tolerances"])
    types = "".join(f"<td>{c}</td>" for c in fab["type_counts"])
    b = fab["kink_bins"]
    bins = "".join(f"<th>{_fmt(lo)}–{_fmt(hi)}°</th>" for lo, hi in zip(b[:-1], b[1:]))
    counts = "".join(f"<td>{c}</td>" for c in fab["kink_counts"])
    axes = f'{fab["axes"]} axes ({"conical" if fab["conical"] else "not conical"})'
    return ("<h4>Fabrication (final mesh)</h4>"
            f'<table><thead><tr><th class="l">panel types at tolerance</th>{tol}</tr></thead>'
            f'<tbody><tr><td class="l">types of {fab["panels"]:,} panels</td>{types}</tr></tbody></table>'
            f'<table><thead><tr><th class="l">kink angle</th>{bins}</tr></thead>'
            f'<tbody><tr><td class="l">joints</td>{counts}</tr></tbody></table>'
            f'<p class="note">Kinks: max {_fmt(fab["max_kink"])}°, mean {_fmt(fab["mean_kink"])}°. Node {_e(axes)}: '
            f'torsion max {_fmt(fab["max_torsion"])}°, mean {_fmt(fab["mean_torsion"])}°. Flat panels keep their '
            f'3D edges and diagonals to {_fmt(fab["max_length_error"])} (relative).</p>')


def run_demo(out_dir=DEFAULT_OUT, progress: bool = True) -> ReportSummary:
    """The report on the four built-in surfaces at a moderate resolution (about a minute on 2 cores)."""
    return run_report(out_dir, surfaces=None, progress=progress, settings=DEMO, mode="demo")


# ----------------------------------------------------------------------------------------------
# command line


def add_report_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``ghserver report``."""
    parser.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default ./{DEFAULT_OUT})")
    parser.add_argument("meshes", nargs="*", help="extra design surfaces: .3dm (a mesh, NURBS surface or one-face "
                                                  "Brep), .stl (welded), .obj, .off or .ply files")
    parser.add_argument("--layer", default=None, help="in a .3dm holding several meshes/surfaces: the layer to use")
    parser.add_argument("--object", default=None, help="in a .3dm holding several meshes/surfaces: the object name")
    parser.add_argument("--surfaces", default=None,
                        help="comma-separated built-in surfaces (default: all; 'none' for mesh files only)")
    parser.add_argument("--strategies", default=None,
                        help=f"comma-separated strategies: {', '.join(STRATEGY_NAMES)} (default: all)")
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="small meshes, few panels (seconds)")
    size.add_argument("--full", action="store_true", help="finer meshes and more panels (minutes)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_demo_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``ghserver demo``."""
    parser.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default ./{DEFAULT_OUT})")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def _split(value):
    if value is None:
        return None
    if value.strip().lower() == "none":
        return []
    return [v.strip() for v in value.split(",") if v.strip()]


def _done(summary: ReportSummary) -> int:
    for surface, strategy, status, detail in summary.statuses:
        line = f"  {surface:<10} {strategy:<18} {status}"
        if status != "ok":
            line += f": {detail}" if len(detail) <= 160 else f": {detail[:157]}..."
        print(line)
    print(f"report written to {summary.html} ({summary.rows} rows, {summary.images} images) in "
          f"{summary.elapsed:.1f} s; serve it with: ghserver serve --report-dir {summary.out_dir}")
    return 0


def report_command(args) -> int:
    """``ghserver report``: run :func:`run_report` from parsed arguments; prints where the report is."""
    settings = FULL if args.full else (QUICK if args.quick else DEMO)
    try:
        summary = run_report(args.out, surfaces=_split(args.surfaces), mesh_files=args.meshes,
                             progress=not args.no_progress, strategies=_split(args.strategies), settings=settings,
                             layer=args.layer, object_name=args.object)
    except (ValueError, OSError) as exc:  # InputError / MeshError are ValueErrors: a bad file or option
        print(f"ghserver report: {exc}", file=sys.stderr)
        return 2
    return _done(summary)


def demo_command(args) -> int:
    """``ghserver demo``: run :func:`run_demo`; prints the elapsed time and where the report is."""
    return _done(run_demo(args.out, progress=not args.no_progress))

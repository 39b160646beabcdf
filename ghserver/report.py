"""The comparison report: every PQ strategy on the built-in surfaces (and on mesh files), with pictures.

``ghserver report`` and ``ghserver demo`` call :func:`run_report` / :func:`run_demo` (wired in
:mod:`ghserver.cli` by :func:`add_report_arguments` / :func:`report_command` and :func:`add_demo_arguments` /
:func:`demo_command`). The output folder holds:

* ``report.html``: inline CSS, no fonts, no network; a table of contents, the summary (status from panel health
  with the defect named, a warnings column), the comparison plots, and per result its warnings, an interactive 3D
  view, the pictures, the histograms and a fabrication section; valid HTML5. It links only files beside it
  (``img/...``, ``viewer/...``), so it works opened from disk (``file://``) and served
  (``ghserver serve --report-dir``);
* ``img/*.png``: every candidate and optimized mesh rendered and coloured per face by planarity, closeness and
  area (matplotlib, Agg backend, fixed size and camera per surface, a colour bar whose limits are the min/max of
  the plotted values; a field that is one number up to round-off, :func:`constant_field`, is drawn in one colour
  and labelled "all equal to …"), histograms of planarity / warping height / area before and after optimization,
  and the comparison plots (panel area against panel count, planarity before/after, panel-area box plots). No
  text is below :data:`MIN_FONT_PT` and the page shows every picture at (at most) its pixel size, so the smallest
  text is :data:`MIN_FONT_PX` ≥ 11 pixels on a 1280-pixel-wide window;
* ``viewer/``: the 3D views: ``viewer.js`` (classic script), ``three.js`` (three.js's ES modules from
  ``ghserver/static/three`` joined into one classic script, :func:`viewer_bundle`, with ``three-LICENSE.txt``) and
  ``data/<surface>_<strategy>.js`` (:func:`view_data`: float32 vertices about the box centre, the faces and the
  per-face fields). A view starts when scrolled into sight (or clicked): orbit, zoom, pan, colour by planarity,
  closeness, area or warping height, candidate / optimized toggle; at most a few hold a WebGL context at once;
  meshes over :data:`VIEW_FACE_CAP` faces get a note instead;
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
import base64
import csv
import datetime as _dt
import html
import json
import logging
import math
import re
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

log = logging.getLogger(__name__)

DEFAULT_OUT = "ghserver-report"
IMAGE_SIZE = (400, 340)  # PNG width, height in pixels for the mesh pictures (three side by side on the page)
_DPI = 100
HIST_SIZE = (1200, 400)
COMPARE_SIZE = (1200, 520)

#: measure key -> (title, unit) of the per-face colourings
MEASURES = {
    "planarity": ("planarity", "scale-free: diagonal distance / mean diagonal"),
    "closeness": ("closeness", "largest corner distance to the design surface, model units"),
    "area": ("panel area", "model units²"),
}

#: the colour-bar label's unit per measure (the pictures are small; the page says the rest)
_SHORT_UNITS = {"planarity": "scale-free", "closeness": "model units", "area": "model units²"}

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
    units: str | None = None  # a .3dm's unit system by Rhino's name; None: not given (the built-in surfaces)


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
    V, F, notes, units = read_model(path, layer=layer, name=object_name)
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
    return Surface(name, V, T, desc, default_panel_size(V, settings.divisions), DEFAULT_CAMERA, units)


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


#: smallest font of every figure, in points; at :data:`_DPI` a point is ``_DPI / 72`` pixels, and the page shows
#: every picture at its own pixel size (CSS ``max-width``), so the smallest text is :data:`MIN_FONT_PX` pixels
MIN_FONT_PT = 9.0
MIN_FONT_PX = MIN_FONT_PT * _DPI / 72.0

#: matplotlib sizes of the report's figures (no text below :data:`MIN_FONT_PT`)
_RC = {"font.size": 10.0, "axes.titlesize": 11.0, "axes.labelsize": 10.0, "xtick.labelsize": MIN_FONT_PT,
       "ytick.labelsize": MIN_FONT_PT, "legend.fontsize": MIN_FONT_PT, "legend.title_fontsize": 10.0,
       "figure.titlesize": 11.0}


#: a field whose spread (max - min) is at most this share of its scale is drawn as constant
CONSTANT_SPREAD = 1e-9


def constant_field(values, scale: float = 0.0) -> str | None:
    """``"all equal to …"`` when the per-face values are one number up to round-off, else None.

    The values are constant when ``max - min <= 1e-9 × max(max |value|, scale)``; ``scale`` is the size the
    measure is relative to (1 for the scale-free planarity, a length of the mesh for distances, its square for
    areas), so that a round-off spread (1e-16 planarity of a translation surface) counts as constant at every
    model scale. Values that are also within round-off of zero read ``"all equal to 0 (round-off …)"``.

    >>> constant_field([1e-16, 1.2e-16, 0.0], scale=1.0)
    'all equal to 0 (round-off: |value| ≤ 1.2e-16)'
    >>> constant_field([2.5, 2.5, 2.5 + 1e-12], scale=10.0)
    'all equal to 2.5'
    >>> constant_field([1e-3, 2e-3], scale=1.0) is None
    True
    """
    v = np.asarray(values, dtype=np.float64).ravel()
    v = v[np.isfinite(v)]
    if v.size == 0:
        return None
    top = float(np.max(np.abs(v)))
    scale = abs(float(scale)) if math.isfinite(float(scale)) else 0.0
    if not float(v.max() - v.min()) <= CONSTANT_SPREAD * max(top, scale):
        return None
    if top == 0.0:
        return "all equal to 0"
    if top <= CONSTANT_SPREAD * scale:
        return f"all equal to 0 (round-off: |value| ≤ {_fmt(top, 2)})"
    return f"all equal to {_fmt(float(np.median(v)), 4)}"


def measure_scale(measure: str, length: float) -> float:
    """The scale a per-face measure is relative to (for :func:`constant_field`): 1 for the scale-free planarity,
    ``length`` (a length of the mesh, e.g. its bounding-box diagonal) for distances, ``length²`` for areas."""
    if measure == "planarity":
        return 1.0
    if measure == "area":
        return float(length) ** 2
    return float(length)


def _polygons(V, F):
    from components.core.mesh import face_sizes

    sizes = face_sizes(F)
    if np.all(sizes == F.shape[1]):
        return V[F]
    return [V[f[:s]] for f, s in zip(F, sizes)]


def _bbox(V):
    lo, hi = V.min(axis=0), V.max(axis=0)
    return lo, hi


#: the single colour of a constant field (the middle of viridis)
CONSTANT_COLOUR = "#21918c"


def render_mesh(path, V, F, values, title: str, label: str, box, camera=DEFAULT_CAMERA,
                size=IMAGE_SIZE, scale: float | None = None) -> tuple[float, float]:
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
        Figure title and colour-bar label (keep them short: the picture is :data:`IMAGE_SIZE` pixels and no font is
        below :data:`MIN_FONT_PT`).
    box : (lo, hi) pair of (3,) arrays
        Scene bounds (the same for every mesh of a surface, so pictures compare).
    camera : (elevation, azimuth)
        View angles in degrees.
    size : (width, height)
        Pixels.
    scale : float, optional
        The measure's scale (:func:`measure_scale`); when given, a field that is constant up to round-off
        (:func:`constant_field`) is drawn in one colour and labelled "all equal to …" instead of a colour bar.
        Exactly equal values always are.

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
    same = constant_field(values, 0.0 if scale is None else scale)
    norm = mcolors.Normalize(vmin=vmin, vmax=vmax if vmax > vmin else vmin + 1.0)
    cmap = plt.get_cmap("viridis")
    colours = [CONSTANT_COLOUR] * len(values) if same else cmap(norm(values))
    with plt.rc_context(_RC):
        fig = plt.figure(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
        try:
            ax = fig.add_axes([0.0, 0.0, 0.74, 0.88] if not same else [0.0, 0.1, 1.0, 0.78], projection="3d")
            coll = Poly3DCollection(_polygons(V, F), facecolors=colours, edgecolors=(0.1, 0.1, 0.1, 0.6),
                                    linewidths=0.3)
            ax.add_collection3d(coll)
            lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
            ext = np.maximum(hi - lo, 1e-9 * max(float(np.max(hi - lo)), 1.0))
            ax.set_xlim(lo[0], hi[0])
            ax.set_ylim(lo[1], hi[1])
            ax.set_zlim(lo[2], hi[2])
            ax.set_box_aspect(tuple(ext / ext.max()), zoom=1.25)
            ax.view_init(elev=camera[0], azim=camera[1])
            ax.set_axis_off()
            fig.suptitle(title, y=0.97)
            if same:
                fig.text(0.5, 0.04, f"{label}\n{same}", ha="center", va="bottom", fontsize=10.0,
                         bbox={"facecolor": "#f3f3f3", "edgecolor": "#bbbbbb", "boxstyle": "round"})
            else:
                cax = fig.add_axes([0.74, 0.1, 0.035, 0.7])
                sm = ScalarMappable(norm=norm, cmap=cmap)
                sm.set_array(values)
                cb = fig.colorbar(sm, cax=cax)
                cb.set_label(label)
                cb.ax.yaxis.get_offset_text().set_fontsize(MIN_FONT_PT)
            fig.savefig(path, dpi=_DPI, format="png")
        finally:
            plt.close(fig)
    return vmin, vmax


def _log_values(x, floor=1e-12):
    return np.log10(np.maximum(np.asarray(x, dtype=np.float64), floor))


#: the histogram panels: key, axis label, log10 scale
_HIST_PANELS = (("planarity", "log10 planarity", True), ("warping", "log10 warping height", True),
                ("area", "panel area", False))


def render_histograms(path, before: dict, after: dict | None, title: str, size=HIST_SIZE,
                      scales: dict | None = None) -> None:
    """Histograms of planarity, warping height (log10 scales) and area, before and after optimization.

    ``before`` / ``after`` map ``"planarity"``, ``"warping"``, ``"area"`` to per-face arrays. ``scales`` maps the
    same keys to the measure's scale (:func:`measure_scale`; default 1 for planarity, the largest value for the
    others): a stage whose values are constant up to round-off (:func:`constant_field`) is not binned (one clamped
    bar says nothing) but written in its panel as "candidate: all equal to …"; log10 scales start at 1e-12 of the
    scale.
    """
    plt = _pyplot()
    scales = dict(scales or {})
    with plt.rc_context(_RC):
        fig, axes = plt.subplots(1, 3, figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
        try:
            for ax, (key, xlabel, logscale) in zip(axes, _HIST_PANELS):
                stages = [("candidate", before[key], "#d95f02")]
                if after is not None:
                    stages.append(("optimized", after[key], "#1b9e77"))
                raw = np.concatenate([np.asarray(v, float).ravel() for _, v, _ in stages])
                scale = scales.get(key, 1.0 if key == "planarity" else float(np.max(np.abs(raw), initial=0.0)))
                floor = 1e-12 * scale if scale > 0 else 1e-300
                drawn, notes = [], []
                for stage, vals, colour in stages:
                    same = constant_field(vals, scale)
                    if same:
                        notes.append(f"{stage}:\n{same}")
                        continue
                    drawn.append((stage, _log_values(vals, floor) if logscale else np.asarray(vals, float), colour))
                if drawn:
                    allv = np.concatenate([d[1] for d in drawn])
                    lo, hi = float(allv.min()), float(allv.max())
                    if not hi > lo:
                        lo, hi = lo - 0.5, hi + 0.5
                    bins = np.linspace(lo, hi, 31)
                    for stage, vals, colour in drawn:
                        ax.hist(vals, bins=bins, histtype="stepfilled", alpha=0.45, color=colour, label=stage)
                    ax.legend(loc="upper right")
                    ax.set_ylabel("panels")
                else:
                    ax.set_yticks([])
                    ax.set_xticks([])
                if notes:
                    ax.text(0.5, 0.5 if not drawn else 0.97, "\n".join(notes), transform=ax.transAxes, ha="center",
                            va="center" if not drawn else "top", wrap=True, fontsize=MIN_FONT_PT,
                            bbox={"facecolor": "#f3f3f3", "edgecolor": "#bbbbbb", "boxstyle": "round"})
                ax.set_xlabel(xlabel)
            fig.suptitle(title + ("" if after is not None else " (no optimization step)"))
            fig.subplots_adjust(left=0.06, right=0.98, bottom=0.15, top=0.86, wspace=0.25)
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

    with plt.rc_context(_RC):
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
            ax.set_ylabel("panel area (model units²)\nmean ± std, line = min…max")
            ax.grid(True, alpha=0.3)
            handles = [Line2D([], [], color="k", marker=_MARKERS[i % len(_MARKERS)], linestyle="", label=s)
                       for i, s in enumerate(strategies)]
            handles += [Line2D([], [], color=_COLORS[i % len(_COLORS)], marker="s", linestyle="", label=s)
                        for i, s in enumerate(surfaces)]
            ax.legend(handles=handles, loc="center left", bbox_to_anchor=(1.01, 0.5))
            ax.set_title("Panel area against panel count, per strategy (marker) and surface (colour)")
            fig.subplots_adjust(left=0.09, right=0.8, bottom=0.12, top=0.9)
            fig.savefig(path, dpi=_DPI, format="png")
        finally:
            plt.close(fig)


#: pixel height of one box of :func:`render_area_boxes` (the labels' line height, so they never overlap)
BOX_ROW_PX = 26


def area_boxes_size(n: int, width: int = COMPARE_SIZE[0]) -> tuple[int, int]:
    """Pixel size of :func:`render_area_boxes` for ``n`` boxes: a row of :data:`BOX_ROW_PX` per box."""
    return (int(width), int(110 + BOX_ROW_PX * max(int(n), 1)))


def render_area_boxes(path, groups: list[tuple[str, np.ndarray]], title: str, size=None) -> None:
    """Box plots of panel areas, one horizontal box per (label, areas) group, top to bottom in the given order.

    Each label is one line (line breaks become " · ") beside its own box, and each box gets :data:`BOX_ROW_PX`
    pixels of height (``size`` default :func:`area_boxes_size`), so labels never overlap however many there are.
    """
    plt = _pyplot()
    size = size or area_boxes_size(len(groups))
    labels = [" · ".join(part.strip() for part in g[0].split("\n") if part.strip()) for g in groups]
    with plt.rc_context(_RC):
        fig, ax = plt.subplots(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
        try:
            pos = np.arange(len(groups), 0, -1)
            import matplotlib

            horizontal = ({"orientation": "horizontal"} if tuple(int(x) for x in matplotlib.__version__.split(".")[:2])
                          >= (3, 10) else {"vert": False})
            ax.boxplot([g[1] for g in groups], positions=pos, showmeans=True, widths=0.6, **horizontal)
            ax.set_yticks(pos, labels)
            ax.set_ylim(0.4, len(groups) + 0.6)
            ax.set_xlabel("panel area (model units²)")
            ax.grid(True, axis="x", alpha=0.3)
            ax.set_title(title)
            fig.canvas.draw()  # measure the labels: the plot starts right of the longest
            widest = max((t.get_window_extent().width for t in ax.get_yticklabels()), default=0.0)
            left = min((widest + 16) / size[0], 0.6)
            fig.subplots_adjust(left=left, right=0.98, bottom=70 / size[1], top=1 - 40 / size[1])
            fig.savefig(path, dpi=_DPI, format="png")
        finally:
            plt.close(fig)


def render_planarity_bars(path, rows: list[dict], strategies: list[str], surfaces: list[str],
                          size=COMPARE_SIZE) -> None:
    """Max planarity before (hatched) and after optimization, per strategy and surface (log scale; a round-off
    planarity below 1e-12 is drawn at 1e-12)."""
    plt = _pyplot()
    from matplotlib.patches import Patch

    with plt.rc_context(_RC):
        fig, ax = plt.subplots(figsize=(size[0] / _DPI, size[1] / _DPI), dpi=_DPI)
        try:
            width = 0.8 / max(len(strategies), 1)
            for r in rows:
                si, ti = surfaces.index(r["surface"]), strategies.index(r["strategy"])
                x = si + (ti - (len(strategies) - 1) / 2) * width
                b = max(r["metrics_before"]["planarity_max"], 1e-12)
                c = _COLORS[ti % len(_COLORS)]
                ax.bar(x, b, width=width * 0.9, color="none", edgecolor=c, hatch="//")
                if r["metrics_after"] is not None:
                    ax.bar(x, max(r["metrics_after"]["planarity_max"], 1e-12), width=width * 0.9, color=c,
                           alpha=0.8)
            ax.set_yscale("log")
            ax.set_ylim(bottom=1e-12)
            ax.set_xticks(range(len(surfaces)), surfaces, rotation=30 if len(surfaces) > 6 else 0,
                          ha="right" if len(surfaces) > 6 else "center")
            ax.set_ylabel("max planarity (scale-free)")
            handles = [Patch(color=_COLORS[i % len(_COLORS)], label=s) for i, s in enumerate(strategies)]
            handles.append(Patch(facecolor="none", edgecolor="k", hatch="//", label="candidate (before)"))
            ax.legend(handles=handles, loc="center left", bbox_to_anchor=(1.01, 0.5))
            ax.set_title("Max planarity of the candidate (hatched) and of the optimized mesh (filled)")
            ax.grid(True, axis="y", alpha=0.3)
            fig.subplots_adjust(left=0.08, right=0.8, bottom=0.18 if len(surfaces) > 6 else 0.1, top=0.9)
            fig.savefig(path, dpi=_DPI, format="png")
        finally:
            plt.close(fig)


# ----------------------------------------------------------------------------------------------
# HTML


_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0 auto;max-width:1600px;
padding:.5em 1em 3em;color:#222;background:#fff;line-height:1.4}
h1{margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}
h3{margin-top:1.8em;border-bottom:1px solid #eee}h2 a.up,h3 a.up{font-size:.6em;font-weight:normal;margin-left:.8em}
table{border-collapse:collapse;margin:.6em 0;font-size:.85em}
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right;vertical-align:top}
th{background:#f3f3f3}td.l,th.l{text-align:left}
tr.na td{color:#888;font-style:italic}tr.failed td{color:#a00}tr.unhealthy td.status{color:#a00}
tr.tolerance td.status{color:#8a5a00}td.status{min-width:12em;max-width:26em}td.warnings{min-width:5em;max-width:36em;font-size:.9em}
.bad{color:#a00}.s-ok{color:#1b7a3a}.s-unhealthy,.s-failed{color:#a00}.s-tolerance{color:#8a5a00}
.grid{display:flex;flex-wrap:wrap;gap:12px;margin:.6em 0}
figure{margin:.6em 0;max-width:100%}figure img{max-width:100%;height:auto;border:1px solid #eee;display:block}
.grid figure{margin:0;flex:0 1 400px;min-width:0}
.scroll{overflow-x:auto;max-width:100%}
figcaption{font-size:.85em;color:#555}
.note{color:#555;font-size:.9em}.warn{color:#8a5a00;font-size:.9em;margin:.2em 0}
details{margin:.4em 0}summary{cursor:pointer}
code{background:#f5f5f5;padding:0 .2em}
nav.toc{background:#fafafa;border:1px solid #e4e4e4;padding:.2em 1em .6em;margin:1em 0}
nav.toc h2{margin-top:.4em;border:0}nav.toc ol{margin:.2em 0;padding-left:1.4em}
nav.toc>ol{columns:2 22em;column-gap:2em}nav.toc>ol>li{break-inside:avoid;margin-bottom:.3em}
nav.toc li{font-size:.95em}
a.totop{position:fixed;right:1em;bottom:1em;background:#fff;border:1px solid #ccc;border-radius:4px;
padding:.3em .6em;font-size:.9em;text-decoration:none;box-shadow:0 1px 4px rgba(0,0,0,.15)}
.viewer3d{border:1px solid #ddd;border-radius:4px;margin:.8em 0;background:#fcfcfc}
.v-bar{display:flex;flex-wrap:wrap;gap:.4em 1.2em;align-items:center;padding:.4em .6em;border-bottom:1px solid #eee;
font-size:.95em}
.v-canvas{position:relative;height:520px;width:100%;overflow:hidden;background:#f4f4f4}
.v-canvas canvas{display:block;width:100%;height:100%;touch-action:none}
.v-canvas .v-start{position:absolute;inset:0;width:100%;height:100%;border:0;background:#f4f4f4;color:#444;
font-size:1em;cursor:pointer}
.v-canvas .v-start img{position:absolute;inset:0;width:100%;height:100%;object-fit:contain;opacity:.45}
.v-canvas .v-start span{position:relative;background:#fff;padding:.3em .7em;border-radius:4px;border:1px solid #ccc}
.v-legend{display:flex;flex-wrap:wrap;align-items:center;gap:.5em;padding:.4em .6em;font-size:.95em;min-height:1.6em}
.v-ramp{display:inline-block;width:260px;height:14px;border:1px solid #999;
background:linear-gradient(to right,#440154,#48186a,#472d7b,#424086,#3b528b,#33638d,#2c728e,#26828e,#21918c,#1fa088,
#28ae80,#3fbc73,#5ec962,#84d44b,#addc30,#d8e219,#fde725)}
.v-swatch{display:inline-block;width:28px;height:14px;border:1px solid #999;background:#21918c}
.v-help{color:#555;font-size:.85em;margin-left:auto}
"""


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _fmt(x, digits: int = 3) -> str:
    return _e(x) if isinstance(x, str) else format_number(x, digits)


def format_number(x, digits: int = 3) -> str:
    """A number for a table cell or a tooltip: "–" for none, integers with separators, else ``digits`` significant
    digits (the report's and the study report's cells)."""
    if x is None:
        return "–"
    x = float(x)
    if not math.isfinite(x):
        return str(x)
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
    out = ['<div class="scroll"><table><thead><tr><th class="l">surface</th><th class="l">strategy</th>'
           f'<th class="l">status</th>{head}<th>time (s)</th></tr></thead><tbody>']
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
        out.append(f'<tr{cls}><td class="l">{_e(r["surface"])}</td><td class="l">'
                   f'<a href="#{_anchor(r["surface"], r["strategy"])}">{_e(r["strategy"])}</a></td>'
                   f'<td class="l status">{_e(status_text(r))}</td>{"".join(cells)}<td>{_fmt(total)}</td></tr>')
    out.append("</tbody></table></div>")
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


def _anchor(surface: str, strategy: str) -> str:
    """The id of a result's section (``r-<surface>_<strategy>``)."""
    return "r-" + _slug(surface, strategy)


def _up() -> str:
    return '<a class="up" href="#contents">↑ contents</a>'


def _toc(report: dict, titles: dict) -> str:
    rows = report["results"]
    out = ['<nav id="contents" class="toc" aria-label="contents"><h2>Contents</h2><ol>',
           '<li><a href="#strategies">Strategies</a></li>',
           f'<li><a href="#summary">Summary</a> ({len(rows)} results: '
           + ", ".join(f"{sum(r['status'] == s for r in rows)} {_e(s)}"
                       for s in ("ok", "tolerance missed", "unhealthy", "failed")
                       if any(r["status"] == s for r in rows))
           + ")</li>"]
    if report["comparisons"]:
        out.append('<li><a href="#comparisons">Comparison plots</a></li>')
    for surf in report["surfaces"]:
        sname = surf["name"]
        out.append(f'<li><a href="#surface-{_e(sname)}">Surface: {_e(sname)}</a><ol>')
        for r in (r for r in rows if r["surface"] == sname):
            cls = "s-" + (_STATUS_CLASS[r["status"]] or "ok")
            out.append(f'<li><a href="#{_anchor(sname, r["strategy"])}">{_e(titles[r["strategy"]][0])}</a> '
                       f'<span class="{cls}">{_e(r["status"])}</span></li>')
        out.append("</ol></li>")
    out.append("</ol></nav>")
    return "".join(out)


def _viewer_html(r: dict) -> str:
    """The 3D view's block: controls, a canvas area (filled by ``viewer/viewer.js`` when scrolled into view or
    clicked) and the colour legend; or the note why there is none."""
    view = r.get("view")
    if not view:
        return ""
    if "note" in view:
        return f'<p class="note">3D view: {_e(view["note"])}</p>'
    vid = view["id"]
    stages = view["stages"]
    options = "".join(f'<option value="{_e(m)}"{" selected" if m == "planarity" else ""}>{_e(VIEW_MEASURES[m][0])}'
                      "</option>" for m in view["measures"])
    radios = ""
    if len(stages) > 1:
        radios = '<span class="v-stages" role="radiogroup" aria-label="stage">' + "".join(
            f'<label><input type="radio" name="stage-{_e(vid)}" value="{_e(s)}"{" checked" if s == stages[-1] else ""}>'
            f" {_e(s)}</label> " for s in stages) + "</span>"
    else:
        radios = f'<span class="v-stages">{_e(stages[0])} (no optimization step)</span>'
    return (f'<div class="viewer3d" id="view-{_e(vid)}" data-view="{_e(vid)}" data-src="{_e(view["file"])}" '
            f'data-stage="{_e(stages[-1])}">'
            f'<div class="v-bar"><label>colour by <select class="v-metric">{options}</select></label>{radios}'
            '<label><input type="checkbox" class="v-edges" checked> panel edges</label>'
            '<button type="button" class="v-reset">reset view</button>'
            f'<span class="v-help">{view["faces"]:,} panels · drag: orbit · wheel: zoom · right-drag: pan'
            "</span></div>"
            '<div class="v-canvas"><button type="button" class="v-start"><span>3D view: starts when scrolled into '
            'view (click to start now)</span></button></div>'
            '<div class="v-legend" aria-live="polite"></div>'
            "</div>")


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
        '<body id="top">',
        "<h1>Planar-quad meshing strategies: comparison report</h1>",
        f'<p class="note">Generated {_e(report["generated"])} in {report["elapsed"]:.1f} s; mode '
        f'<code>{_e(s["mode"])}</code>, sample resolution {s["resolution"]}, {s["divisions"]} panels across the '
        f'larger extent, optimization budget {s["time_budget"]:g} s per run. The same numbers: '
        '<a href="report.csv">report.csv</a>, <a href="report.json">report.json</a>; meshes in '
        "<code>meshes/</code>" + (f' and <a href="{_e(report["model_file"])}">{_e(report["model_file"])}</a>'
                                   if report.get("model_file") else "") + ".</p>",
        _toc(report, titles),
        f'<h2 id="strategies">Strategies {_up()}</h2><ul>',
    ]
    for name, (title, desc) in titles.items():
        parts.append(f"<li><b>{_e(title)}</b> (<code>{_e(name)}</code>): {_e(desc)}</li>")
    parts.append("</ul>")
    parts.append('<p class="note">Planarity is scale-free (distance between the diagonals / mean diagonal); '
                 "warping height and closeness (distance to the design surface) are in model units. Pictures are "
                 "coloured per face; every colour bar runs from the smallest to the largest plotted value, and a "
                 "field that is one number up to round-off (its spread at most 1e-9 of its scale) is drawn in one "
                 "colour and labelled \"all equal to …\". Every result has an interactive 3D view (orbit, zoom, "
                 "colour by metric, candidate / optimized) that works offline from this folder.</p>")
    parts.append(f'<h2 id="summary">Summary {_up()}</h2>')
    parts.append('<p class="note">Status: "ok" only for a result within the planarity tolerance whose panels are '
                 'healthy; otherwise the status names the defect. The warnings column folds the strategy\'s '
                 "warnings and the panel-health violations under their count.</p>")
    parts.append(_summary_table(rows))
    if report["comparisons"]:
        parts.append(f'<h2 id="comparisons">Comparison plots {_up()}</h2>')
    for img in report["comparisons"]:
        parts.append(f'<figure>{_img(img["file"], img["title"], img["size"])}'
                     f'<figcaption>{_e(img["title"])}</figcaption></figure>')
    for surf in report["surfaces"]:
        sname = surf["name"]
        parts.append(f'<h2 id="surface-{_e(sname)}">Surface: {_e(sname)} {_up()}</h2>')
        parts.append(f'<p class="note">{_e(surf["description"])}; design mesh {surf["vertices"]:,} vertices, '
                     f'{surf["triangles"]:,} triangles; panel size {surf["panel_size"]:.3g}.</p>')
        for r in (r for r in rows if r["surface"] == sname):
            title = titles[r["strategy"]][0]
            cls = "s-" + (_STATUS_CLASS[r["status"]] or "ok")
            parts.append(f'<h3 id="{_anchor(sname, r["strategy"])}">{_e(title)} on {_e(sname)}: '
                         f'<span class="{cls}">{_e(r["status"])}</span> {_up()}</h3>')
            if not r["images"]:  # failed: no mesh to show
                parts.append(f'<p class="bad">{_e(status_text(r))}</p>')
                continue
            if r["status"] != "ok":
                parts.append(f'<p class="bad">{_e(status_text(r))}</p>')
            parts.append(f'<p class="note">{_e(r["description"])}</p>')
            for w in list(r["warnings"]) + [f"panel health: {v}" for v in r["violations"]]:
                parts.append(f'<p class="warn">⚠ {_e(w)}</p>')
            parts.append(_viewer_html(r))
            stages = [st for st in ("candidate", "optimized") if st in r["meshes"]]
            for stage in stages:
                parts.append('<div class="grid">')
                for img in r["images"]:
                    if img["kind"] != "mesh" or img["stage"] != stage:
                        continue
                    cap = img.get("constant") or f'{_fmt(img["vmin"])} … {_fmt(img["vmax"])}'
                    cap = f'{stage}, {MEASURES[img["measure"]][0]}: {cap}'
                    parts.append(f'<figure>{_img(img["file"], cap, img["size"])}<figcaption>{_e(cap)}</figcaption>'
                                 "</figure>")
                parts.append("</div>")
            for img in r["images"]:
                if img["kind"] == "histogram":
                    parts.append(f'<figure>{_img(img["file"], img["title"], img["size"])}'
                                 f'<figcaption>{_e(img["title"])}</figcaption></figure>')
            parts.append(_fabrication_html(r.get("fabrication")))
            files = " ".join(f'<a href="{_e(f)}">{_e(Path(f).name)}</a>' for f in r["meshes"].values())
            parts.append(f'<details><summary>All metrics and timings ({_e(r["strategy"])}, {_e(sname)})</summary>'
                         f'{_metrics_table(r)}<p class="note">Meshes: {files}</p></details>')
    parts.append('<a class="totop" href="#contents">↑ contents</a>')
    if any((r.get("view") or {}).get("file") for r in rows):
        parts.append(f'<script src="{VIEWER_DIR}/viewer.js" data-three="{VIEWER_DIR}/three.js"></script>')
    parts.append("</body>")
    parts.append("</html>")
    return "\n".join(parts) + "\n"


# ----------------------------------------------------------------------------------------------
# the interactive 3D views (three.js, offline from the report folder)


#: the per-face fields a 3D view can be coloured by: key -> (title, unit)
VIEW_MEASURES = {**MEASURES, "warping": ("warping height", "distance between the diagonals, model units")}

#: a mesh of more faces than this gets no 3D view (a note says so; its pictures and OBJ stay)
VIEW_FACE_CAP = 200_000

#: the report's sub-folder of the 3D views: viewer.js, three.js (the joined three.js modules), data/<id>.js
VIEWER_DIR = "viewer"

STATIC_DIR = Path(__file__).resolve().parent / "static"

#: the three.js ES modules joined into ``viewer/three.js``: file, {import specifier: module file}
THREE_MODULES = (("three.core.js", {}), ("three.module.js", {"./three.core.js": "three.core.js"}),
                 ("OrbitControls.js", {"three": "three.module.js"}))

_STATEMENT = re.compile(r"^(import|export)[ \t]*\{([^}]*)\}[ \t]*(?:from[ \t]*(['\"])([^'\"]+)\3)?[ \t]*;[ \t]*$",
                        re.M)
_OTHER_STATEMENT = re.compile(r"^[ \t]*(?:import|export)\b(?![ \t]*\()", re.M)


def _export_names(text: str, module: str) -> list[tuple[str, str]]:
    out = []
    for part in text.split(","):
        bits = part.split()
        if len(bits) == 1:
            out.append((bits[0], bits[0]))
        elif len(bits) == 3 and bits[1] == "as":
            out.append((bits[0], bits[2]))
        elif bits:
            raise ValueError(f"{module}: cannot read the import/export clause {part.strip()!r}")
    return out


def classic_module(name: str, source: str, specifiers: dict) -> str:
    """One ES module as a classic-script function registering its exports in the table ``__m[name]``.

    Only the shape rollup writes is accepted: ``import { a, b as c } from 'x';`` and ``export { a, b as c }
    [from 'x'];`` statements on their own lines, every ``from`` a key of ``specifiers`` (mapped to the module file
    already in the table). Anything else (``export default``, ``export const``, side-effect imports) raises
    ValueError, so a changed three.js fails when the report is written, not in the browser.

    >>> print(classic_module("b.js", "import { x as y } from './a.js';\\nconst z = y + 1;\\nexport { z, y as w };",
    ...                      {"./a.js": "a.js"}).strip())
    (function (__m) {
    "use strict";
    const __e = {};
    const { x: y } = __m["a.js"];
    const z = y + 1;
    Object.assign(__e, { z: z, w: y });
    __m["b.js"] = __e;
    })(__m);
    """
    def statement(m):
        kind, names, spec = m.group(1), _export_names(m.group(2), name), m.group(4)
        table = None
        if spec is not None:
            if spec not in specifiers:
                raise ValueError(f"{name}: unexpected import of {spec!r}")
            table = f"__m[{json.dumps(specifiers[spec])}]"
        if kind == "import":
            if table is None:
                raise ValueError(f"{name}: an import without 'from'")
            return "const { " + ", ".join(a if a == b else f"{a}: {b}" for a, b in names) + f" }} = {table};"
        return "Object.assign(__e, { " + ", ".join(f"{b}: {a if table is None else f'{table}.{a}'}"
                                                  for a, b in names) + " });"

    body = _STATEMENT.sub(statement, source)
    left = _OTHER_STATEMENT.findall(body)
    if left:
        raise ValueError(f"{name}: {len(left)} import/export statement(s) of a shape the report cannot join")
    return (f'(function (__m) {{\n"use strict";\nconst __e = {{}};\n{body}\n__m[{json.dumps(name)}] = __e;\n'
            "})(__m);\n")


_BUNDLE: list[str] = []  # the joined three.js, built once per process


def viewer_bundle() -> str:
    """The three.js modules of ``ghserver/static/three`` joined into one classic script that sets
    ``window.PQ_THREE`` (three.js's exports and ``OrbitControls``).

    A classic script loads from a ``file://`` page (where Chromium refuses ES modules: CORS) and from a server
    that labels ``.js`` as anything (ES modules need a JavaScript MIME type), so the report opens from disk and
    under ``ghserver serve`` alike.
    """
    if not _BUNDLE:
        head = ("/* three.js r{rev} (MIT licence: three-LICENSE.txt) joined from its ES modules by ghserver.report "
                "(viewer_bundle) */\n")
        rev = re.search(r"const REVISION = '(\d+)'", (STATIC_DIR / "three" / "three.core.js").read_text("utf-8"))
        parts = [head.format(rev=rev.group(1) if rev else "?"), "(function () {\nconst __m = {};\n"]
        for name, specs in THREE_MODULES:
            parts.append(classic_module(name, (STATIC_DIR / "three" / name).read_text(encoding="utf-8"), specs))
        parts.append('window.PQ_THREE = Object.assign({}, __m["three.module.js"], '
                     '{ OrbitControls: __m["OrbitControls.js"].OrbitControls });\n})();\n')
        _BUNDLE.append("".join(parts))
    return _BUNDLE[0]


def write_viewer_assets(out) -> list[Path]:
    """Write ``viewer/viewer.js``, ``viewer/three.js`` (:func:`viewer_bundle`) and three.js's licence into the
    report folder ``out``; returns the paths."""
    d = Path(out) / VIEWER_DIR
    (d / "data").mkdir(parents=True, exist_ok=True)
    files = {"viewer.js": (STATIC_DIR / "viewer.js").read_text(encoding="utf-8"), "three.js": viewer_bundle(),
             "three-LICENSE.txt": (STATIC_DIR / "three" / "LICENSE").read_text(encoding="utf-8")}
    paths = []
    for name, text in files.items():
        (d / name).write_text(text, encoding="utf-8")
        paths.append(d / name)
    return paths


def _b64(a, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()).decode()


def view_data(stages, fields: dict, box, camera=DEFAULT_CAMERA, length: float | None = None,
              title: str = "") -> dict:
    """The data of one 3D view (what ``viewer/viewer.js`` draws), JSON-ready.

    Parameters
    ----------
    stages : list of (stage, V, F)
        The meshes to switch between (``"candidate"``, ``"optimized"``).
    fields : dict
        ``fields[stage][measure]``: per-face values for every key of :data:`VIEW_MEASURES`.
    box : (lo, hi)
        Scene bounds; the coordinates are stored as float32 relative to the box centre (site coordinates of 5e6
        keep their millimetres) and the camera frames the box.
    camera : (elevation, azimuth)
        The first view, in degrees (as the pictures).
    length : float, optional
        The length the measures' round-off is judged against (default the box diagonal); see
        :func:`constant_field`.

    Returns
    -------
    dict
        ``title``, ``camera``, ``radius`` (half the box diagonal), ``half`` (the box's half extents), ``centre``,
        ``stages`` (per stage ``V`` base64 float32 x,y,z; ``F``
        base64 uint32 of the padded faces, ``k`` their width and ``sizes`` base64 uint16, or ``same_faces`` naming
        the stage whose faces it shares) and ``metrics`` (per measure ``title``, ``unit`` and per stage
        ``values`` base64 float32, ``lo``/``hi`` as printed and ``constant``: "all equal to …" or None).
    """
    from components.core.mesh import face_sizes

    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    centre = (lo + hi) / 2
    diag = float(np.linalg.norm(hi - lo))
    length = diag if length is None else float(length)
    out = {"title": title, "camera": [float(camera[0]), float(camera[1])], "radius": diag / 2,
           "half": ((hi - lo) / 2).tolist(), "centre": centre.tolist(), "stages": {}, "metrics": {}}
    seen = []
    for stage, V, F in stages:
        F = np.asarray(F)
        st = {"faces": int(len(F)), "vertices": int(len(V)), "V": _b64(np.asarray(V, float) - centre, np.float32)}
        same = next((s for s, Fs in seen if Fs.shape == F.shape and np.array_equal(Fs, F)), None)
        if same is not None:
            st["same_faces"] = same
        else:
            st.update({"F": _b64(F, np.uint32), "k": int(F.shape[1]), "sizes": _b64(face_sizes(F), np.uint16)})
            seen.append((stage, F))
        out["stages"][stage] = st
    for measure, (mtitle, unit) in VIEW_MEASURES.items():
        per = {}
        for stage, _, _ in stages:
            v = np.asarray(fields[stage][measure], dtype=np.float64)
            per[stage] = {"values": _b64(v, np.float32), "lo": _fmt(float(v.min())), "hi": _fmt(float(v.max())),
                          "constant": constant_field(v, measure_scale(measure, length))}
        out["metrics"][measure] = {"title": mtitle, "unit": unit, "stages": per}
    return out


def write_view(path, view_id: str, data: dict) -> None:
    """Write a view's data as a classic script (``PQViewer.add(id, {...});``): a page opened from ``file://``
    cannot fetch() a JSON file beside it, but it can load a script."""
    Path(path).write_text(f"PQViewer.add({json.dumps(view_id)}, {json.dumps(_finite_json(data))});\n",
                          encoding="utf-8")


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
    for sub, pattern in (("img", "*.png"), ("meshes", "*.obj"), (f"{VIEWER_DIR}/data", "*.js")):
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
    from components.metrics.quality import warping_height

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
                length = float(np.linalg.norm(np.ptp(surf.V, axis=0)))  # round-off is judged against it
                for stage, (Vm, Fm) in stages:
                    mesh_file = f"meshes/{_slug(surf.name, sname, stage)}.obj"
                    write_obj(out / mesh_file, Vm, Fm)
                    model_meshes.append((sname, f"{surf.name} {stage}", Vm, Fm))
                    row["meshes"][stage] = mesh_file
                    per_stage[stage] = {"warping": warping_height(Vm, Fm)}
                    for measure, (mtitle, unit) in MEASURES.items():
                        vals = face_values(Vm, Fm, measure, (surf.V, surf.T))
                        per_stage[stage][measure] = vals
                        fname = f"img/{_slug(surf.name, sname, stage, measure)}.png"
                        title = f"{sname} on {surf.name}: {stage}\n{mtitle} · {len(Fm):,} panels"
                        scale = measure_scale(measure, length)
                        vmin, vmax = render_mesh(out / fname, Vm, Fm, vals, title,
                                                 f"{mtitle} ({_SHORT_UNITS[measure]})", box, surf.camera,
                                                 scale=scale)
                        n_images += 1
                        row["images"].append({"kind": "mesh", "file": fname, "stage": stage, "measure": measure,
                                              "vmin": vmin, "vmax": vmax, "constant": constant_field(vals, scale),
                                              "faces": int(len(Fm)), "vertices": int(len(Vm)),
                                              "size": list(IMAGE_SIZE), "min_font_px": MIN_FONT_PX})
                        bar.step(f"{surf.name}: {sname} {stage} {measure}")
                row["fabrication"] = fabrication_summary(*stages[-1][1][:2])
                fname = f"img/{_slug(surf.name, sname, 'histograms')}.png"
                htitle = f"{titles[sname][0]} on {surf.name}: candidate vs optimized"
                render_histograms(out / fname, per_stage["candidate"], per_stage.get("optimized"), htitle,
                                  scales={k: measure_scale(k, length) for k in ("planarity", "warping", "area")})
                n_images += 1
                row["images"].append({"kind": "histogram", "file": fname, "title": htitle, "size": list(HIST_SIZE),
                                      "min_font_px": MIN_FONT_PX})
                # the interactive 3D view: the same meshes and per-face fields, loaded by viewer/viewer.js
                vid = _slug(surf.name, sname)
                faces = max(len(m[1]) for _, m in stages)
                if faces > VIEW_FACE_CAP:
                    row["view"] = {"note": f"none: {faces:,} panels are over the {VIEW_FACE_CAP:,}-panel limit of "
                                           "a 3D view (the pictures and the OBJ files have them all)"}
                else:
                    vfile = f"{VIEWER_DIR}/data/{vid}.js"
                    data = view_data([(stage, *m) for stage, m in stages], per_stage, box, surf.camera, length,
                                     f"{titles[sname][0]} on {surf.name}")
                    write_view(out / vfile, vid, data)
                    row["view"] = {"id": vid, "file": vfile, "stages": [stage for stage, _ in stages],
                                   "measures": list(VIEW_MEASURES), "faces": int(faces)}
                bar.step(f"{surf.name}: {sname} histograms", n=8 - 1 - 3 * len(stages))
        # comparison plots over every measured run (unhealthy ones included: their panels are the point)
        ok = [r for r in rows if r["final_metrics"] is not None]
        if any("file" in (r.get("view") or {}) for r in rows):
            write_viewer_assets(out)
        comparisons = []
        surf_names = [s.name for s in surfs]
        if ok:
            f = "img/compare_area_vs_count.png"
            render_area_vs_count(out / f, ok, strat_names, surf_names)
            comparisons.append({"kind": "comparison", "file": f, "size": list(COMPARE_SIZE),
                                "title": "Panel area against panel count per strategy and surface",
                                "min_font_px": MIN_FONT_PX})
            f = "img/compare_planarity.png"
            render_planarity_bars(out / f, ok, strat_names, surf_names)
            comparisons.append({"kind": "comparison", "file": f, "size": list(COMPARE_SIZE),
                                "title": "Max planarity before and after optimization per strategy and surface",
                                "min_font_px": MIN_FONT_PX})
            groups = []
            for r in ok:
                mesh_file = r["meshes"].get("optimized") or r["meshes"]["candidate"]
                stage = "optimized" if "optimized" in r["meshes"] else "candidate"
                areas = _areas_of(out / mesh_file)
                groups.append((f"{r['surface']} · {r['strategy']} ({stage})", areas))
            f = "img/compare_area_boxes.png"
            render_area_boxes(out / f, groups, "Panel area distribution of the final mesh per surface and strategy")
            comparisons.append({"kind": "comparison", "file": f, "size": list(area_boxes_size(len(groups))),
                                "title": "Panel area distribution (box: quartiles, line: median, triangle: mean)",
                                "min_font_px": MIN_FONT_PX})
            n_images += len(comparisons)
        bar.step("comparison plots", n=3)
        if model_meshes:
            from ghserver.convert import write_meshes_3dm

            units = {s.units for s in surfs}  # one file: in the meshes' units when they all have the same ones
            write_meshes_3dm(out / "results.3dm", model_meshes, units=units.pop() if len(units) == 1 else None)
        elapsed = time.perf_counter() - t0
        report = {
            "generated": _dt.datetime.now().isoformat(timespec="seconds"),
            "elapsed": elapsed,
            "settings": {"mode": mode, **settings._asdict(), "image_size": list(IMAGE_SIZE)},
            "strategies": [{"name": n, "title": titles[n][0], "description": titles[n][1]} for n in strat_names],
            "surfaces": surf_info,
            "results": [{k: v for k, v in r.items() if k not in ("final_metrics", "final_health")} for r in rows],
            "comparisons": comparisons,
            "model_file": "results.3dm" if model_meshes else None,
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

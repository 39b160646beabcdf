"""The study report: ``study.csv``, ``study.json`` and ``study.html`` of a :class:`ghserver.study.StudyTable`.

``study.html`` is one self-contained page (inline CSS and inline SVG charts: no scripts, no images, no fonts, no
network), styled like the comparison report (:mod:`ghserver.report`): the study's settings, rows per status, four
charts of the panel count against max planarity, max closeness, coverage (panel health) and panel types — a
marker per surface, a colour per strategy, filled when the status is "ok", hollow otherwise, a tooltip per point —
and the table, one row per variant. The charts are drawn as SVG text (no matplotlib), so that a study rerun from
the cache writes its report in milliseconds.
"""
from __future__ import annotations

import csv
import datetime as _dt
import html
import json
import math
from pathlib import Path

from ghserver.report import format_number, status_text

__all__ = ["write_report", "scatter_svg", "CHARTS"]

#: colours per strategy (the comparison report's palette), markers per surface
COLORS = ("#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e", "#e6ab02", "#a6761d", "#666666")
MARKERS = ("circle", "square", "triangle", "diamond", "down", "plus", "cross", "star")

#: the charts: (column on the y axis, title, axis label, log scale)
CHARTS = (
    ("planarity_max", "Max planarity against panel count", "max planarity (scale-free)", True),
    ("closeness_max", "Max closeness to the design surface against panel count", "max closeness (model units)",
     True),
    ("coverage", "Panel health: coverage of the design surface against panel count", "coverage (share covered)",
     False),
    ("panel_types", "Panel types against panel count", "panel types (1e-3 × median edge)", False),
)

# the comparison report's look (ghserver/report.py), for the elements this page uses
_CSS = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,Helvetica,Arial,sans-serif;margin:0 auto;max-width:1600px;
padding:1em 2em;color:#222;background:#fff;line-height:1.4}
h1{margin-bottom:.2em}h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}
table{border-collapse:collapse;margin:.6em 0;font-size:.85em}
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right;vertical-align:top}
th{background:#f3f3f3;position:sticky;top:0}td.l,th.l{text-align:left}
tr.failed td,tr.notrun td{color:#a00}tr.unhealthy td.status{color:#a00}tr.tolerance td.status{color:#8a5a00}
td.status{min-width:10em;max-width:26em}td.notes{max-width:30em;font-size:.9em}
.grid{display:flex;flex-wrap:wrap;gap:.8em}
figure{margin:0;flex:0 1 600px}figure svg{width:100%;height:auto;border:1px solid #eee}
figcaption{font-size:.8em;color:#555}
.note{color:#555;font-size:.9em}
details{margin:.4em 0}summary{cursor:pointer}
code{background:#f5f5f5;padding:0 .2em}
"""

_STATUS_CLASS = {"ok": "", "unhealthy": "unhealthy", "tolerance missed": "tolerance", "failed": "failed",
                 "not run": "notrun"}


def _e(x) -> str:
    return html.escape(str(x), quote=True)


def _num(x, digits: int = 3) -> str:
    """:func:`ghserver.report.format_number`, with yes/no for flags."""
    if isinstance(x, bool):
        return "yes" if x else "no"
    return format_number(x, digits)


# ----------------------------------------------------------------------------------------------
# SVG scatter plots


def _tick(t: float, log: bool) -> str:
    return f"{t:g}" if log else _num(t, 3)


def _ticks(lo: float, hi: float, log: bool) -> list[float]:
    if log:
        a, b = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
        ticks = [10.0 ** k for k in range(a, b + 1)]
        if b - a <= 3:
            ticks = sorted(m * t for t in ticks for m in (1, 2, 5))
        return [t for t in ticks if lo * (1 - 1e-9) <= t <= hi * (1 + 1e-9)] or [lo, hi]
    span = hi - lo
    step = 10.0 ** math.floor(math.log10(span / 5))
    for m in (1, 2, 5, 10):
        if span / (m * step) <= 6:
            step *= m
            break
    first = math.ceil(lo / step - 1e-9) * step
    return [first + i * step for i in range(int((hi - first) / step + 1e-9) + 1)]


def _marker(kind: str, x: float, y: float, r: float, color: str, filled: bool, tip: str) -> str:
    fill = color if filled else "#fff"
    style = f'fill="{fill}" stroke="{color}" stroke-width="1.5"'
    tip = f"<title>{_e(tip)}</title>"
    if kind == "circle":
        return f'<circle cx="{x:.1f}" cy="{y:.1f}" r="{r:.1f}" {style}>{tip}</circle>'
    if kind == "square":
        return f'<rect x="{x - r:.1f}" y="{y - r:.1f}" width="{2 * r:.1f}" height="{2 * r:.1f}" {style}>{tip}</rect>'
    shapes = {"triangle": ((0, -1.2), (1.1, 0.8), (-1.1, 0.8)), "down": ((0, 1.2), (1.1, -0.8), (-1.1, -0.8)),
              "diamond": ((0, -1.3), (1.2, 0), (0, 1.3), (-1.2, 0)),
              "plus": ((-.4, -1.2), (.4, -1.2), (.4, -.4), (1.2, -.4), (1.2, .4), (.4, .4), (.4, 1.2), (-.4, 1.2),
                       (-.4, .4), (-1.2, .4), (-1.2, -.4), (-.4, -.4)),
              "cross": ((-1, -1.2), (0, -.3), (1, -1.2), (1.2, -1), (.3, 0), (1.2, 1), (1, 1.2), (0, .3), (-1, 1.2),
                        (-1.2, 1), (-.3, 0), (-1.2, -1)),
              "star": tuple((1.3 * math.sin(k * math.pi / 5) * (1 if k % 2 == 0 else 0.45),
                             -1.3 * math.cos(k * math.pi / 5) * (1 if k % 2 == 0 else 0.45)) for k in range(10))}
    pts = " ".join(f"{x + r * dx:.1f},{y + r * dy:.1f}" for dx, dy in shapes[kind])
    return f'<polygon points="{pts}" {style}>{tip}</polygon>'


def scatter_svg(points: list[dict], title: str, xlabel: str, ylabel: str, ylog: bool = False,
                legend: list[tuple[str, str, str, bool]] = (), size=(600, 400)) -> str:
    """An inline SVG scatter plot.

    ``points``: dicts with ``x``, ``y``, ``color``, ``marker`` (one of :data:`MARKERS`), ``filled`` and ``tip``
    (the tooltip). The x axis (panel count) is logarithmic when it spans more than a factor of 10; ``ylog`` makes
    the y axis logarithmic (non-positive values are then left out, and said so). ``legend``: (label, color,
    marker, filled) entries drawn on the right.
    """
    W, H = size
    left, right, top, bottom = 70, 150, 30, 48
    pw, ph = W - left - right, H - top - bottom
    dropped = 0
    if ylog:
        kept = [p for p in points if p["y"] > 0]
        dropped = len(points) - len(kept)
        points = kept
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {W} {H}" width="{W}" height="{H}" role="img" '
           f'aria-label="{_e(title)}" font-family="system-ui,Helvetica,Arial,sans-serif" font-size="11">',
           f'<text x="{left + pw / 2:.0f}" y="18" text-anchor="middle" font-size="13">{_e(title)}</text>',
           f'<rect x="{left}" y="{top}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>']
    if points:
        xs = [float(p["x"]) for p in points]
        ys = [float(p["y"]) for p in points]
        xlo, xhi = min(xs), max(xs)
        xlog = xlo > 0 and xhi / xlo > 10
        ylo, yhi = min(ys), max(ys)

        def pad(lo, hi, log):
            if log:
                lo, hi = math.log10(lo), math.log10(hi)
            if hi - lo < 1e-12:
                d = 0.5 if log else max(abs(lo) * 0.1, 1.0)
                return lo - d, hi + d
            d = 0.06 * (hi - lo)
            return lo - d, hi + d

        X0, X1 = pad(xlo, xhi, xlog)
        Y0, Y1 = pad(ylo, yhi, ylog)

        def sx(v):
            v = math.log10(v) if xlog else v
            return left + (v - X0) / (X1 - X0) * pw

        def sy(v):
            v = math.log10(v) if ylog else v
            return top + ph - (v - Y0) / (Y1 - Y0) * ph

        rx = (10 ** X0, 10 ** X1) if xlog else (X0, X1)
        ry = (10 ** Y0, 10 ** Y1) if ylog else (Y0, Y1)
        for t in _ticks(*rx, xlog):
            x = sx(t)
            out.append(f'<line x1="{x:.1f}" y1="{top}" x2="{x:.1f}" y2="{top + ph}" stroke="#eee"/>'
                       f'<text x="{x:.1f}" y="{top + ph + 14}" text-anchor="middle">{_e(_tick(t, xlog))}</text>')
        for t in _ticks(*ry, ylog):
            y = sy(t)
            out.append(f'<line x1="{left}" y1="{y:.1f}" x2="{left + pw}" y2="{y:.1f}" stroke="#eee"/>'
                       f'<text x="{left - 5}" y="{y + 4:.1f}" text-anchor="end">{_e(_tick(t, ylog))}</text>')
        for p in points:
            out.append(_marker(p["marker"], sx(p["x"]), sy(p["y"]), 5.0, p["color"], p["filled"], p["tip"]))
    else:
        out.append(f'<text x="{left + pw / 2:.0f}" y="{top + ph / 2:.0f}" text-anchor="middle" fill="#888">'
                   "no measured variant</text>")
    xl = xlabel + (" (log scale)" if points and xlog else "")
    yl = ylabel + (f"; {dropped} zero value(s) not shown" if dropped else "")
    out.append(f'<text x="{left + pw / 2:.0f}" y="{H - 10}" text-anchor="middle">{_e(xl)}</text>')
    out.append(f'<text transform="translate(16,{top + ph / 2:.0f}) rotate(-90)" text-anchor="middle">{_e(yl)}</text>')
    for i, (label, color, marker, filled) in enumerate(legend):
        y = top + 10 + 16 * i
        out.append(_marker(marker, left + pw + 16, y, 4.5, color, filled, label))
        out.append(f'<text x="{left + pw + 26}" y="{y + 4}">{_e(label)}</text>')
    out.append("</svg>")
    return "".join(out)


# ----------------------------------------------------------------------------------------------
# the page


def _params(r: dict) -> str:
    size = f"panel {_num(r['panel_size'])}" + (f" ({r['divisions']} across)" if r.get("divisions") else "")
    return f"{size}, budget {_num(r['time_budget'])} s"


def _charts(table) -> list[str]:
    strategies = list(dict.fromkeys(r["strategy"] for r in table.rows))
    surfaces = list(dict.fromkeys(r["surface"] for r in table.rows))
    legend = [(s, COLORS[i % len(COLORS)], "circle", True) for i, s in enumerate(strategies)]
    legend += [(s, "#444", MARKERS[i % len(MARKERS)], True) for i, s in enumerate(surfaces)]
    legend.append(("status not ok", "#444", "circle", False))
    out = []
    for col, title, label, log in CHARTS:
        pts = []
        for r in table.rows:
            if r.get("panels") is None or r.get(col) is None:
                continue
            tip = (f"{r['surface']} · {r['strategy']} · {_params(r)} · {r['panels']} panels · {col} "
                   f"{_num(r[col])} · {r['status']} · id {r['id']}")
            pts.append({"x": r["panels"], "y": r[col], "marker": MARKERS[surfaces.index(r["surface"]) % len(MARKERS)],
                        "color": COLORS[strategies.index(r["strategy"]) % len(COLORS)],
                        "filled": r["status"] == "ok", "tip": tip})
        svg = scatter_svg(pts, title, "panel count", label, ylog=log, legend=legend)
        out.append(f"<figure>{svg}<figcaption>{_e(title)}: {len(pts)} variant(s); hover a point for its "
                   "variant</figcaption></figure>")
    return out


_TABLE = (("id", "id"), ("surface", "surface"), ("strategy", "strategy"), ("panel_size", "panel size"),
          ("divisions", "across"), ("time_budget", "budget (s)"), ("status", "status"), ("panels", "panels"),
          ("planarity_max", "max planarity"), ("planarity_mean", "mean planarity"),
          ("closeness_max", "max closeness"), ("healthy", "healthy"), ("coverage", "coverage"),
          ("worst_corner", "worst corner (°)"), ("shortest_edge_ratio", "shortest edge ÷ median"),
          ("panel_types", "panel types"), ("time", "time (s)"), ("cached", "cached"))
_LEFT = {"id", "surface", "strategy", "status"}


def _table(rows: list[dict]) -> str:
    head = "".join(f'<th class="l">{_e(t)}</th>' if k in _LEFT else f"<th>{_e(t)}</th>" for k, t in _TABLE)
    out = [f'<table><thead><tr>{head}<th class="l">notes</th></tr></thead><tbody>']
    for r in rows:
        cls = _STATUS_CLASS.get(r["status"], "")
        cells = []
        for k, _ in _TABLE:
            v = r.get(k)
            if k == "status":
                text = status_text({"status": r["status"], "detail": r.get("error") or r.get("detail") or ""})
                cells.append(f'<td class="l status">{_e(text)}</td>')
            elif k in _LEFT:
                cells.append(f'<td class="l"><code>{_e(v)}</code></td>' if k == "id" else f'<td class="l">{_e(v)}</td>')
            elif k == "coverage" and v is not None:
                cells.append(f"<td>{float(v):.1%}</td>")
            else:
                cells.append(f"<td>{_e(_num(v))}</td>")
        notes = list(r.get("warnings") or ()) + list(r.get("violations") or ())
        cells.append('<td class="l notes">' + (f"<details><summary>{len(notes)} note{'' if len(notes) == 1 else 's'}"
                                               f"</summary>{'<br>'.join(_e(n) for n in notes)}</details>"
                                               if notes else "") + "</td>")
        out.append(f'<tr{f" class={chr(34)}{cls}{chr(34)}" if cls else ""}>{"".join(cells)}</tr>')
    out.append("</tbody></table>")
    return "\n".join(out)


def _html(table, generated: str) -> str:
    s = table.study
    counts = table.counts()
    sizes = (f"panel sizes {', '.join(_num(h) for h in s.panel_sizes)} (model units)" if s.panel_sizes else
             f"{', '.join(str(d) for d in s.divisions)} panels across the larger extent")
    parts = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
             '<meta name="viewport" content="width=device-width, initial-scale=1">',
             f"<title>PQ study: {_e(s.title)}</title>",
             '<link rel="icon" href="data:,">',  # no favicon request (a 404 would be a console error when served)
             f"<style>{_CSS}</style>", "</head>", "<body>",
             f"<h1>Parametric study: {_e(s.title)}</h1>",
             f'<p class="note">Generated {_e(generated)}; {len(table)} variants = {len(table.surfaces)} surface(s) × '
             f"{len(s.strategies)} strateg{'y' if len(s.strategies) == 1 else 'ies'} × {sizes} × time budget(s) "
             f"{', '.join(_num(b) for b in s.time_budgets)} s. {table.computed} computed"
             + (f" on {table.workers} worker(s)" if table.workers else "")
             + f", {table.cached} from the cache" + (f", {table.not_run} not run" if table.not_run else "")
             + f", in {table.elapsed:.1f} s. The same table: <a href=\"study.csv\">study.csv</a>, "
             '<a href="study.json">study.json</a>.</p>',
             "<p>" + " · ".join(f"<b>{n}</b> {_e(st)}" for st, n in counts.items()) + "</p>",
             '<p class="note">Status is the harness verdict of the final mesh: "ok" only when healthy (no defect but '
             "planarity, coverage reached) and within the planarity tolerance. Planarity is scale-free (distance "
             "between the diagonals / mean diagonal); closeness is the distance to the design surface in model units; "
             "panel types count panels congruent within 1e-3 × the median edge length.</p>",
             "<h2>Charts</h2>", '<div class="grid">', *_charts(table), "</div>",
             "<h2>Design surfaces</h2><ul>"]
    for surf in table.surfaces:
        parts.append(f"<li><b>{_e(surf['name'])}</b>: {_e(surf['description'])}; {surf['vertices']:,} vertices, "
                     f"{surf['triangles']:,} triangles</li>")
    parts += ["</ul>", f"<h2>Variants ({len(table)})</h2>", _table(table.rows), "</body>", "</html>"]
    return "\n".join(parts) + "\n"


# ----------------------------------------------------------------------------------------------
# CSV / JSON


def _csv_value(v) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, (list, tuple)):
        return " | ".join(str(x) for x in v)
    if isinstance(v, float):
        return repr(v)
    return str(v)


def _study_json(s) -> dict:
    return {"title": s.title, "source": s.source, "samples": list(s.samples),
            "meshes": [{"path": str(m.path), "name": m.name, "layer": m.layer, "object": m.object} for m in s.meshes],
            "strategies": list(s.strategies), "panel_size": list(s.panel_sizes), "divisions": list(s.divisions),
            "resolution": s.resolution, "time_budget": list(s.time_budgets)}


def write_report(table, out) -> tuple[Path, Path, Path]:
    """Write ``study.html``, ``study.csv`` and ``study.json`` of a study table into ``out``; their paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    generated = _dt.datetime.now().isoformat(timespec="seconds")
    html_path, csv_path, json_path = out / "study.html", out / "study.csv", out / "study.json"
    with open(csv_path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(table.columns)
        for r in table.rows:
            w.writerow([_csv_value(r.get(c)) for c in table.columns])
    doc = {"title": table.study.title, "generated": generated, "elapsed": table.elapsed, "study": _study_json(
        table.study), "surfaces": table.surfaces, "counts": table.counts(), "computed": table.computed,
        "cached": table.cached, "not_run": table.not_run, "cache": None if table.cache_dir is None else
        str(table.cache_dir), "columns": list(table.columns),
        "rows": [dict(r, metrics=table.metrics.get(r["key"])) for r in table.rows]}
    json_path.write_text(json.dumps(doc, indent=1, allow_nan=False), encoding="utf-8")
    html_path.write_text(_html(table, generated), encoding="utf-8")
    return html_path, csv_path, json_path

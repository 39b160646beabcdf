"""The comparison report (ghserver.report) and the strategy registry behind it (components.harness).

One quick report (all built-in surfaces, all strategies) is generated per session into a temporary folder; the tests
check its files: pictures are PNGs of the fixed size with real content, their colour-bar limits are the metrics'
min/max, CSV and JSON have one row per (strategy, surface), the HTML is well formed and every link resolves, and
every row's status agrees with the panel health recomputed on the mesh saved next to it (issue #16: "ok" only for a
healthy result within the planarity tolerance, otherwise the status names the defect).
"""
from __future__ import annotations

import csv
import io
import json
import re
import struct
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from components import harness as st
from ghserver.cli import main as cli_main
from components.core.errors import InputError
from components.core.mesh import boundary_loops, read_mesh, write_obj
from components.metrics.health import DEFECT_BITS, face_health
from components.metrics.quality import quad_planarity, vertex_distances
from components.surfaces.samples import SAMPLE_NAMES, sample_mesh
from components.surfaces.translation_fit import translation_candidate
from ghserver import report as rp

# ----------------------------------------------------------------------------------------------
# helpers


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()[:32]
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path.name} is not a PNG"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


class WellFormed(HTMLParser):
    """Checks that every element is closed in order (void elements excepted) and collects links."""

    VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.links: list[tuple[str, str, str]] = []  # (tag, attribute, value)
        self.doctype = None
        self.tags: list[str] = []

    def handle_decl(self, decl):
        self.doctype = decl

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        for k, v in attrs:
            if k in ("src", "href"):
                self.links.append((tag, k, v or ""))
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in self.VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in self.VOID:
            self.errors.append(f"end tag for void element <{tag}>")
        elif not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes <{self.stack[-1] if self.stack else None}> at {self.getpos()}")
        else:
            self.stack.pop()


def close(a, b, rtol=1e-9, atol=1e-15):
    return abs(a - b) <= atol + rtol * abs(b)


class SummaryCells(HTMLParser):
    """The text of every cell of the first table (the summary), row by row, and each row's class."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.rows: list[list[str]] = []
        self.classes: list[str] = []
        self.head: list[str] = []
        self._tables = 0
        self._cell = None
        self._in_head = False

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self._tables += 1
        if self._tables != 1:
            return
        if tag == "thead":
            self._in_head = True
        elif tag == "tr" and not self._in_head:
            self.rows.append([])
            self.classes.append(dict(attrs).get("class") or "")
        elif tag in ("td", "th"):
            self._cell = []
        elif tag == "br" and self._cell is not None:
            self._cell.append("\n")

    def handle_endtag(self, tag):
        if self._tables != 1:
            return
        if tag == "thead":
            self._in_head = False
        elif tag == "summary" and self._cell is not None:  # the notes' count, then one note per line
            self._cell.append("\n")
        elif tag in ("td", "th") and self._cell is not None:
            text = "".join(self._cell)
            (self.head if self._in_head else self.rows[-1]).append(text)
            self._cell = None
        elif tag == "table":
            self._tables += 1

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)


def summary_cells(html_text: str) -> list[dict]:
    """The summary table as one dict per row, keyed by the column titles (plus ``"class"``)."""
    p = SummaryCells()
    p.feed(html_text)
    p.close()
    return [dict(zip(p.head, r), **{"class": c}) for r, c in zip(p.rows, p.classes)]


#: the panel-health bounds of issue #16, spelled out here (not read from the harness)
BOUNDS = {"min_edge_ratio": 0.2, "min_angle": 20.0, "min_area_ratio": 0.1, "min_coverage": 0.85}


def expected_status(h, tolerance: float) -> tuple[str, bool]:
    """Status and healthy flag of a verdict, decided here from the per-face bits and the coverage."""
    shape = np.any(h.face_defects & ~DEFECT_BITS["nonplanar"]) or h.coverage < BOUNDS["min_coverage"]
    planar = float(np.max(h.planarity)) <= tolerance
    if shape:
        return "unhealthy", False
    return ("ok" if planar else "tolerance missed"), True


# ----------------------------------------------------------------------------------------------
# the quick report, once


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    summary = rp.run_report(out, quick=True, progress=False)
    data = json.loads(summary.json.read_text())
    return summary, data


def test_report_files(quick_report):
    summary, data = quick_report
    out = summary.out_dir
    for f in ("report.html", "report.csv", "report.json"):
        assert (out / f).is_file() and (out / f).stat().st_size > 0
    assert summary.rows == len(SAMPLE_NAMES) * len(st.STRATEGIES)
    assert data["settings"]["mode"] == "quick"


def test_one_row_per_strategy_and_surface(quick_report):
    summary, data = quick_report
    pairs = [(r["strategy"], r["surface"]) for r in data["results"]]
    expected = {(s, f) for s in st.strategy_names() for f in SAMPLE_NAMES}
    assert len(pairs) == len(set(pairs)) and set(pairs) == expected
    rows = list(csv.DictReader(io.StringIO(summary.csv.read_text())))
    assert [(r["strategy"], r["surface"]) for r in rows] == pairs
    # CSV numbers are the JSON numbers
    for row, res in zip(rows, data["results"]):
        assert row["status"] == res["status"] and row["detail"] == res["detail"]
        for k in ("coverage", "worst_corner", "shortest_edge_ratio"):
            assert (row[k] == "") if res[k] is None else float(row[k]) == res[k]
        assert row["healthy"] == ("" if res["healthy"] is None else str(res["healthy"]))
        assert row["violations"] == " | ".join(res["violations"])
        assert float(row["tolerance"]) == res["tolerance"]
        for stage in ("before", "after"):
            m = res[f"metrics_{stage}"]
            if m is None:
                assert row[f"{stage}_planarity_max"] == ""
            else:
                assert float(row[f"{stage}_planarity_max"]) == m["planarity_max"]
                assert float(row[f"{stage}_closeness_max"]) == m["closeness_max"]
        for k, v in res["timings"].items():
            assert float(row[f"time_{k}"]) == v


def test_statuses_are_honest(quick_report):
    _, data = quick_report
    for r in data["results"]:
        assert r["status"] in st.STATUSES
        if r["status"] == "ok":  # ok only for a healthy result within the tolerance
            assert r["healthy"] is True and r["violations"] == [] and r["coverage"] >= BOUNDS["min_coverage"]
            assert (r["metrics_after"] or r["metrics_before"])["planarity_max"] <= r["tolerance"]
        elif r["status"] == "failed":
            assert r["healthy"] is None and r["images"] == [] and r["meshes"] == {}
        else:  # the status names the defect
            assert r["violations"] and r["detail"] and r["detail"] != r["description"]
            assert (r["status"] == "unhealthy") == (r["healthy"] is False)
    by = {(r["strategy"], r["surface"]): r for r in data["results"]}
    for surface in SAMPLE_NAMES:  # translation and subdivision produce a mesh everywhere
        assert by[("translation", surface)]["status"] != "failed"
        assert by[("subdivision", surface)]["status"] != "failed"
        # translation surfaces are exact PQ, no optimization step
        t = by[("translation", surface)]
        assert t["metrics_before"]["planarity_max"] < 1e-12 and t["metrics_after"] is None
        assert t["status"] != "tolerance missed"
        s = by[("subdivision", surface)]
        assert s["metrics_after"] is not None and s["timings"]["planarize"] > 0
        assert s["metrics_after"]["faces"] == s["metrics_before"]["faces"]
        ok_after = s["metrics_after"]["planarity_max"] <= s["tolerance"]
        assert s["status"] in (("ok", "unhealthy") if ok_after else ("tolerance missed", "unhealthy"))


def test_status_agrees_with_panel_health_of_the_saved_mesh(quick_report):
    """Every row's status, healthy flag and coverage are face_health's verdict on the final mesh written next to it
    (recomputed here from the OBJ and the design surface, not taken from the harness)."""
    summary, data = quick_report
    cells = summary_cells(summary.html.read_text(encoding="utf-8"))
    assert len(cells) == len(data["results"])
    refs = {name: sample_mesh(name, rp.QUICK.resolution)[:2] for name in SAMPLE_NAMES}
    for r, c in zip(data["results"], cells):
        assert (c["surface"], c["strategy"]) == (r["surface"], r["strategy"])
        if r["status"] == "failed":
            assert not r["meshes"] and c["status"].startswith("failed: ")
            continue
        stage = "optimized" if "optimized" in r["meshes"] else "candidate"
        V, F = read_mesh(summary.out_dir / r["meshes"][stage])
        h = face_health(V, F, refs[r["surface"]], tolerance=r["tolerance"], **BOUNDS)
        status, healthy = expected_status(h, r["tolerance"])
        assert (r["status"], r["healthy"]) == (status, healthy), (r["surface"], r["strategy"], r["detail"])
        assert r["violations"] == h.violations
        assert close(r["coverage"], h.coverage, rtol=1e-9, atol=1e-12)
        assert close(r["worst_corner"], h.worst_corner, rtol=1e-9, atol=1e-9)
        assert close(r["shortest_edge_ratio"], h.shortest_edge_ratio, rtol=1e-9, atol=1e-12)
        # the summary table shows the same verdict; "ok" only for healthy results within the tolerance
        assert c["healthy"] == ("yes" if healthy else "no")
        assert c["coverage"] == f"{h.coverage:.1%}"
        if status == "ok":
            assert c["status"] == "ok" and c["class"] == ""
        else:
            assert c["status"] == f"{status}: {r['detail']}" and c["class"] != ""
            if status == "tolerance missed":
                assert "max planarity" in c["status"] and "> tolerance" in c["status"]
        notes = h.violations + r["warnings"]
        lines = c["warnings"].split("\n")
        assert lines[0] == (f"{len(notes)} note{'' if len(notes) == 1 else 's'}" if notes else "")
        assert sorted(lines[1:]) == sorted(notes)


def test_summary_columns(quick_report):
    summary, _ = quick_report
    p = SummaryCells()
    p.feed(summary.html.read_text(encoding="utf-8"))
    for title in ("status", "healthy", "coverage", "worst corner (°)", "shortest edge ÷ median", "warnings"):
        assert title in p.head, title


def test_images_are_pngs_of_the_expected_meshes(quick_report):
    summary, data = quick_report
    import matplotlib.image as mpimg

    n = 0
    for r in data["results"]:
        for img in r["images"]:
            path = summary.out_dir / img["file"]
            assert path.is_file()
            assert png_size(path) == tuple(img["size"])
            if img["kind"] == "mesh":
                assert tuple(img["size"]) == rp.IMAGE_SIZE
                m = r["metrics_before"] if img["stage"] == "candidate" else r["metrics_after"]
                assert img["faces"] == m["faces"] and img["vertices"] == m["vertices"]
            rgb = np.round(mpimg.imread(path)[..., :3] * 255).astype(np.uint32)
            colours = np.unique((rgb[..., 0] << 16 | rgb[..., 1] << 8 | rgb[..., 2]).ravel())
            assert len(colours) > 50, f"{img['file']} is nearly blank ({len(colours)} colours)"
            n += 1
    for img in data["comparisons"]:
        path = summary.out_dir / img["file"]
        assert png_size(path) == tuple(img["size"])
        n += 1
    assert n == summary.images
    # every strategy that produced a mesh (healthy or not) has 3 pictures per stage and one histogram figure
    for r in data["results"]:
        if r["status"] != "failed":
            stages = 1 + (r["metrics_after"] is not None)
            kinds = [i["kind"] for i in r["images"]]
            assert kinds.count("mesh") == 3 * stages and kinds.count("histogram") == 1


def test_colour_bar_limits_are_the_metrics(quick_report):
    _, data = quick_report
    checked = 0
    for r in data["results"]:
        for img in r["images"]:
            if img["kind"] != "mesh":
                continue
            m = r["metrics_before"] if img["stage"] == "candidate" else r["metrics_after"]
            lo, hi = img["vmin"], img["vmax"]
            assert lo <= hi
            if img["measure"] == "planarity":
                assert close(lo, m["planarity_min"]) and close(hi, m["planarity_max"])
            elif img["measure"] == "area":
                assert close(lo, m["area_min"]) and close(hi, m["area_max"])
            else:  # closeness: a face shows its farthest corner, so the top of the bar is the mesh's maximum
                assert close(hi, m["closeness_max"], atol=1e-12)
                assert lo >= m["closeness_min"] - 1e-12
            checked += 1
    assert checked >= 2 * 9 * len(SAMPLE_NAMES) / 2


def test_face_values_recomputed_from_the_written_meshes(quick_report):
    """The pictures' numbers come from the meshes written next to them."""
    from components.core.mesh import read_mesh

    summary, data = quick_report
    r = next(r for r in data["results"] if r["strategy"] == "subdivision" and r["surface"] == "saddle")
    V, F = read_mesh(summary.out_dir / r["meshes"]["optimized"])
    img = next(i for i in r["images"] if i["stage"] == "optimized" and i["measure"] == "planarity")
    q = quad_planarity(V, F)
    assert close(q.max(), img["vmax"], rtol=1e-9) and close(q.min(), img["vmin"], atol=1e-12)
    Vr, Tr, _ = sample_mesh("saddle", rp.QUICK.resolution)
    d, _ = vertex_distances(V, Vr, Tr, signed=False)
    img = next(i for i in r["images"] if i["stage"] == "optimized" and i["measure"] == "closeness")
    assert close(np.abs(d).max(), img["vmax"], rtol=1e-6, atol=1e-9)


def test_html_is_well_formed_and_self_contained(quick_report):
    summary, data = quick_report
    text = summary.html.read_text(encoding="utf-8")
    p = WellFormed()
    p.feed(text)
    p.close()
    assert p.doctype and p.doctype.lower() == "doctype html"
    assert not p.errors, p.errors[:5]
    assert p.stack == [], f"unclosed elements: {p.stack}"
    assert p.tags[:1] == ["html"] and "head" in p.tags and "title" in p.tags and "body" in p.tags
    # one script: the 3D views' classic script beside the page (it loads three.js and each view's data itself)
    scripts = [v for t, k, v in p.links if t == "script"]
    assert p.tags.count("script") == len(scripts) == 1 and scripts == ["viewer/viewer.js"]
    # inline CSS, no stylesheets or fonts: the only <link> is the empty inline favicon
    assert [(t, v) for t, k, v in p.links if t == "link"] == [("link", "data:,")]
    srcs = [v for t, k, v in p.links if t == "img"]
    assert len(srcs) == summary.images
    for tag, attr, v in p.links:
        assert "://" not in v and not v.startswith("//"), f"external reference {v}"
        if v.startswith("#") or v.startswith("data:"):
            continue
        assert (summary.out_dir / v).is_file(), f"<{tag} {attr}={v}> does not resolve"
    for r in data["results"]:
        assert r["surface"] in text and r["strategy"] in text


class Anchors(HTMLParser):
    """Ids, in-page links (with the link text), the table of contents' links and the 3D views' data files."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.ids: list[str] = []
        self.links: list[str] = []
        self.toc: list[str] = []
        self.views: list[dict] = []
        self._nav = 0

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if "id" in a:
            self.ids.append(a["id"])
        if tag == "nav":
            self._nav += 1
        if tag == "a" and (a.get("href") or "").startswith("#"):
            self.links.append(a["href"][1:])
            if self._nav:
                self.toc.append(a["href"][1:])
        if tag == "div" and "viewer3d" in (a.get("class") or "").split():
            self.views.append(a)

    def handle_endtag(self, tag):
        if tag == "nav":
            self._nav -= 1


def test_table_of_contents_reaches_every_section(quick_report):
    summary, data = quick_report
    p = Anchors()
    p.feed(summary.html.read_text(encoding="utf-8"))
    assert len(p.ids) == len(set(p.ids)), "duplicate ids"
    assert set(p.links) <= set(p.ids), set(p.links) - set(p.ids)
    assert "contents" in p.ids
    sections = {"strategies", "summary", "comparisons"} | {f"surface-{s}" for s in SAMPLE_NAMES}
    results = {"r-" + rp._slug(r["surface"], r["strategy"]) for r in data["results"]}
    assert len(results) == len(data["results"])
    assert sections | results <= set(p.toc) <= set(p.ids)
    # the summary table links every row to its section too
    assert all(p.links.count(a) == p.toc.count(a) + 1 for a in results)


def test_every_result_with_a_mesh_has_a_3d_view(quick_report):
    """The view's data file holds the meshes written beside it (float32 about the box centre) and the per-face
    fields of the pictures; its controls offer every measure and, when there is one, the optimized stage."""
    import base64

    summary, data = quick_report
    p = Anchors()
    p.feed(summary.html.read_text(encoding="utf-8"))
    views = {v["data-view"]: v for v in p.views}
    out = summary.out_dir
    for name in ("viewer.js", "three.js", "three-LICENSE.txt"):
        assert (out / rp.VIEWER_DIR / name).is_file()
    assert "window.PQ_THREE" in (out / rp.VIEWER_DIR / "three.js").read_text(encoding="utf-8")
    refs = {name: sample_mesh(name, rp.QUICK.resolution)[:2] for name in SAMPLE_NAMES}
    for r in data["results"]:
        if r["status"] == "failed":
            assert "view" not in r
            continue
        view = r["view"]
        el = views[view["id"]]
        assert el["data-src"] == view["file"] and (out / view["file"]).is_file()
        assert el["data-stage"] == view["stages"][-1] == ("optimized" if "optimized" in r["meshes"] else "candidate")
        text = (out / view["file"]).read_text(encoding="utf-8")
        prefix = f"PQViewer.add({json.dumps(view['id'])}, "
        assert text.startswith(prefix) and text.rstrip().endswith(");")
        d = json.loads(text.rstrip()[len(prefix):-2])
        assert set(d["stages"]) == set(r["meshes"]) and set(d["metrics"]) == set(rp.VIEW_MEASURES)
        centre = np.array(d["centre"])
        for stage, mesh_file in r["meshes"].items():
            V, F = read_mesh(out / mesh_file)
            st = d["stages"][stage]
            topo = d["stages"][st["same_faces"]] if "same_faces" in st else st
            Vv = np.frombuffer(base64.b64decode(st["V"]), dtype="<f4").reshape(-1, 3) + centre
            assert np.abs(Vv - V).max() <= 1e-6 * d["radius"]
            Fv = np.frombuffer(base64.b64decode(topo["F"]), dtype="<u4").reshape(-1, topo["k"])
            assert np.array_equal(Fv, F)
            q = np.frombuffer(base64.b64decode(d["metrics"]["planarity"]["stages"][stage]["values"]), dtype="<f4")
            assert np.allclose(q, quad_planarity(V, F), rtol=1e-6, atol=1e-30)
            c = np.frombuffer(base64.b64decode(d["metrics"]["closeness"]["stages"][stage]["values"]), dtype="<f4")
            assert np.allclose(c, rp.face_values(V, F, "closeness", refs[r["surface"]]), rtol=1e-5,
                               atol=1e-6 * d["radius"])
            for m, spec in d["metrics"].items():  # the legend's "all equal to" is the pictures' verdict
                img = next((i for i in r["images"] if i.get("stage") == stage and i.get("measure") == m), None)
                if img is not None:
                    assert spec["stages"][stage]["constant"] == img["constant"]


def test_round_off_fields_are_constant(quick_report):
    """A translation surface is exactly planar: its planarity (about 1e-16) is drawn in one colour and labelled
    "all equal to 0 (round-off …)" (picture, caption, 3D legend), never coloured as if it varied; real variation
    (the subdivision's optimized planarity, every area) keeps its colour bar."""
    summary, data = quick_report
    text = summary.html.read_text(encoding="utf-8")
    for r in data["results"]:
        for img in r["images"]:
            if img["kind"] != "mesh":
                continue
            if r["strategy"] == "translation" and img["measure"] == "planarity":
                assert img["constant"].startswith("all equal to 0 (round-off"), img
                assert img["constant"] in text
            elif img["measure"] == "area" or (r["strategy"] == "subdivision" and img["measure"] == "planarity"
                                              and img["stage"] == "optimized"):
                assert img["constant"] is None, img


def test_constant_field_is_relative_to_the_scale():
    rng = np.random.default_rng(3)
    noise = rng.uniform(0, 1, 50)
    for unit in (1e-3, 1.0, 1e3):  # mm / m / km: the same verdict
        length = 40.0 * unit
        assert rp.constant_field(1e-15 * length * noise, length).startswith("all equal to 0 (round-off")
        assert rp.constant_field(1e-6 * length * noise, length) is None
        area = 16.0 * unit**2
        assert rp.constant_field(area * (1 + 1e-13 * noise), rp.measure_scale("area", length)) == \
            f"all equal to {rp._fmt(float(np.median(area * (1 + 1e-13 * noise))), 4)}"
        assert rp.constant_field(area * (1 + 1e-3 * noise), rp.measure_scale("area", length)) is None
    assert rp.constant_field(np.full(5, 2.0)) == "all equal to 2"  # exactly equal, no scale needed
    assert rp.constant_field([]) is None


def _captured_figures(monkeypatch):
    """Record every figure the report closes (it closes each after saving)."""
    import matplotlib.pyplot as plt

    figs, close = [], plt.close

    def keep(fig=None):
        figs.append(fig)
        close(fig)

    monkeypatch.setattr(plt, "close", keep)
    return figs


def _drawn_texts(fig):
    from matplotlib.text import Text

    fig.canvas.draw()
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()
            and (t.axes is None or t.axes.axison)]


def test_every_figure_text_is_legible(monkeypatch, tmp_path):
    """No text of any report figure is below MIN_FONT_PT, i.e. MIN_FONT_PX >= 11 pixels at the pictures' own size
    (the browser test checks the page shows them at that size)."""
    assert rp.MIN_FONT_PX >= 11.0
    figs = _captured_figures(monkeypatch)
    V, T, _ = sample_mesh("dome", 12)
    Vt, Qt, _ = translation_candidate(V, T, st.default_panel_size(V, 6))
    q = quad_planarity(Vt, Qt)
    box = (Vt.min(axis=0), Vt.max(axis=0))
    rp.render_mesh(tmp_path / "a.png", Vt, Qt, np.linspace(0, 1e-3, len(Qt)), "t\nx", "planarity (scale-free)", box)
    rp.render_mesh(tmp_path / "b.png", Vt, Qt, q, "t", "planarity", box, scale=1.0)
    fields = {"planarity": q, "warping": q * 10, "area": np.linspace(1, 2, len(Qt))}
    rp.render_histograms(tmp_path / "h.png", fields, {k: v * 2 + 1e-3 for k, v in fields.items()}, "h")
    rp.render_area_boxes(tmp_path / "x.png", [(f"s{i} · strategy_{i}", np.arange(5.0) + i) for i in range(20)], "x")
    assert len(figs) == 4
    for fig in figs:
        texts = _drawn_texts(fig)
        assert texts
        small = [(t.get_text(), t.get_fontsize()) for t in texts if t.get_fontsize() < rp.MIN_FONT_PT]
        assert not small, small


def test_constant_fields_are_drawn_in_one_colour(monkeypatch, tmp_path):
    figs = _captured_figures(monkeypatch)
    V, T, _ = sample_mesh("dome", 12)
    Vt, Qt, _ = translation_candidate(V, T, st.default_panel_size(V, 6))
    q = quad_planarity(Vt, Qt)
    assert 0 < q.max() < 1e-12
    rp.render_mesh(tmp_path / "p.png", Vt, Qt, q, "t", "planarity", (Vt.min(axis=0), Vt.max(axis=0)), scale=1.0)
    fig = figs[-1]
    assert len(fig.axes) == 1  # no colour bar
    colours = np.unique(np.round(fig.axes[0].collections[0].get_facecolor()[:, :3], 6), axis=0)
    assert len(colours) == 1
    assert any("all equal to 0 (round-off" in t.get_text() for t in _drawn_texts(fig))
    # the histogram of a round-off field is a sentence, not one clamped bar
    fields = {"planarity": q, "warping": q, "area": np.linspace(1, 2, len(Qt))}
    rp.render_histograms(tmp_path / "h.png", fields, None, "h",
                         scales={"planarity": 1.0, "warping": 40.0, "area": 1600.0})
    ax_pl, ax_w, ax_a = figs[-1].axes
    assert len(ax_pl.patches) == 0 and len(ax_w.patches) == 0 and len(ax_a.patches) > 0
    assert "all equal to 0" in " ".join(t.get_text() for t in ax_pl.texts)


def test_box_plot_labels_do_not_overlap(monkeypatch, tmp_path):
    figs = _captured_figures(monkeypatch)
    for n in (3, 16, 40):
        groups = [(f"surface{i}\ncurvature_network\n(optimized)", np.arange(6.0) * (i + 1)) for i in range(n)]
        rp.render_area_boxes(tmp_path / f"b{n}.png", groups, "boxes")
        assert png_size(tmp_path / f"b{n}.png") == rp.area_boxes_size(n)
        fig = figs[-1]
        fig.canvas.draw()
        boxes = sorted((t.get_window_extent() for t in fig.axes[0].get_yticklabels() if t.get_text()),
                       key=lambda b: b.y0)
        assert len(boxes) == n
        assert all(a.y1 <= b.y0 for a, b in zip(boxes, boxes[1:])), "labels overlap"
        assert min(b.x0 for b in boxes) >= 0 and max(b.y1 for b in boxes) <= fig.bbox.height


def test_classic_module_join():
    """The three.js modules are joined into a classic script; a module of another shape is refused."""
    out = rp.classic_module("m.js", "import { A, B as C } from 'three';\nclass D extends A {}\nexport { D, C as E };",
                            {"three": "three.module.js"})
    assert 'const { A, B: C } = __m["three.module.js"];' in out and "Object.assign(__e, { D: D, E: C });" in out
    for bad in ("export default 1;", "export const x = 1;", "import 'side-effect';", "import { a } from 'other';"):
        with pytest.raises(ValueError):
            rp.classic_module("m.js", bad, {"three": "three.module.js"})
    bundle = rp.viewer_bundle()
    assert "window.PQ_THREE" in bundle and "OrbitControls" in bundle
    assert not re.search(r"^\s*(import|export)\s*\{", bundle, re.M)


def test_view_data_keeps_site_coordinates_and_caps_big_meshes(monkeypatch, tmp_path):
    import base64

    V, T, _ = sample_mesh("wave", 12)
    Vt, Qt, _ = translation_candidate(V, T, st.default_panel_size(V, 6))
    shift = np.array([5e6, -3e6, 120.0])
    W = Vt + shift
    fields = {m: rp.face_values(W, Qt, m, (V + shift, T)) if m != "warping" else np.zeros(len(Qt))
              for m in rp.VIEW_MEASURES}
    d = rp.view_data([("candidate", W, Qt)], {"candidate": fields}, (W.min(axis=0), W.max(axis=0)))
    back = np.frombuffer(base64.b64decode(d["stages"]["candidate"]["V"]), dtype="<f4").reshape(-1, 3)
    back = back + np.array(d["centre"])
    assert np.abs(back - W).max() <= 1e-6 * d["radius"]  # float32 about the centre: no 0.5-unit steps at 5e6
    assert d["metrics"]["planarity"]["stages"]["candidate"]["constant"].startswith("all equal to 0")
    monkeypatch.setattr(rp, "VIEW_FACE_CAP", 10)
    summary = rp.run_report(tmp_path, surfaces=["dome"], strategies=["translation"], quick=True, progress=False)
    row = json.loads(summary.json.read_text())["results"][0]
    assert "10-panel limit" in row["view"]["note"] and not list((tmp_path / rp.VIEWER_DIR / "data").glob("*.js"))
    html_text = summary.html.read_text(encoding="utf-8")
    assert "10-panel limit" in html_text and "viewer.js" not in html_text


def test_static_files_are_package_data():
    """The wheel carries the 3D view's files: pyproject's package-data globs match every file of ghserver/static."""
    import fnmatch

    tomllib = pytest.importorskip("tomllib")  # Python 3.11+

    root = Path(rp.__file__).resolve().parent
    cfg = tomllib.loads((root.parent / "pyproject.toml").read_text(encoding="utf-8"))
    globs = cfg["tool"]["setuptools"]["package-data"]["ghserver"]
    files = [p.relative_to(root).as_posix() for p in (root / "static").rglob("*") if p.is_file()]
    assert {"static/viewer.js", "static/three/three.core.js", "static/three/three.module.js",
            "static/three/OrbitControls.js", "static/three/LICENSE", "static/three/README.md"} <= set(files)
    for f in files:
        assert any(fnmatch.fnmatch(f, g) for g in globs), f"{f} is not package data"


def test_progress_bar_only_on_a_terminal():
    class Tty(io.StringIO):
        def isatty(self):
            return True

    s = Tty()
    bar = rp.Progress(4, enabled=True, stream=s)
    for k in range(4):
        bar.step(f"item {k}")
    bar.close()
    assert "[" in s.getvalue() and "4/4" in s.getvalue() and s.getvalue().endswith("\n")
    plain = io.StringIO()
    bar = rp.Progress(4, enabled=True, stream=plain)
    bar.step("x")
    bar.close()
    assert plain.getvalue() == ""
    s = Tty()
    bar = rp.Progress(4, enabled=False, stream=s)
    bar.step("x")
    bar.close()
    assert s.getvalue() == ""


def test_report_on_a_mesh_file(tmp_path):
    V, T, _ = sample_mesh("wave", 16)
    write_obj(tmp_path / "roof.obj", V, T)
    summary = rp.run_report(tmp_path / "out", surfaces=(), mesh_files=[tmp_path / "roof.obj"], progress=False,
                            quick=True, strategies=["translation"])
    data = json.loads(summary.json.read_text())
    assert [(r["strategy"], r["surface"], r["status"]) for r in data["results"]] == [("translation", "roof", "ok")]
    assert data["surfaces"][0]["description"].startswith("mesh file roof.obj")


def test_report_command_line(tmp_path, capsys):
    assert cli_main(["report", "--quick", "--no-progress", "--surfaces", "dome", "--strategies", "translation",
                    "--out", str(tmp_path)]) == 0
    assert "report written to" in capsys.readouterr().out
    assert cli_main(["report", "--quick", "--no-progress", "--strategies", "nope", "--out", str(tmp_path)]) == 2
    assert "strategy" in capsys.readouterr().err
    # bad options fail before the previous report is touched
    before = sorted(p.name for p in (tmp_path / "img").iterdir())
    assert cli_main(["report", "--quick", "--surfaces", "blob", "--out", str(tmp_path)]) == 2
    assert "surfaces" in capsys.readouterr().err
    assert cli_main(["report", "--quick", "--surfaces", "none", "--out", str(tmp_path)]) == 2
    assert cli_main(["report", "--quick", str(tmp_path / "missing.obj"), "--out", str(tmp_path)]) == 2
    assert "missing.obj" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "img").iterdir()) == before and before


# ----------------------------------------------------------------------------------------------
# the strategy registry


@pytest.mark.parametrize("name", SAMPLE_NAMES)
def test_translation_candidate_is_exactly_planar_and_close(name):
    V, T, _ = sample_mesh(name, 24)
    h = st.default_panel_size(V, 10)
    Vt, Qt, info = translation_candidate(V, T, h)
    assert quad_planarity(Vt, Qt).max() < 1e-12
    # parallelograms: opposite edges equal
    e01 = Vt[Qt[:, 1]] - Vt[Qt[:, 0]]
    e32 = Vt[Qt[:, 2]] - Vt[Qt[:, 3]]
    assert np.abs(e01 - e32).max() < 1e-9
    # near the design surface: within a small fraction of its size
    d, _ = vertex_distances(Vt, V, T, signed=False)
    assert np.abs(d).max() < 0.12 * np.ptp(V[:, 0])
    assert len(boundary_loops(Qt)) >= 1 and info["rms"] >= 0


def test_translation_fits_a_hyperbolic_paraboloid_along_its_bisectors():
    """z = xy is the translation surface of two parabolas along the diagonals: the fit is exact there."""
    from components.core.mesh import quad_grid, triangulate

    V, Q = quad_grid(20, 20, 2.0, 2.0, height=lambda x, y: (x - 1) * (y - 1))
    T = triangulate(Q)[0]
    Vt, Qt, info = translation_candidate(V, T, 0.1, angles=36)
    # along the x/y axes the best additive fit of xy leaves an RMS of about 0.1; along the bisectors it is exact
    # up to the piecewise-linear sampling of the two parabolas
    assert info["rms"] < 5e-3
    assert quad_planarity(Vt, Qt).max() < 1e-12


def test_every_strategy_runs_on_the_dome():
    V, T, _ = sample_mesh("dome", 16)
    h = st.default_panel_size(V, 8)
    for name in st.strategy_names():
        r = st.run_strategy(name, V, T, h, surface="dome", time_budget=10)
        assert r.status != "failed", (name, r.detail)
        assert r.health is not None and r.candidate_health is not None
        assert (r.status == "ok") == (r.healthy and r.health.counts["nonplanar"] == 0), (name, r.detail)
        Vc, Qc = r.candidate
        if name != "translation":  # the translation fit is exact PQ off the surface; the others are built on it
            d, _ = vertex_distances(Vc, V, T, signed=False)
            assert np.abs(d).max() < 1e-6 * np.ptp(V, axis=0).max(), name
        if r.metrics_after is not None:  # strategies with an optimization step never make planarity worse
            assert r.metrics_after["planarity_max"] <= r.metrics_before["planarity_max"] + 1e-12, name


def test_run_strategy_result_shape():
    V, T, _ = sample_mesh("saddle", 16)
    r = st.run_strategy("subdivision", V, T, st.default_panel_size(V, 6), surface="saddle", time_budget=5)
    assert r.status in st.STATUSES and r.status != "failed", r.detail
    assert r.name == "subdivision" and r.surface == "saddle" and r.tolerance == 1e-4
    assert r.optimized is not None and r.optimized[1].shape == r.candidate[1].shape
    assert r.final is r.optimized
    assert r.metrics_after["planarity_max"] <= r.metrics_before["planarity_max"] + 1e-12
    assert {"planarize", "total"} <= set(r.timings)


def _wrapped_translation(monkeypatch, damage):
    """Register ``"translation"`` with a runner that damages the translation candidate by ``damage(V, Q)``."""
    original = st.get_strategy("translation")

    def runner(V, T, panel_size, time_budget=30.0):
        out = original.runner(V, T, panel_size, time_budget=time_budget)
        Vc, Qc = out.candidate
        Vc = Vc.copy()
        damage(Vc, Qc)
        return out._replace(candidate=(Vc, Qc))

    patched = tuple(s._replace(runner=runner) if s.name == "translation" else s for s in st.STRATEGIES)
    monkeypatch.setattr(st, "STRATEGIES", patched)


def _collapse_column(V, Q):
    """Squeeze one strip of panels to 0.003 of its width, as in issue #16 (panels still planar: the translation net
    ``g(u) + h(v)`` with one step of ``g`` shrunk). The strip is walked across the grid from the middle face's edge
    ``(Q[f, 0], Q[f, 1])`` to the opposite edge ``(Q[f, 3], Q[f, 2])`` of each face and back."""
    f = len(Q) // 2
    strip, todo = set(), [(int(Q[f, 0]), int(Q[f, 1]))]
    while todo:
        a, b = todo.pop()
        if (a, b) in strip:
            continue
        strip.add((a, b))
        for g in np.nonzero((Q[:, 0] == a) & (Q[:, 1] == b))[0]:
            todo.append((int(Q[g, 3]), int(Q[g, 2])))
        for g in np.nonzero((Q[:, 3] == a) & (Q[:, 2] == b))[0]:
            todo.append((int(Q[g, 0]), int(Q[g, 1])))
    assert len(strip) >= 3
    for a, b in strip:
        V[b] = V[a] + 0.003 * (V[b] - V[a])


def test_collapsed_mesh_is_unhealthy(monkeypatch):
    V, T, _ = sample_mesh("dome", 16)
    _wrapped_translation(monkeypatch, _collapse_column)
    r = st.run_strategy("translation", V, T, st.default_panel_size(V, 8), surface="dome")
    assert r.status == "unhealthy" and r.healthy is False and r.candidate_healthy is False
    assert "shorter than 0.2 × median edge" in r.detail and "smaller than 0.1 × median face area" in r.detail
    assert r.violations == r.health.violations and r.description.startswith("translation surface")
    # the verdict is face_health's, not the strategy's
    h = face_health(*r.final, (V, T), tolerance=r.tolerance, **BOUNDS)
    assert expected_status(h, r.tolerance) == ("unhealthy", False)


def test_unhealthy_result_never_shows_ok(monkeypatch, tmp_path):
    _wrapped_translation(monkeypatch, _collapse_column)
    summary = rp.run_report(tmp_path, surfaces=["dome"], progress=False, quick=True, strategies=["translation"])
    data = json.loads(summary.json.read_text())
    (r,) = data["results"]
    assert r["status"] == "unhealthy" and r["healthy"] is False and r["images"]  # pictured, not hidden
    (c,) = summary_cells(summary.html.read_text(encoding="utf-8"))
    assert c["status"].startswith("unhealthy: ") and "shorter than" in c["status"] and c["healthy"] == "no"
    assert c["class"] == "unhealthy"
    (row,) = csv.DictReader(io.StringIO(summary.csv.read_text()))
    assert row["status"] == "unhealthy" and row["healthy"] == "False" and "shorter than" in row["violations"]
    assert summary.statuses == (("dome", "translation", "unhealthy", r["detail"]),)


def test_nonplanar_healthy_result_misses_the_tolerance(monkeypatch):
    V, T, _ = sample_mesh("dome", 16)

    def lift(Vc, Qc):  # one inner vertex lifted by 2 % of the panel size: its panels twist, nothing else
        i = int(np.argmin(np.linalg.norm(Vc[:, :2] - Vc[:, :2].mean(axis=0), axis=1)))
        Vc[i, 2] += 0.02 * np.linalg.norm(Vc[Qc[0, 1]] - Vc[Qc[0, 0]])

    _wrapped_translation(monkeypatch, lift)
    r = st.run_strategy("translation", V, T, st.default_panel_size(V, 8), surface="dome")
    assert r.status == "tolerance missed" and r.healthy is True
    assert r.detail.startswith("max planarity ") and "> tolerance 0.0001" in r.detail


def test_failed_strategy_is_a_row(monkeypatch):
    V, T, _ = sample_mesh("dome", 12)
    boom = st.Strategy("boom", "Boom", "raises", lambda *a, **k: 1 / 0)
    monkeypatch.setattr(st, "STRATEGIES", st.STRATEGIES + (boom,))
    r = st.run_strategy("boom", V, T, 5.0)
    assert r.status == "failed" and "ZeroDivisionError" in r.detail and r.metrics_before is None
    assert r.healthy is None and r.health is None and r.violations == ()


def test_bad_inputs_name_the_input():
    V, T, _ = sample_mesh("dome", 12)
    with pytest.raises(InputError, match="strategy"):
        st.run_strategy("nope", V, T, 1.0)
    with pytest.raises(InputError, match="panel_size"):
        translation_candidate(V, T, -1.0)
    # a bad panel size inside a run is a failed row, not a crash
    r = st.run_strategy("translation", V, T, float("nan"))
    assert r.status == "failed" and "panel_size" in r.detail


def test_the_help_names_every_strategy():
    """``--strategies`` help lists ``report.STRATEGY_NAMES`` (kept apart from the harness for start-up time)."""
    from components.harness import strategy_names

    assert list(rp.STRATEGY_NAMES) == list(strategy_names())

"""The comparison report (ghserver.report) and the strategy registry behind it (components.harness).

One quick report (all built-in surfaces, all strategies) is generated per session into a temporary folder; the tests
check its files: pictures are PNGs of the fixed size with real content, their colour-bar limits are the metrics'
min/max, CSV and JSON have one row per (strategy, surface), the HTML is well formed and every link resolves.
"""
from __future__ import annotations

import csv
import io
import json
import struct
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from components import harness as st
from ghserver.cli import main as cli_main
from components.core.errors import InputError
from components.core.mesh import boundary_loops, write_obj
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
        assert row["status"] == res["status"]
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
        assert r["status"] in ("ok", "failed")
    by = {(r["strategy"], r["surface"]): r for r in data["results"]}
    for surface in SAMPLE_NAMES:  # the two strategies that exist today run everywhere
        assert by[("translation", surface)]["status"] == "ok"
        assert by[("subdivision", surface)]["status"] == "ok"
        # translation surfaces are exact PQ, no optimization step
        t = by[("translation", surface)]
        assert t["metrics_before"]["planarity_max"] < 1e-12 and t["metrics_after"] is None
        s = by[("subdivision", surface)]
        assert s["metrics_after"] is not None and s["timings"]["planarize"] > 0
        assert s["metrics_after"]["faces"] == s["metrics_before"]["faces"]


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
    # every strategy that ran has 3 pictures per stage and one histogram figure
    for r in data["results"]:
        if r["status"] == "ok":
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
    assert "script" not in p.tags  # no scripts
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
        assert r.status == "ok", (name, r.detail)
        Vc, Qc = r.candidate
        if name != "translation":  # the translation fit is exact PQ off the surface; the others are built on it
            d, _ = vertex_distances(Vc, V, T, signed=False)
            assert np.abs(d).max() < 1e-6 * np.ptp(V, axis=0).max(), name
        if r.metrics_after is not None:  # strategies with an optimization step never make planarity worse
            assert r.metrics_after["planarity_max"] <= r.metrics_before["planarity_max"] + 1e-12, name


def test_run_strategy_result_shape():
    V, T, _ = sample_mesh("saddle", 16)
    r = st.run_strategy("subdivision", V, T, st.default_panel_size(V, 6), surface="saddle", time_budget=5)
    assert r.status == "ok" and r.name == "subdivision" and r.surface == "saddle"
    assert r.optimized is not None and r.optimized[1].shape == r.candidate[1].shape
    assert r.final is r.optimized
    assert r.metrics_after["planarity_max"] <= r.metrics_before["planarity_max"] + 1e-12
    assert {"planarize", "total"} <= set(r.timings)


def test_failed_strategy_is_a_row(monkeypatch):
    V, T, _ = sample_mesh("dome", 12)
    boom = st.Strategy("boom", "Boom", "raises", lambda *a, **k: 1 / 0)
    monkeypatch.setattr(st, "STRATEGIES", st.STRATEGIES + (boom,))
    r = st.run_strategy("boom", V, T, 5.0)
    assert r.status == "failed" and "ZeroDivisionError" in r.detail and r.metrics_before is None


def test_bad_inputs_name_the_input():
    V, T, _ = sample_mesh("dome", 12)
    with pytest.raises(InputError, match="strategy"):
        st.run_strategy("nope", V, T, 1.0)
    with pytest.raises(InputError, match="panel_size"):
        translation_candidate(V, T, -1.0)
    # a bad panel size inside a run is a failed row, not a crash
    r = st.run_strategy("translation", V, T, float("nan"))
    assert r.status == "failed" and "panel_size" in r.detail

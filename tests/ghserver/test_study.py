"""Parametric studies (``ghserver study``, :func:`ghserver.study.run`) on a real two-worker Dask cluster and locally.

One loopback cluster (``tests/daskcluster.py``: a ``dask scheduler`` and two ``dask worker`` processes) serves the
module. The main study is the issue's 24 variants (4 sample surfaces × 2 strategies × 3 panel sizes) at test size
(resolution 12, a few panels across); one of its workers is killed mid-study and no variant is lost; the rerun comes
from the cache without touching a cluster; an extended study computes only its new variants on a local cluster;
an interrupted study keeps what finished; the report opens in headless Chromium without console errors.
"""
from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from components.core.errors import InputError
from ghserver import cli
from ghserver import study as st
from tests.conftest import ROOT, data_file
from ghserver.study_report import CHARTS
from tests.daskcluster import LoopbackCluster

STRATEGIES = ["translation", "curvature_network"]
STUDY = {"title": "test study", "samples": ["dome", "saddle", "wave", "canopy"], "strategies": STRATEGIES,
         "divisions": [4, 6, 8], "resolution": 12, "time_budget": 5}
UNREACHABLE = "tcp://127.0.0.1:9"  # nothing listens there: a run that needs a cluster fails to connect


# ----------------------------------------------------------------------------------------------
# fixtures


@pytest.fixture(scope="module")
def cluster():
    with LoopbackCluster(workers=2) as c:
        yield c


@pytest.fixture(scope="module")
def main_run(cluster, tmp_path_factory):
    """The 24-variant study on the two-worker cluster; worker 0 is killed after the third result arrives.

    Returns the table, the output folder, the rows in their order of arrival and the keys of the variants worker 0
    was running when it was killed.
    """
    from distributed import Client

    out = tmp_path_factory.mktemp("study")
    seen, lost = [], []
    with Client(cluster.address) as client:

        def kill_after_three(row):
            seen.append(row)
            if len(seen) == 3:
                w0 = next(a for a, w in client.scheduler_info()["workers"].items() if w["name"] == "w0")
                lost.extend(k.removeprefix("pq-variant-") for k in client.processing().get(w0, ())
                            if k.startswith("pq-variant-"))
                cluster.kill_worker(0)

        table = st.run(STUDY, cluster=client, out=out, progress=False, callback=kill_after_three)
    cluster.add_worker("w2")  # back to two workers for the tests after this one
    return table, out, seen, lost


# ----------------------------------------------------------------------------------------------
# the study file


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("data, name, words", [
    ({"samples": ["dome"], "strategies": ["planar"]}, "strategies", "must be one of 'translation'"),
    ({"samples": ["dome", "sphere"]}, "samples", "must be one of 'dome'"),
    ({"samples": []}, "samples", "empty list"),
    ({"samples": "dome", "divisions": []}, "divisions", "empty list"),
    ({"samples": "dome", "meshes": ["missing.obj"]}, "meshes", "no such file"),
    ({"samples": "dome", "meshes": ["roof.dwg"]}, "meshes", ".3dm"),
    ({"samples": "dome", "stratgies": "translation"}, "study", "unknown key 'stratgies'"),
    ({"strategies": "translation"}, "samples", "no design surface"),
    ({"samples": "dome", "panel_size": [1.0], "divisions": [4]}, "panel_size", "not both"),
    ({"samples": "dome", "panel_size": [1.0, -2.0]}, "panel_size", "> 0"),
    ({"samples": "dome", "divisions": [4.5]}, "divisions", "whole number"),
    ({"samples": "dome", "time_budget": "fast"}, "time_budget", "must be a number"),
    ({"samples": "dome", "resolution": 2}, "resolution", "4 and 1000"),
])
def test_study_file_errors_name_the_key_and_what_to_do(data, name, words, tmp_path):
    with pytest.raises(InputError) as err:
        st.load_study(data, base=tmp_path)
    assert err.value.input_name == name
    assert words in str(err.value)


def test_study_files_toml_and_json_read_alike(tmp_path):
    toml = _write(tmp_path / "s.toml", 'samples = ["dome", "wave"]\nstrategies = "translation"\n'
                                       'panel_size = [2.0, 3]\nmeshes = [{path = "m.obj", name = "roof"}]\n')
    (tmp_path / "m.obj").write_text(data_file("geometrylab_test_tri_dome.obj").read_text())
    js = _write(tmp_path / "s.json", json.dumps({"samples": ["dome", "wave"], "strategies": ["translation"],
                                                 "panel_size": [2.0, 3], "meshes": [{"path": "m.obj",
                                                                                     "name": "roof"}]}))
    a, b = st.load_study(toml), st.load_study(js)
    assert a._replace(source="") == b._replace(source="")
    assert a.panel_sizes == (2.0, 3.0) and a.divisions == () and a.meshes[0].name == "roof"
    assert a.meshes[0].path == (tmp_path / "m.obj").resolve()  # relative to the study file's folder


@pytest.mark.parametrize("text, suffix, words", [
    ("samples = [dome", ".toml", "not valid TOML"),
    ('{"samples": ', ".json", "not valid JSON"),
    ("samples: dome", ".yaml", "a study file is .toml or .json"),
    ("[1, 2]", ".json", "must be a table"),
])
def test_unreadable_study_files_are_typed_errors(text, suffix, words, tmp_path):
    with pytest.raises(InputError) as err:
        st.load_study(_write(tmp_path / f"s{suffix}", text))
    assert err.value.input_name == "study" and words in str(err.value)
    with pytest.raises(InputError, match="no such file"):
        st.load_study(tmp_path / "absent.toml")


def test_toml_without_tomllib_or_tomli_says_what_to_do(tmp_path, monkeypatch):
    """Python 3.10 has no tomllib: with no tomli either, a TOML study is a typed error naming both ways out."""
    monkeypatch.setattr(st, "tomllib", None)
    with pytest.raises(InputError, match="pip install tomli.*JSON"):
        st.load_study(_write(tmp_path / "s.toml", 'samples = "dome"\n'))
    assert st.load_study(_write(tmp_path / "s.json", '{"samples": "dome"}')).samples == ("dome",)


def test_names_agree_with_the_samples_and_the_harness():
    from components.harness import strategy_names
    from components.surfaces.samples import SAMPLE_NAMES

    assert st.SAMPLE_NAMES == SAMPLE_NAMES
    assert tuple(st.load_study({"samples": "dome"}).strategies) == strategy_names()  # "all" by default


def test_the_example_study_is_the_issues_24_variants():
    from components.harness import default_panel_size

    path = ROOT / "examples" / "study.toml"
    study = st.load_study(path)
    surfaces = st.design_surfaces(study)
    vs = st.variants(study, surfaces)
    assert len(vs) == 24 == len({v.key for v in vs})
    assert {(v.surface, v.strategy, v.divisions) for v in vs} == {
        (s, t, d) for s in study.samples for t in study.strategies for d in study.divisions}
    from components.surfaces.samples import sample_mesh

    V, _, _ = sample_mesh("wave", study.resolution)
    wave = [v for v in vs if v.surface == "wave"]
    assert [v.panel_size for v in wave[:3]] == [default_panel_size(V, d) for d in study.divisions]


def test_cache_keys_follow_the_content_and_nothing_else():
    base = st.variant_key("a" * 64, "translation", 2.0, 10.0)
    assert base == st.variant_key("a" * 64, "translation", 2.0, 10)  # the same number, another type
    assert len({base, st.variant_key("b" * 64, "translation", 2.0, 10.0),
                st.variant_key("a" * 64, "subdivision", 2.0, 10.0), st.variant_key("a" * 64, "translation", 2.5, 10.0),
                st.variant_key("a" * 64, "translation", 2.0, 20.0)}) == 5


# ----------------------------------------------------------------------------------------------
# the task: errors are rows


def test_a_typed_error_of_a_variant_is_a_row_not_a_crash():
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 1, 0]])
    T = np.array([[0, 1, 2], [1, 3, 2]])
    out = st.run_variant({"strategy": "translation", "panel_size": 0.5, "time_budget": 1.0}, (V, T))
    row = out["row"]
    assert row["status"] == "failed" and row["error"].startswith("MeshError: surface:")
    assert out["mesh"] is None and out["metrics"] is None


def test_a_failing_strategy_is_a_failed_row():
    # a closed surface (an octahedron) has no boundary for the automatic coarse net
    V = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    T = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    row = st.run_variant({"strategy": "subdivision", "panel_size": 0.5, "time_budget": 1.0}, (V, T))["row"]
    assert row["status"] == "failed" and row["error"]


# ----------------------------------------------------------------------------------------------
# the main study on the cluster


def test_the_study_runs_on_two_workers_and_loses_no_variant_to_a_killed_worker(main_run, cluster):
    table, out, seen, lost = main_run
    assert cluster.workers[0].poll() is not None  # worker 0 was killed mid-study ...
    assert len(seen) == 24  # ... after 3 of 24 results: 21 arrived after it
    assert lost  # it was running a variant then, which another worker ran again
    status = {r["key"]: r["status"] for r in table}
    assert all(status[k] != st.STATUS_NOT_RUN for k in lost)
    assert len(table) == 24 and table.not_run == 0 and table.computed == 24 and table.cached == 0
    assert table.workers == 2
    from components.harness import STATUSES

    for r in table:
        assert r["status"] in STATUSES
        if r["status"] != "failed":
            assert r["panels"] > 0 and 0 <= r["planarity_max"] < 1 and r["closeness_max"] >= 0
            assert 0 < r["coverage"] <= 1 and r["healthy"] in (True, False)
            assert 1 <= r["panel_types"] <= r["panels"]
        if r["status"] == "ok":
            assert r["healthy"] and r["planarity_max"] <= 1e-4
        if r["strategy"] == "translation" and r["panels"]:
            assert r["planarity_max"] < 1e-9  # exact PQ
    # rows in the study's order: surface, strategy, panel size
    assert [(r["surface"], r["strategy"], r["divisions"]) for r in table] == [
        (s, t, d) for s in STUDY["samples"] for t in STRATEGIES for d in STUDY["divisions"]]
    # more panels at finer divisions, per surface and strategy
    for i in range(0, 24, 3):
        p = table["panels"][i:i + 3]
        assert p[0] < p[2], table.rows[i:i + 3]


def test_every_finished_variant_is_in_the_cache_with_its_mesh(main_run):
    table, out, _, _ = main_run
    entries = sorted((out / "cache").glob("??/*.json"))
    assert {p.stem for p in entries} == set(table["key"])
    assert not list((out / "cache").rglob(".tmp-*"))  # every write was atomic and finished
    i = next(i for i, r in enumerate(table) if r["status"] != "failed")
    V, F = table.mesh(i)
    assert len(F) == table[i]["panels"] and np.isfinite(V).all()


def test_csv_and_json_hold_the_table(main_run):
    table, out, _, _ = main_run
    with open(out / "study.csv", newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == list(st.COLUMNS) and len(rows) == 24
    for r, t in zip(rows, table):
        assert r["id"] == t["id"] and r["status"] == t["status"]
        assert float(r["panel_size"]) == t["panel_size"]  # exact round trip
        if t["planarity_max"] is not None:
            assert float(r["planarity_max"]) == t["planarity_max"]
    doc = json.loads((out / "study.json").read_text())
    assert doc["columns"] == list(st.COLUMNS) and len(doc["rows"]) == 24 and doc["computed"] == 24
    assert doc["rows"][0]["metrics"]["faces"] == table[0]["panels"]
    assert doc["study"]["divisions"] == STUDY["divisions"]


def test_a_rerun_comes_from_the_cache_without_a_cluster(main_run):
    table, out, _, _ = main_run
    again = st.run(STUDY, cluster=UNREACHABLE, out=out, progress=False)  # would fail if it had to connect
    assert again.computed == 0 and again.cached == 24 and again.timings["cluster"] == 0.0
    strip = lambda rows: [{k: v for k, v in r.items() if k != "cached"} for r in rows]  # noqa: E731
    assert strip(again.rows) == strip(table.rows)


def test_an_unreachable_cluster_is_a_typed_error(tmp_path, monkeypatch):
    monkeypatch.setattr(st, "CONNECT_TIMEOUT", 1.0)
    with pytest.raises(InputError) as err:
        st.run({"samples": "dome", "strategies": "translation", "divisions": 4, "resolution": 8},
               cluster=UNREACHABLE, out=None, cache=tmp_path / "c", progress=False)
    assert err.value.input_name == "cluster" and "--workers" in str(err.value)


def test_an_extended_study_computes_only_the_new_variants_locally(main_run):
    """Locally (a LocalCluster of two processes): one more panel size runs 4 variants, the 12 others of the
    translation strategy come from the cache."""
    table, out, _, _ = main_run
    extended = dict(STUDY, divisions=[4, 6, 8, 5], strategies=["translation"])
    local = st.run(extended, workers=2, out=None, cache=out / "cache", progress=False)
    assert len(local) == 16 and local.computed == 4 and local.cached == 12 and local.not_run == 0
    assert local.workers == 2
    new = [r for r in local if r["divisions"] == 5]
    assert len(new) == 4 and not any(r["cached"] for r in new)
    old = {r["key"]: r for r in table}
    assert all(r["panels"] == old[r["key"]]["panels"] for r in local if r["cached"])
    for r in new:  # 5 across: a panel size between those of 4 and 6 across
        size = {x["divisions"]: x["panel_size"] for x in local
                if (x["surface"], x["strategy"]) == (r["surface"], r["strategy"])}
        assert size[4] > r["panel_size"] > size[6] and r["panel_size"] == pytest.approx(size[4] * 4 / 5)


def test_an_interrupted_study_keeps_what_finished(cluster, tmp_path):
    mesh = tmp_path / "tri_dome.obj"
    mesh.write_text(data_file("geometrylab_test_tri_dome.obj").read_text())
    spec = {"samples": ["dome", "saddle"], "meshes": [str(mesh)], "strategies": "translation",
            "divisions": [4, 6], "resolution": 10}
    done = []

    def stop_after_two(row):
        done.append(row)
        if len(done) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        st.run(spec, cluster=cluster.address, out=None, cache=tmp_path / "cache", progress=False,
               callback=stop_after_two)
    kept = len(list((tmp_path / "cache").glob("??/*.json")))
    assert kept >= 2
    rest = st.run(spec, cluster=cluster.address, out=tmp_path / "out", cache=tmp_path / "cache", progress=False)
    assert len(rest) == 6 and rest.cached == kept and rest.computed == 6 - kept
    assert [r["surface"] for r in rest][-2:] == ["tri_dome", "tri_dome"]
    # a damaged entry (e.g. edited by hand) counts as missing: only that variant runs again
    entry = tmp_path / "cache" / rest[0]["key"][:2] / f"{rest[0]['key']}.json"
    entry.write_text(entry.read_text()[:40])
    again = st.run(spec, cluster=cluster.address, out=None, cache=tmp_path / "cache", progress=False)
    assert again.computed == 1 and again.cached == 5 and again[0]["panels"] == rest[0]["panels"]


# ----------------------------------------------------------------------------------------------
# command line and report


def test_command_line_runs_a_study_file(main_run, cluster, tmp_path, capsys):
    table, out, _, _ = main_run
    toml = ["samples = " + json.dumps(STUDY["samples"]), "strategies = " + json.dumps(STRATEGIES),
            f"divisions = {STUDY['divisions']}", "resolution = 12", "time_budget = 5"]
    path = _write(tmp_path / "study.toml", "\n".join(toml) + "\n")
    code = cli.main(["study", str(path), "--cluster", cluster.address, "--out", str(tmp_path / "o"),
                     "--cache", str(out / "cache"), "--quiet"])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "24 variants" in text and "0 computed, 24 from the cache" in text
    assert (tmp_path / "o" / "study.html").is_file()
    code = cli.main(["study", str(tmp_path / "nope.toml")])
    assert code == 2 and "study: " in capsys.readouterr().err


def test_the_report_opens_in_chromium_without_console_errors(main_run, tmp_path_factory):
    from tests.browser import CHROMIUM, SKIP_REASON, Browser, evaluate, load

    if CHROMIUM is None:
        pytest.skip(SKIP_REASON)
    table, out, _, _ = main_run
    with Browser(tmp_path_factory.mktemp("chromium_profile")) as b:
        page, problems, state = load(b.base, (out / "study.html").resolve().as_uri())
        try:
            assert not problems, "\n".join(problems)
            state = json.loads(state)
            assert state["title"] == "PQ study: test study" and state["mode"] == "CSS1Compat"
            assert state["images"] == []  # self-contained: the charts are inline SVG
            shape = evaluate(page, "[document.querySelectorAll('figure svg').length,"
                                   " document.querySelectorAll('tbody tr').length,"
                                   " document.querySelectorAll('figure svg title').length]")
        finally:
            page.ws.close()
    measured = sum(1 for r in table if r["panels"])
    assert shape[0] == len(CHARTS) == 4
    assert shape[1] == 24
    assert shape[2] >= measured  # a tooltip per plotted variant


def test_scatter_svg_axes():
    from ghserver.study_report import scatter_svg

    pts = [{"x": 10, "y": 1e-6, "marker": "square", "color": "#000", "filled": False, "tip": "a<b"},
           {"x": 1000, "y": 2e-3, "marker": "star", "color": "#000", "filled": True, "tip": "b"},
           {"x": 100, "y": 0.0, "marker": "diamond", "color": "#000", "filled": True, "tip": "c"}]
    svg = scatter_svg(pts, "t", "panels", "planarity", ylog=True)
    assert svg.startswith("<svg") and svg.endswith("</svg>")
    assert "a&lt;b" in svg and "1 zero value(s) not shown" in svg and "panels (log scale)" in svg
    assert svg.count("<title>") == 2 and "nan" not in svg.lower()
    for label in ("1e-06", "1e-05", "0.0001", "0.001"):  # a tick per decade
        assert f">{label}</text>" in svg
    flat = scatter_svg([dict(p, y=1.0) for p in pts[:1]], "t", "panels", "coverage")  # one point, one value
    assert "nan" not in flat.lower() and flat.count("<title>") == 1

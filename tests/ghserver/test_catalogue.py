"""The catalogue page and the component pages (``ghserver.catalogue``): markup rendered and escaped, the full Hops
URL with a copy button, inputs with defaults/ranges/choices, examples that really solve; Hops still gets its JSON.
The last tests open both pages in headless Chromium (skipped when none is installed)."""
from __future__ import annotations

import json
import re
import shlex
from pathlib import Path
from typing import NamedTuple

import pytest

from components.core.types import Mesh
from ghserver import catalogue as cat
from ghserver.app import Config, create_app
from ghserver.endpoints import build_registry
from ghserver.registry import Registry, declare
from tests.browser import CHROMIUM, SKIP_REASON, Browser, evaluate, load, screenshot

BROWSER = "text/html,application/xhtml+xml,application/xml;q=0.9,*/*;q=0.8"  # what Chromium sends
HOST = {"Host": "127.0.0.1:5000"}


@pytest.fixture(scope="module")
def registry():
    return build_registry()


@pytest.fixture(scope="module")
def client(registry):
    return create_app(Config(cache_size=0), registry=registry).test_client()


# ----------------------------------------------------------------------------------------------
# markup → HTML


def test_inline_html_renders_markup_and_escapes_everything_else():
    assert cat.inline_html("``x < y`` & :func:`a.b.c` *e* **s** <script>") == (
        "<code>x &lt; y</code> &amp; <code>c</code> <em>e</em> <strong>s</strong> &lt;script&gt;")
    assert cat.inline_html("2 * 3 * 4") == "2 * 3 * 4"


def test_doc_html_paragraphs_and_lists():
    text = "First line\nsecond line.\n\n* item ``a``\n* item b\n  continued\n\nLast <p>."
    assert cat.doc_html(text) == ("<p>First line second line.</p><ul><li>item <code>a</code></li>"
                                  "<li>item b continued</li></ul><p>Last &lt;p&gt;.</p>")


class EvilResult(NamedTuple):
    out: float


def evil(mesh: Mesh, label: str = "</code><script>alert(1)</script>") -> EvilResult:
    """Do <script>alert("x")</script> with ``<b>`` & *more*.

    Parameters
    ----------
    mesh : Mesh
        A mesh <img src=x onerror=alert(1)>.
    label : str
        A label ``"<i>"``.

    Returns
    -------
    out : float
        Result <svg onload=alert(1)>.
    """
    return EvilResult(0.0)


def test_pages_escape_docstrings_and_defaults():
    app = create_app(Config(cache_size=0), registry=Registry([declare(evil, "t/evil")]))
    c = app.test_client()
    for url in ("/", "/t/evil", "/doc/t/evil"):
        page = c.get(url, headers={"Accept": BROWSER, **HOST}).get_data(as_text=True)
        assert "<script>alert" not in page and "<img" not in page and "<svg" not in page and "<i>" not in page
        assert "&lt;script&gt;alert" in page and "<code>&lt;b&gt;</code> &amp; <em>more</em>" in page
        assert page.count("<script>") == 1  # the page's own copy handler only
    meta = c.get("/t/evil").json
    assert meta["Description"] == 'Do <script>alert("x")</script> with <b> & more.'  # JSON: plain text, no markup


# ----------------------------------------------------------------------------------------------
# routes: Hops keeps its JSON, browsers get pages


@pytest.mark.parametrize("headers", [{}, {"Accept": "*/*"}, {"Accept": "application/json"},
                                     {"Accept": "application/json, text/html"}, {"Accept": "text/html;q=0.5, */*"}])
def test_hops_and_scripts_get_the_metadata_json(client, registry, headers):
    for uri in ("metrics/planarity", "planarize/planarize"):
        r = client.get("/" + uri, headers=headers)
        assert r.status_code == 200 and r.mimetype == "application/json"
        assert r.json == registry.get(uri).metadata()
    r = client.get("/", headers=headers)
    assert r.mimetype == "application/json" and r.json == registry.catalogue()


def test_browser_gets_pages_and_format_json_gets_the_metadata(client, registry):
    r = client.get("/metrics/planarity", headers={"Accept": BROWSER, **HOST})
    assert r.status_code == 200 and r.mimetype == "text/html" and "Accept" in r.headers["Vary"]
    assert r.get_data() == client.get("/doc/metrics/planarity", headers=HOST).get_data()
    r = client.get("/metrics/planarity?format=json", headers={"Accept": BROWSER})
    assert r.mimetype == "application/json" and r.json == registry.get("metrics/planarity").metadata()
    r = client.get("/doc/no/such", headers={"Accept": BROWSER})
    assert r.status_code == 404 and r.mimetype == "text/html" and 'href="/"' in r.get_data(as_text=True)
    r = client.get("/no/such", headers={"Accept": BROWSER})  # unknown component: still Hops' JSON 404
    assert r.status_code == 404 and r.mimetype == "application/json" and r.json["Inputs"] == []


def test_catalogue_page_has_the_full_url_and_a_copy_button_per_component(client, registry):
    page = client.get("/", headers={"Accept": BROWSER, **HOST}).get_data(as_text=True)
    urls = re.findall(r'<button type="button" class="copy" data-copy="([^"]+)"', page)
    assert urls == [f"http://127.0.0.1:5000/{c.uri}" for c in registry]
    assert "http://127.0.0.1:5000/planarize/planarize</code>" in page
    assert all(f'href="/doc/{c.uri}"' in page for c in registry)
    assert "``" not in page and ":func:" not in page  # markup rendered
    assert "<code>(V, F)</code>" in page
    # inputs show their defaults, ranges and choices
    assert "(= 10.0, range [0, 180])" in page  # fabrication/kinks limit
    assert '(= &quot;diagonal&quot;, one of &quot;diagonal&quot;, &quot;angle&quot;, &quot;warping&quot;)' in page
    # the address follows the request (another port, a proxy's name)
    other = client.get("/", headers={"Accept": BROWSER, "Host": "localhost:8123"}).get_data(as_text=True)
    assert 'data-copy="http://localhost:8123/metrics/planarity"' in other


def test_component_page_lists_inputs_outputs_and_examples(client, registry):
    comp = registry.get("planarize/planarize")
    page = client.get("/doc/planarize/planarize", headers=HOST).get_data(as_text=True)
    assert 'data-copy="http://127.0.0.1:5000/planarize/planarize"' in page
    assert 'href="/#planarize/planarize"' in page  # back to the catalogue
    rows = re.findall(r"<tr><td><b>([^<]+)</b>", page)
    assert rows == [p.name for p in comp.inputs] + [p.name for p in comp.outputs]
    tol = next(p for p in comp.inputs if p.name == "tolerance")
    assert re.search(rf"<td><b>tolerance</b></td><td>Number</td><td>item</td><td><code>{tol.default!r}</code></td>"
                     r"<td>\[0, ∞\]</td>", page)
    assert '<code>&quot;free&quot;</code> <code>&quot;fixed&quot;</code> <code>&quot;slide&quot;</code>' in page
    assert "<td><b>mesh</b> <span class=\"kind\">(M)</span></td><td>Mesh</td><td>item</td><td><b>required</b>" in page
    assert "curl -X POST http://127.0.0.1:5000/planarize/planarize" in page
    assert "client.call(&#x27;planarize/planarize&#x27;, mesh=(V, F))" in page


CHEAP = ["metrics/planarity", "fabrication/kinks", "surfaces/translation", "surfaces/surface_mesh",
         "surfaces/paraboloid", "fields/remesh", "planarize/on_surface"]


@pytest.mark.parametrize("uri", CHEAP)
def test_curl_example_solves(client, registry, uri):
    """The page's curl command, parsed as a shell would, posts a body that solves (every kind of required
    input: meshes, curves, a surface, numbers; and none)."""
    cmd = shlex.split(cat.curl_command(registry.get(uri), "http://127.0.0.1:5000/"))
    assert cmd[:3] == ["curl", "-X", "POST"] and cmd[3] == f"http://127.0.0.1:5000/{uri}"
    body = cmd[cmd.index("-d") + 1]
    required = [p.name for p in registry.get(uri).inputs if not (p.has_default or p.optional)]
    assert [t["ParamName"] for t in json.loads(body)["values"]] == required
    r = client.post("/" + uri, data=body, headers={"Content-Type": "application/json"})
    assert r.status_code == 200 and not r.json.get("errors"), r.json
    assert [t["ParamName"] for t in r.json["values"]] == [p.name for p in registry.get(uri).outputs]


@pytest.mark.parametrize("uri", ["metrics/planarity", "surfaces/surface_mesh", "surfaces/translation"])
def test_python_example_runs_against_a_live_server(registry, uri):
    from tests.ghserver.conftest import LiveServer

    with LiveServer(create_app(Config(cache_size=0), registry=registry)) as srv:
        code = cat.python_snippet(registry.get(uri), srv.url + "/")
        assert f'Client({srv.url!r})' in code
        scope: dict = {}
        exec(compile(code.replace("print(", "result = ("), f"<{uri} example>", "exec"), scope)
    first = registry.get(uri).outputs[0].name
    assert type(scope["res"]).__name__ == uri.rsplit("/", 1)[-1] and scope["result"] is getattr(scope["res"], first)


def test_list_verbose_prints_defaults_ranges_and_choices(capsys):
    from ghserver.cli import main

    assert main(["list", "-v"]) == 0
    out = capsys.readouterr().out
    kinks = out[out.index("/fabrication/kinks"):out.index("/fabrication/nodes")]
    assert re.search(r"in: +mesh +Mesh item, required: The panelling \(V, F\)", kinks)
    assert re.search(r"limit +Number item, = 10.0, range \[0, 180\]: Largest kink \(degrees\)", kinks)
    assert re.search(r"out: +kinks +Number list: Kink angle", kinks)
    assert re.search(r'measure +Text item, = "diagonal", one of "diagonal", "angle", "warping": ', out)
    assert "``" not in out and ":func:" not in out


# ----------------------------------------------------------------------------------------------
# in a real browser

SHOTS = Path("/tmp/shots")

COPY_CHECK = """(async () => {
  const b = document.querySelector('section#%s button.copy');
  const url = b.dataset.copy;
  let readBack = null;
  b.click();
  for (let i = 0; i < 50 && !b.dataset.copied; i++) await new Promise(r => setTimeout(r, 20));
  try { readBack = await navigator.clipboard.readText(); } catch (e) { readBack = 'blocked: ' + e.name; }
  return {url, text: document.querySelector('section#%s code.full-url').textContent, copied: b.dataset.copied || null,
          label: b.textContent, readBack, buttons: document.querySelectorAll('button.copy').length};
})()"""


FALLBACK_CHECK = """(async () => {
  Object.defineProperty(window, 'isSecureContext', {value: false});
  document.execCommand = () => false;
  const b = document.querySelector('.url button.copy');
  b.click();
  for (let i = 0; i < 50 && !b.dataset.copied; i++) await new Promise(r => setTimeout(r, 20));
  return {label: b.textContent, selected: window.getSelection().toString()};
})()"""


@pytest.mark.skipif(CHROMIUM is None, reason=SKIP_REASON)
def test_pages_in_chromium(tmp_path, registry):
    from tests.ghserver.conftest import LiveServer

    SHOTS.mkdir(parents=True, exist_ok=True)
    with LiveServer(create_app(Config(cache_size=0), registry=registry)) as srv, Browser(tmp_path / "profile") as b:
        page, problems, state = load(b.base, srv.url + "/")
        try:
            assert problems == [] and json.loads(state)["title"] == "PQ mesh components"
            try:  # a focused page with clipboard permission, as a user's click gives it
                page.call("Emulation.setFocusEmulationEnabled", enabled=True)
                page.call("Browser.grantPermissions", origin=srv.url,
                          permissions=["clipboardReadWrite", "clipboardSanitizedWrite"])
                granted = True
            except RuntimeError:  # an older Chromium: only check that the handler ran
                granted = False
            sel = "planarize\\\\/planarize"
            res = evaluate(page, COPY_CHECK % (sel, sel))
            assert res["url"] == res["text"] == f"{srv.url}/planarize/planarize"
            assert res["buttons"] == len(registry)
            assert res["copied"] in ("yes", "no") and res["label"] in ("Copied", "Select and copy")  # handler ran
            if granted:
                assert res["copied"] == "yes" and res["label"] == "Copied" and res["readBack"] == res["url"]
            assert evaluate(page, "(async () => { await new Promise(r => setTimeout(r, 2100)); "
                                  "return document.querySelector('button.copy').textContent; })()") == "Copy"
            screenshot(page, SHOTS / "catalogue.png")
        finally:
            page.ws.close()
        # the browser's own Accept on the Hops path gives the component's page
        page, problems, state = load(b.base, srv.url + "/planarize/planarize")
        try:
            assert problems == [] and json.loads(state)["title"].startswith("/planarize/planarize")
            info = evaluate(page, "({rows: document.querySelectorAll('tbody tr').length, "
                                  "url: document.querySelector('code.full-url').textContent, "
                                  "back: document.querySelector('nav a').getAttribute('href'), "
                                  "curl: document.getElementById('curl').textContent.slice(0, 40)})")
            comp = registry.get("planarize/planarize")
            assert info == {"rows": len(comp.inputs) + len(comp.outputs), "url": f"{srv.url}/planarize/planarize",
                            "back": "/#planarize/planarize", "curl": f"curl -X POST {srv.url}/planarize/pl"[:40]}
            screenshot(page, SHOTS / "component.png")
            # where the clipboard is refused (plain http to another host), the button selects the URL instead
            fallback = evaluate(page, FALLBACK_CHECK)
            assert fallback == {"label": "Select and copy", "selected": f"{srv.url}/planarize/planarize"}
        finally:
            page.ws.close()

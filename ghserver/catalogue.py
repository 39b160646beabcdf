"""The human side of the server: the catalogue page (``GET /`` from a browser) and one page per component
(``GET /<component>`` from a browser, or ``GET /doc/<component>``).

Hops and scripts keep getting JSON: a page is answered only when the request prefers ``text/html`` to
``application/json`` (a browser's ``Accept``; Hops sends none, ``requests``/``urllib`` send ``*/*``), and
``?format=json`` asks for the JSON from a browser too. Docstring markup is rendered here only (````x```` →
``<code>x</code>``, ``:func:`a.b``` → ``<code>b</code>``, ``*x*`` → ``<em>x</em>``, paragraphs and ``*``/``-``
lists), every piece of text HTML-escaped; the metadata JSON carries plain text (:func:`ghserver.registry.plain_text`).
"""
from __future__ import annotations

import html
import json
import math
import shlex
from functools import lru_cache
from pathlib import Path

import numpy as np
from flask import Blueprint, Response, current_app, request

from components.core.mesh import quad_grid
from components.core.types import NurbsSurface
from ghserver import convert
from ghserver import params as P
from ghserver.registry import (Component, Param, Registry, first_sentence, inline_markup, input_summary, range_text,
                               value_text)

bp = Blueprint("catalogue", __name__)

_TAGS = {"code": "code", "emph": "em", "strong": "strong"}


# ----------------------------------------------------------------------------------------------
# docstring markup → HTML


def inline_html(text: str) -> str:
    """One paragraph of docstring text as HTML: inline markup rendered, everything else escaped.

    >>> inline_html('The mesh ``(V, F)`` <b> & :func:`components.metrics.health.face_health`, *not* 2 * 3.')
    'The mesh <code>(V, F)</code> &lt;b&gt; &amp; <code>face_health</code>, <em>not</em> 2 * 3.'
    """
    out = []
    for kind, run in inline_markup(text):
        run = html.escape(run, quote=False)
        out.append(run if kind == "text" else f"<{_TAGS[kind]}>{run}</{_TAGS[kind]}>")
    return "".join(out)


def doc_html(text: str) -> str:
    """Docstring text as HTML: blank-line separated paragraphs (``<p>``), runs of ``* `` / ``- `` lines as lists.

    >>> doc_html("First *paragraph*\\ncontinued.\\n\\n* one ``1``\\n* two\\n  wrapped")
    '<p>First <em>paragraph</em> continued.</p><ul><li>one <code>1</code></li><li>two wrapped</li></ul>'
    """
    parts = []
    for block in text.strip().split("\n\n"):
        lines = [line.rstrip() for line in block.strip("\n").splitlines() if line.strip()]
        if not lines:
            continue
        if lines[0].lstrip().startswith(("* ", "- ")):
            items: list[list[str]] = []
            for line in lines:
                s = line.strip()
                if s.startswith(("* ", "- ")) and len(line) - len(line.lstrip()) <= 1:
                    items.append([s[2:]])
                elif items:
                    items[-1].append(s)
            parts.append("<ul>" + "".join(f"<li>{inline_html(' '.join(i))}</li>" for i in items) + "</ul>")
        else:
            parts.append(f"<p>{inline_html(' '.join(line.strip() for line in lines))}</p>")
    return "".join(parts)


# ----------------------------------------------------------------------------------------------
# request helpers


def wants_html() -> bool:
    """Whether the current request is a browser's: it prefers ``text/html`` to JSON and did not ask for
    ``?format=json``."""
    if request.args.get("format", "").lower() == "json":
        return False
    accept = request.accept_mimetypes
    best = accept.best_match(["application/json", "text/html"])
    return best == "text/html" and accept["text/html"] > accept["application/json"]


def base_url() -> str:
    """``scheme://host:port/`` of the current request (the address the client used, e.g. the Hops path's)."""
    return request.host_url


def _registry() -> Registry:
    return current_app.extensions["ghserver.registry"]


def _report_path() -> Path | None:
    folder = current_app.extensions["ghserver.config"].report_dir
    if not folder:
        return None
    path = Path(folder) / "report.html"
    return path if path.is_file() else None


def _json(obj, status: int = 200) -> Response:  # the same bytes as ghserver.app.json_response
    return Response(json.dumps(obj, ensure_ascii=False, allow_nan=False), status=status, mimetype="application/json",
                    headers={"Vary": "Accept"})


def _page(text: str, status: int = 200) -> Response:
    return Response(text, status=status, mimetype="text/html", headers={"Vary": "Accept"})


@bp.get("/")
def catalogue():
    """``GET /``: the catalogue page for a browser, else the JSON array of every component's metadata."""
    reg = _registry()
    if wants_html():
        return _page(catalogue_html(reg, has_report=_report_path() is not None, base=base_url()))
    return _json(reg.catalogue())


@bp.get("/doc/<path:uri>")
def doc(uri: str):
    """``GET /doc/<component>``: the component's page (whatever the ``Accept``)."""
    comp = _registry().get(uri)
    if comp is None:
        return _page(not_found_html(uri, base_url()), 404)
    return component_page(comp)


def component_page(comp: Component) -> Response:
    """The component's page as a response (``GET /<component>`` from a browser, ``GET /doc/<component>``)."""
    return _page(component_html(comp, base_url(), has_report=_report_path() is not None,
                                api_key=bool(current_app.extensions["ghserver.config"].api_key)))


# ----------------------------------------------------------------------------------------------
# examples: a minimal solve body (curl) and a Python client call


def _example_mesh() -> tuple[np.ndarray, np.ndarray]:
    """4 × 4 quads on [-1, 1]² lifted onto an elliptic paraboloid: a translation surface, so every quad is planar,
    and not umbilic (the curvature-network components need distinct principal curvatures)."""
    V, F = quad_grid(4, 4, 2.0, 2.0)
    V[:, :2] -= 1.0
    V[:, 2] = -0.15 * V[:, 0] ** 2 - 0.05 * V[:, 1] ** 2
    return V, F


_MESH_SETUP = ["V, F = quad_grid(4, 4, 2.0, 2.0)  # 4 x 4 planar quads on a paraboloid over [-1, 1]^2",
               "V[:, :2] -= 1.0", "V[:, 2] = -0.15 * V[:, 0] ** 2 - 0.05 * V[:, 1] ** 2"]
_CURVES = {  # polylines (a Curve input takes a NURBS curve or a polyline)
    0: "[[-1.0, 0.0, 0.0], [0.0, 0.0, 0.3], [1.0, 0.0, 0.0]]",
    1: "[[0.0, -1.0, 0.0], [0.0, 0.0, 0.2], [0.0, 1.0, 0.0]]",
}
_SURFACE_SETUP = ["surface = NurbsSurface(1, 1, np.array([[[-1.0, -1, 0], [-1, 1, 0]], [[1, -1, 0], [1, 1, 0.5]]]),",
                  "                       np.ones((2, 2)), np.array([0.0, 1.0]), np.array([0.0, 1.0]))"]


def _example_number(p: Param) -> float:
    lo, hi = p.minimum, p.maximum
    x = 0.5  # a quarter of the example mesh's width: a panel size, a target edge length
    if lo is not None and x < lo:
        x = lo + 1.0
    if hi is not None and x > hi:
        x = hi
    return float(x)


def example_inputs(comp: Component) -> list[tuple[Param, dict, str]]:
    """``(param, JSON item, Python expression)`` for every input a solve needs (no default, not optional)."""
    out = []
    curves = 0
    for p in comp.inputs:
        if p.has_default or p.optional:
            continue
        if p.kind == "Mesh":
            item, expr = {"type": "Rhino.Geometry.Mesh", "data": _encoded("Mesh")}, "(V, F)"
        elif p.kind == "Surface":
            item, expr = {"type": "Rhino.Geometry.NurbsSurface", "data": _encoded("Surface")}, "surface"
        elif p.kind == "Curve":
            pts = _CURVES[curves % 2]
            curves += 1
            item, expr = P.encode_item("Curve", np.array(json.loads(pts))), f"np.array({pts})"
        elif p.kind == "Number":
            x = _example_number(p)
            item, expr = P.encode_item("Number", x), repr(x)
        elif p.kind == "Integer":
            n = max(4, int(math.ceil(p.minimum)) if p.minimum is not None else 4)
            item, expr = P.encode_item("Integer", n), repr(n)
        elif p.kind == "Boolean":
            item, expr = P.encode_item("Boolean", False), "False"
        elif p.kind == "Text":
            t = p.choices[0] if p.choices else "text"
            item, expr = P.encode_item("Text", t), repr(t)
        elif p.kind in ("Point", "Vector"):
            v = [0.0, 0.0, 0.0] if p.kind == "Point" else [0.0, 0.0, 1.0]
            item, expr = P.encode_item(p.kind, v), f"np.array({v})"
        elif p.kind == "Line":
            item, expr = P.encode_item("Line", [[0.0, 0, 0], [1.0, 0, 0]]), "np.array([[0.0, 0, 0], [1.0, 0, 0]])"
        else:  # Plane
            frame = [[0.0, 0, 0], [1.0, 0, 0], [0.0, 1, 0], [0.0, 0, 1]]
            item, expr = P.encode_item("Plane", [np.array(a) for a in frame]), f"[np.array(a) for a in {frame}]"
        if p.access != "item":
            expr = f"[{expr}]"
        out.append((p, item, expr))
    return out


@lru_cache(maxsize=None)
def _encoded(kind: str) -> str:
    if kind == "Mesh":
        return convert.encode_mesh(*_example_mesh())
    pts = np.array([[[-1.0, -1, 0], [-1, 1, 0]], [[1, -1, 0], [1, 1, 0.5]]])
    return convert.encode_surface(NurbsSurface(1, 1, pts, np.ones((2, 2)), np.array([0.0, 1.0]), np.array([0.0, 1.0])))


def example_body(comp: Component) -> dict:
    """A minimal solve body for ``POST /<component>``: the inputs without a default, one item each."""
    return {"values": [{"ParamName": p.name, "InnerTree": {"{0}": [item]}} for p, item, _ in example_inputs(comp)]}


def curl_command(comp: Component, base: str, api_key: bool = False) -> str:
    body = json.dumps(example_body(comp), ensure_ascii=False)
    key = " -H 'RhinoComputeKey: YOUR_KEY'" if api_key else ""
    return (f"curl -X POST {shlex.quote(base.rstrip('/') + '/' + comp.uri)} "
            f"-H 'Content-Type: application/json'{key} -d {shlex.quote(body)}")


def python_snippet(comp: Component, base: str, api_key: bool = False) -> str:
    ins = example_inputs(comp)
    kinds = {p.kind for p, _, _ in ins}
    lines = []
    if kinds & {"Curve", "Point", "Vector", "Line", "Plane", "Surface", "Mesh"}:
        lines.append("import numpy as np")
    if "Mesh" in kinds:
        lines.append("from components.core.mesh import quad_grid")
    if "Surface" in kinds:
        lines.append("from components.core.types import NurbsSurface")
    lines.append("from ghserver.client import Client")
    lines.append("")
    if "Mesh" in kinds:
        lines += _MESH_SETUP
    if "Surface" in kinds:
        lines += _SURFACE_SETUP
    key = ', api_key="YOUR_KEY"' if api_key else ""
    lines.append(f"client = Client({base.rstrip('/')!r}{key})")
    args = ", ".join(f"{p.name}={expr}" for p, _, expr in ins)
    lines.append(f"res = client.call({comp.uri!r}{', ' if args else ''}{args})")
    if comp.outputs:
        lines.append(f"print(res.{comp.outputs[0].name})")
    return "\n".join(lines)


# ----------------------------------------------------------------------------------------------
# pages

_STYLE = """
body{font-family:system-ui,sans-serif;max-width:64rem;margin:2rem auto;padding:0 1rem;color:#222;line-height:1.4}
section{border-top:1px solid #ddd;padding:.5rem 0} .io{display:flex;gap:2rem} .io>div{flex:1;min-width:0}
code{background:#f4f4f4;padding:0 .2em;border-radius:2px} li{margin:.2rem 0} .kind{color:#666}
.url{display:flex;align-items:center;gap:.5rem;margin:.3rem 0} .url code{font-size:.95em}
button.copy{font:inherit;font-size:.85em;padding:.1rem .6rem;cursor:pointer;border:1px solid #999;border-radius:4px;
 background:#fff} button.copy:hover{background:#eef}
h2 a{text-decoration:none} nav{color:#555} .toc dt{font-weight:600;margin-top:.3rem} .toc dd{margin:0 0 0 1rem}
table{border-collapse:collapse;width:100%;margin:.5rem 0} th,td{border-bottom:1px solid #e4e4e4;text-align:left;
 vertical-align:top;padding:.25rem .5rem} th{background:#fafafa} td p{margin:0 0 .3rem}
pre{background:#f6f6f6;border:1px solid #e0e0e0;padding:.6rem;white-space:pre-wrap;word-break:break-all;
 max-height:16rem;overflow:auto;font-size:.85em}
.snippet{position:relative} .snippet pre{padding-right:5.5rem} .snippet button.copy{position:absolute;top:.3rem;right:.3rem}
"""

# one click handler for every copy button: the clipboard API where the page may use it (https, localhost),
# else a selected textarea and execCommand; the button says what happened
_SCRIPT = """
function copyText(text){
  if(navigator.clipboard&&window.isSecureContext){return navigator.clipboard.writeText(text).then(()=>true,()=>legacyCopy(text));}
  return Promise.resolve(legacyCopy(text));
}
function legacyCopy(text){
  const t=document.createElement('textarea');t.value=text;t.setAttribute('readonly','');
  t.style.position='fixed';t.style.opacity='0';document.body.appendChild(t);t.select();
  let ok=false;try{ok=document.execCommand('copy');}catch(e){ok=false;}
  t.remove();return ok;
}
document.addEventListener('click',function(ev){
  const b=ev.target.closest('button.copy');if(!b)return;
  const text=b.dataset.copy!==undefined?b.dataset.copy:document.getElementById(b.dataset.copyFrom).textContent;
  copyText(text).then(function(ok){
    b.dataset.copied=ok?'yes':'no';b.textContent=ok?'Copied':'Select and copy';
    if(!ok){const r=document.createRange();const el=b.parentElement.querySelector('code,pre');
      if(el){r.selectNodeContents(el);const s=window.getSelection();s.removeAllRanges();s.addRange(r);}}
    setTimeout(function(){b.textContent='Copy';},2000);
  });
});
"""


def _head(title: str) -> str:
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1"><link rel="icon" href="data:,">'
            f"<title>{html.escape(title)}</title>"
            f"<style>{_STYLE}</style></head><body>\n")


def _tail() -> str:
    return f"<script>{_SCRIPT}</script>\n</body></html>"


def _url_line(url: str) -> str:
    e = html.escape
    return (f'<div class="url"><code class="full-url">{e(url)}</code>'
            f'<button type="button" class="copy" data-copy="{e(url)}" title="Copy the Hops path">Copy</button></div>')


def _param_li(p: Param, is_input: bool) -> str:
    e = html.escape
    extra = f" <span class=\"kind\">({e(input_summary(p))})</span>" if is_input else ""
    return (f'<li><b>{e(p.name)}</b> <span class="kind">{e(p.kind)} {e(p.access)}</span>{extra}: '
            f'{inline_html(first_sentence(p.doc) if p.doc else p.description)}</li>')


def catalogue_html(registry: Registry, has_report: bool = False, base: str = "http://127.0.0.1:5000/") -> str:
    """The catalogue page: every component with its full Hops path (and a copy button), description, inputs and
    outputs, linking to its own page."""
    e = html.escape
    base = base.rstrip("/") + "/"
    rows = []
    groups: dict[str, list[Component]] = {}
    for c in registry:
        groups.setdefault(c.subcategory or c.uri.split("/")[0], []).append(c)
        ins = "".join(_param_li(p, True) for p in c.inputs)
        outs = "".join(_param_li(p, False) for p in c.outputs)
        rows.append(
            f'<section id="{e(c.uri)}"><h2><a href="/doc/{e(c.uri)}"><code>/{e(c.uri)}</code></a></h2>'
            f"{_url_line(base + c.uri)}{doc_html(c.doc or c.description)}"
            f'<div class="io"><div><h3>Inputs</h3><ul>{ins}</ul></div>'
            f"<div><h3>Outputs</h3><ul>{outs}</ul></div></div>"
            f'<p><a href="/doc/{e(c.uri)}">Details, types and examples of /{e(c.uri)}</a></p></section>'
        )
    report = ('<p><a href="/report/">Comparison report</a> of all strategies on the built-in surfaces.</p>'
              if has_report else
              "<p>No comparison report yet: run <code>ghserver demo</code> (or <code>ghserver report</code>) in "
              'the folder the server was started from, and it appears at <a href="/report/">/report/</a>.</p>')
    toc = "".join(f"<dt>{e(g)}</dt><dd>" + " · ".join(f'<a href="#{e(c.uri)}">{e(c.uri.rsplit("/", 1)[-1])}</a>'
                                                       for c in cs) + "</dd>" for g, cs in groups.items())
    example = e(base + "metrics/planarity")
    return (_head("PQ mesh components") + "<h1>Planar-quad meshing components</h1>"
            f"<p>{len(registry)} component{'' if len(registry) == 1 else 's'}. In Grasshopper, place a <b>Hops</b> component and set its path to the "
            f"component's full URL, e.g. <code>{example}</code> (the <b>Copy</b> buttons copy it). "
            f"<code>GET /&lt;component&gt;</code> answers Hops with its metadata as JSON; from a browser it shows the "
            f"component's page.</p>{report}<dl class=\"toc\">{toc}</dl>{''.join(rows)}" + _tail())


def _input_row(p: Param) -> str:
    e = html.escape
    if p.has_default and p.default is not None:
        default = f"<code>{e(value_text(p.default))}</code>"
    else:
        default = "optional" if p.optional else "<b>required</b>"
    limits = []
    if range_text(p):
        limits.append(e(range_text(p)))
    if p.choices:
        limits.append(" ".join(f"<code>{e(json.dumps(c))}</code>" for c in p.choices))
    nick = f' <span class="kind">({e(p.nickname)})</span>' if p.nickname and p.nickname != p.name else ""
    return (f"<tr><td><b>{e(p.name)}</b>{nick}</td><td>{e(p.kind)}</td><td>{e(p.access)}</td><td>{default}</td>"
            f"<td>{'<br>'.join(limits)}</td><td>{doc_html(p.doc or p.description)}</td></tr>")


def _output_row(p: Param) -> str:
    e = html.escape
    nick = f' <span class="kind">({e(p.nickname)})</span>' if p.nickname and p.nickname != p.name else ""
    return (f"<tr><td><b>{e(p.name)}</b>{nick}</td><td>{e(p.kind)}</td><td>{e(p.access)}</td>"
            f"<td>{doc_html(p.doc or p.description)}</td></tr>")


def _snippet(ident: str, text: str) -> str:
    return (f'<div class="snippet"><pre id="{ident}">{html.escape(text)}</pre>'
            f'<button type="button" class="copy" data-copy-from="{ident}">Copy</button></div>')


def component_html(comp: Component, base: str = "http://127.0.0.1:5000/", has_report: bool = False,
                   api_key: bool = False) -> str:
    """A component's page: description, full URL with a copy button, inputs (type, access, default, range or
    choices), outputs, notes, a curl and a Python example, links back to the catalogue."""
    e = html.escape
    base = base.rstrip("/") + "/"
    ins = "".join(_input_row(p) for p in comp.inputs)
    outs = "".join(_output_row(p) for p in comp.outputs)
    notes = f"<h2>Notes</h2>{doc_html(comp.notes)}" if comp.notes else ""
    needed = [p.name for p, _, _ in example_inputs(comp)]
    what = (f"the input{'s' if len(needed) > 1 else ''} without a default ({', '.join(needed)}; the others take "
            f"their defaults)" if needed else "no inputs (every input takes its default)")
    key_note = ("<p>This server requires an API key on solves: replace <code>YOUR_KEY</code>.</p>"
                if api_key else "")
    warn = (" It also answers a <code>warnings</code> list." if comp.warnings_field else "")
    back = f'<nav><a href="/#{e(comp.uri)}">← All components</a>' + (
        ' · <a href="/report/">Comparison report</a>' if has_report else "") + "</nav>"
    return (_head(f"/{comp.uri} — PQ mesh components") + back +
            f"<h1><code>/{e(comp.uri)}</code></h1>{_url_line(base + comp.uri)}"
            f'<div class="description">{doc_html(comp.doc or comp.description)}</div>'
            f"<p class=\"kind\">Python: <code>{e(comp.function.__module__)}.{e(comp.function.__name__)}</code> · "
            f"Grasshopper subcategory {e(comp.subcategory)} · "
            f'<a href="/{e(comp.uri)}?format=json">metadata JSON</a> (what Hops reads)</p>'
            f"<h2>Inputs</h2><table><thead><tr><th>name</th><th>type</th><th>access</th><th>default</th>"
            f"<th>range / choices</th><th>description</th></tr></thead><tbody>{ins}</tbody></table>"
            f"<h2>Outputs</h2><table><thead><tr><th>name</th><th>type</th><th>access</th><th>description</th>"
            f"</tr></thead><tbody>{outs}</tbody></table>{notes}"
            f"<h2>Example</h2><p>Solve it by posting a JSON body to <code>/{e(comp.uri)}</code> (or to "
            f"<code>/solve</code> with <code>\"pointer\": \"{e(comp.uri)}\"</code>, as Hops does); this body has "
            f"{e(what)}. The mesh is a 4 × 4 grid of planar quads. The answer is "
            f"<code>{{\"values\": [...]}}</code>, one data tree per output.{warn}</p>{key_note}"
            f"<h3>curl</h3>{_snippet('curl', curl_command(comp, base, api_key))}"
            f"<h3>Python (<code>ghserver.client</code>)</h3>{_snippet('python', python_snippet(comp, base, api_key))}"
            f'<p><a href="/#{e(comp.uri)}">← All components</a></p>' + _tail())


def not_found_html(uri: str, base: str) -> str:
    e = html.escape
    return (_head("Unknown component") + f"<h1>Unknown component <code>/{e(uri.strip('/'))}</code></h1>"
            f'<p>See the <a href="/">catalogue</a> of every component served at <code>{e(base)}</code>.</p>'
            + _tail())

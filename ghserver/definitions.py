"""The Grasshopper definitions shipped in ``gh_definitions/``, generated from the component registry.

Each :class:`Spec` names the components of one definition by URI and how they chain; everything else (the Hops
parameters, their names, kinds, access and descriptions, the sliders' ranges and defaults) is derived from the
registry's metadata, so a definition can never disagree with the server: ``tests/ghserver/test_ghx.py``
regenerates every shipped file and compares.

How an input of a step is fed (first rule that applies):

1. an explicit entry in ``Step.feeds`` (``"slider"``, ``"panel"``, ``"param"``, ``"none"`` or
   ``("<step id>", "<output name>")``);
2. the upstream step (``Step.after``): its output with the same name and kind, else (for a Mesh input) its first
   Mesh output;
3. optional inputs (``X | None = None`` on the server) stay unconnected;
4. geometry inputs (Mesh, Curve, Surface, Point, …) get a floating parameter shared by every step of the
   definition that has an input of the same kind and name (set it from Rhino: *Set one Mesh*…);
5. Number / Integer items get a slider: default and range from :data:`SLIDERS` (in metres for lengths: the range
   covers real use and stays inside what the server accepts), else the server's default with the declared
   minimum/maximum (else a range around the default); an input without a server default needs an entry in
   :data:`SLIDERS` (``tests/ghserver/test_definition_walk.py`` checks the shipped files). Text / Boolean items
   get a panel holding the default;
6. anything else (lists without a source) stays unconnected: Hops sends the server's default.

A spec whose required components are not in the registry yet is skipped and reported by
:func:`write_definitions`; the set fills in as components land. ``python -m ghserver.definitions [--out DIR]``.
"""
from __future__ import annotations

import argparse
import fnmatch
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, NamedTuple

from ghserver import ghx

log = logging.getLogger(__name__)

SERVER_URL = "http://127.0.0.1:5000"
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "gh_definitions"
GEOMETRY_KINDS = ("Point", "Vector", "Plane", "Line", "Curve", "Surface", "Mesh")

# Custom Preview colours ("R,G,B" text in a panel, converted by Grasshopper to a material)
COLOURS = {
    "orange": "230,120,40",
    "teal": "40,160,160",
    "violet": "140,90,200",
    "green": "90,170,70",
    "red": "210,60,60",
    "grey": "170,170,170",
}


@dataclass(frozen=True)
class Step:
    """One Hops component of a definition.

    Parameters
    ----------
    id : str
        Unique name of the step in its spec (seeds GUIDs; referenced by ``after`` and ``feeds``).
    uri : str or tuple of str
        Component URI; a tuple lists alternatives, each exact or a glob (``"planarize/*"``): the first that
        matches a registered URI wins.
    after : str, optional
        Upstream step whose outputs feed this step's inputs (by name, then the first Mesh output).
    feeds : mapping
        Explicit feeding per input name (see the module docstring).
    lane : int
        Row of the canvas the step is drawn in (steps of a lane run left to right).
    preview : str, optional
        Name of a colour in :data:`COLOURS`: the step's Mesh outputs get a Custom Preview in that colour.
    coloured : bool
        The step's Mesh outputs carry vertex colours (analysis meshes): they get a Mesh parameter named
        "coloured preview", which Grasshopper draws with the mesh's own colours.
    show : {"items", "all", "none"}
        Which outputs get a panel: item outputs only, also lists, or none.
    optional : bool
        Skip the step (instead of the whole definition) when no registered URI matches.
    every : bool
        Expand into one optional step per matching URI not used by another step of the spec.
    label : str
        Group label on the canvas (default: the URI).
    """

    id: str
    uri: str | tuple[str, ...]
    after: str | None = None
    feeds: Mapping[str, Any] = field(default_factory=dict)
    lane: int = 0
    preview: str | None = None
    coloured: bool = False
    show: str = "items"
    optional: bool = False
    every: bool = False
    label: str = ""

    @property
    def patterns(self) -> tuple[str, ...]:
        return (self.uri,) if isinstance(self.uri, str) else tuple(self.uri)


@dataclass(frozen=True)
class Spec:
    """A definition file: its name, what it shows and its steps."""

    filename: str
    title: str
    description: str
    steps: tuple[Step, ...]


class MissingComponents(LookupError):
    """A spec names components the registry does not have (yet)."""

    def __init__(self, filename: str, missing: list[str]):
        self.filename, self.missing = filename, missing
        super().__init__(f"{filename}: missing component(s) {', '.join(missing)}")


class Report(NamedTuple):
    written: list[Path]
    missing: dict[str, list[str]]  # filename -> URIs (patterns) not in the registry


# ----------------------------------------------------------------------------------------------
# sliders


class Slider(NamedTuple):
    """Default and range of the slider feeding an input (``default`` None: the server's default)."""

    default: float | None
    minimum: float
    maximum: float


# By input name, or by ``(URI, input name)`` where one name means different things. Lengths are in metres (the
# model's units in Rhino); every range stays inside the server's declared range and the function's checks, so a
# slider can only send values the server accepts (``conical/offset`` ``distance`` excepted: 0 is refused, and a
# slider across 0 is the only way to reach both sides).
SLIDERS: dict[str | tuple[str, str], Slider] = {
    # lengths, metres
    "target_length": Slider(1.5, 0.25, 10.0),
    "panel_size": Slider(1.5, 0.25, 10.0),
    ("network/pq_from_curvature_network", "offset"): Slider(0.0, -1.0, 1.0),
    ("conical/offset", "distance"): Slider(0.2, -1.0, 1.0),
    "sheet_width": Slider(0.0, 0.0, 6.0),  # 0: one sheet about as wide as high
    "sheet_height": Slider(0.0, 0.0, 6.0),  # 0: unlimited
    "gap": Slider(0.01, 0.0, 0.2),
    ("fabrication/panel_types", "tolerance"): Slider(0.0, 0.0, 0.05),  # 0: the document's tolerance
    "beam_height": Slider(0.0, 0.0, 1.0),  # 0: 0.2 x the mean edge
    "beam_width": Slider(0.0, 0.0, 0.3),  # 0: 0.05 x the mean edge
    # scale-free tolerances, weights, budgets
    "tolerance": Slider(None, 1e-6, 0.01),  # scale-free planarity (subdivision/pq_from_subdivision fails at 0)
    ("metrics/panel_health", "tolerance"): Slider(None, 0.0, 0.05),
    "time_budget": Slider(None, 1.0, 80.0),  # seconds; the server stops a solve at 90 s, Hops waits 100 s
    "closeness_weight": Slider(None, 0.0, 100.0),
    "fairness_weight": Slider(None, 0.0, 1.0),
    "alignment": Slider(None, 0.0, 1.0),
    "smoothness": Slider(None, 0.01, 10.0),
    "umbilic_threshold": Slider(None, 0.0, 0.5),  # must stay below 1
    "threshold": Slider(None, 0.0, 2.0),
    "flat_tolerance": Slider(None, 0.0, 0.5),
    "scale": Slider(None, 0.5, 1.5),  # per step of the directrix: 1.5 ** 10 is already 58
    "min_angle": Slider(None, 0.0, 80.0),
    # counts
    "iterations": Slider(None, 1, 200),
    "max_iterations": Slider(None, 1, 1000),
    "radius": Slider(None, 1, 5),
    "count_u": Slider(None, 1, 100),
    "count_v": Slider(None, 1, 100),
    "faces": Slider(None, 4, 200),
    "levels": Slider(None, 0, 4),
    ("subdivision/pq_from_subdivision", "levels"): Slider(None, 0, 3),  # 4 levels of 36 faces: over 40 s
    "max_faces": Slider(None, 1000, 5_000_000),
}


def slider_of(uri: str, p: dict) -> Slider | None:
    """The :data:`SLIDERS` entry of input ``p`` of component ``uri`` (the ``(uri, name)`` entry first)."""
    return SLIDERS.get((uri, p["Name"]), SLIDERS.get(p["Name"]))


# ----------------------------------------------------------------------------------------------
# the shipped definitions

PLANARITY = "metrics/planarity"
TRANSLATION = "surfaces/translation"
SCALE_TRANSLATION = "surfaces/scale_translation"
ANALYSIS = ("metrics/analysis",)
EVERY_PER_LANE = 4  # steps expanded from ``every`` wrap onto a new lane after this many


def _measured(step_id: str, output: str, lane: int) -> Step:
    """A planarity component measuring ``output`` of ``step_id``."""
    return Step(f"{step_id}_{output}_planarity", PLANARITY, feeds={"mesh": (step_id, output)}, lane=lane,
                label=f"planarity of {output}")


SPECS: tuple[Spec, ...] = (
    Spec(
        "metrics_analysis.ghx",
        "Mesh quality analysis",
        "One mesh parameter feeding every metrics component of the server; panels show the summaries, the "
        "analysis component's coloured mesh previews the per-face values.",
        (
            Step("planarity", PLANARITY, show="all", label="planarity (per face and summary)"),
            Step("analysis", ANALYSIS, optional=True, coloured=True, lane=1, label="coloured analysis"),
            Step("metrics", "metrics/*", every=True, show="items", lane=2),
        ),
    ),
    Spec(
        "translation_surfaces.ghx",
        "Translation and scale-translation surfaces",
        "Generatrix and directrix curves (set them from Rhino) swept into a translation surface (top) and a "
        "scale-translation surface (bottom); both quad meshes are planar by construction, the planarity panels "
        "prove it.",
        (
            Step("translation", TRANSLATION, lane=0, preview="orange"),
            Step("translation_planarity", PLANARITY, after="translation", lane=0),
            Step("scale_translation", SCALE_TRANSLATION, lane=1, preview="teal"),
            Step("scale_translation_planarity", PLANARITY, after="scale_translation", lane=1),
        ),
    ),
    Spec(
        "conjugate_field.ghx",
        "Conjugate direction field → quad mesh → planarization",
        "The conjugate direction field of the design surface mesh (top, as short lines), the quad mesh extracted "
        "along it and its planarized version (bottom), with planarity before and after.",
        (
            Step("field", "fields/conjugate_field", lane=0),
            Step("pq", "fields/pq_from_conjugate_field", lane=1, preview="violet"),
            _measured("pq", "candidate", 2),
            _measured("pq", "planarized", 2),
        ),
    ),
    Spec(
        "curvature_network_conical.ghx",
        "Principal curvature network, conformal map, conical mesh and offset",
        "Principal curvature lines of the design surface mesh (top) and its conformal map (second row); the quad "
        "mesh rebuilt from the curvature network, optimized into a conical mesh (third row), its conical analysis "
        "and its constant-distance face offset with the node axes (bottom).",
        (
            Step("network", "network/curvature_network", lane=0),
            Step("conformal", "parametrize/conformal_map", lane=1),
            Step("pq", "network/pq_from_curvature_network", lane=2, preview="green"),
            Step("conical", "conical/analysis", feeds={"mesh": ("pq", "optimized")}, lane=3),
            Step("offset", "conical/offset", feeds={"mesh": ("pq", "optimized")}, lane=3, preview="teal"),
        ),
    ),
    Spec(
        "subdivision.ghx",
        "Singularities, coarse net, subdivision and planarization",
        "Curvature regions and suggested singularities of the design surface (top), an automatic coarse quad net "
        "(second row), then Catmull-Clark subdivision pulled onto the surface and planarized (third row), with "
        "planarity before and after; the bottom row shows the same steps one by one for a coarse net of your own.",
        (
            Step("singularities", "subdivision/singularity_analysis", lane=0),
            Step("coarse", "subdivision/coarse_mesh", lane=1, preview="orange"),
            Step("pq", "subdivision/pq_from_subdivision", feeds={"coarse": ("coarse", "coarse")}, lane=2,
                 preview="red"),
            _measured("pq", "candidate", 3),
            _measured("pq", "planarized", 3),
            Step("subdivide", "subdivision/catmull_clark", lane=4),
            Step("pull", "subdivision/pull_to_surface", after="subdivide", lane=4),
            Step("planarize", "planarize/on_surface", after="pull", lane=4, preview="violet"),
        ),
    ),
    Spec(
        "fabrication.ghx",
        "From a conical mesh to fabrication",
        "The curvature-network strategy makes a conical planar-quad mesh of the design surface (top); its panels "
        "laid flat on sheets with labels and dimensions, their panel types at a tolerance with the count at four "
        "tolerances, the kink angle at every joint, and the node axes with torsion-free beams (the offset axes of "
        "the conical mesh).",
        (
            Step("pq", "network/pq_from_curvature_network", lane=0, preview="green"),
            Step("panels", "fabrication/panels", feeds={"mesh": ("pq", "optimized")}, lane=1),
            Step("types", "fabrication/panel_types", feeds={"mesh": ("pq", "optimized")}, lane=1, show="all"),
            Step("kinks", "fabrication/kinks", feeds={"mesh": ("pq", "optimized")}, lane=2),
            Step("nodes", "fabrication/nodes", feeds={"mesh": ("pq", "optimized")}, lane=2, preview="grey"),
        ),
    ),
    Spec(
        "comparison.ghx",
        "All strategies side by side",
        "Every strategy of the server on the same design surface, one lane each (translation and "
        "scale-translation surfaces from two curves, conjugate field, curvature network with conical "
        "optimization, subdivision), every result measured by the same planarity component.",
        (
            Step("translation", TRANSLATION, lane=0, preview="orange"),
            Step("translation_planarity", PLANARITY, after="translation", lane=0),
            Step("scale_translation", SCALE_TRANSLATION, lane=1, preview="teal"),
            Step("scale_translation_planarity", PLANARITY, after="scale_translation", lane=1),
            Step("conjugate", "fields/pq_from_conjugate_field", lane=2, preview="violet"),
            _measured("conjugate", "planarized", 2),
            Step("network", "network/pq_from_curvature_network", lane=3, preview="green"),
            _measured("network", "optimized", 3),
            Step("subdivision", "subdivision/pq_from_subdivision", lane=4, preview="red"),
            _measured("subdivision", "planarized", 4),
        ),
    ),
)


# ----------------------------------------------------------------------------------------------
# resolution


def _match(patterns: tuple[str, ...], uris: list[str]) -> list[str]:
    for pat in patterns:
        if any(ch in pat for ch in "*?["):
            hits = [u for u in uris if fnmatch.fnmatchcase(u, pat)]
            if hits:
                return hits
        elif pat in uris:
            return [pat]
    return []


def resolve(spec: Spec, registry) -> list[tuple[Step, Any]]:
    """The steps of ``spec`` with their registry components, optional and ``every`` steps expanded.

    Raises
    ------
    MissingComponents
        When a required step matches no registered URI (lists every missing one).
    """
    uris = sorted(c.uri for c in registry)
    missing, resolved, used = [], [], set()
    for step in spec.steps:
        if step.every:
            continue
        hits = _match(step.patterns, uris)
        if not hits:
            if not step.optional:
                missing.append(" | ".join(step.patterns))
            continue
        resolved.append((step, registry.get(hits[0])))
        used.add(hits[0])
    if missing:
        raise MissingComponents(spec.filename, list(dict.fromkeys(missing)))
    out = []
    for step in spec.steps:
        if step.every:
            fresh = [u for u in _match(step.patterns, uris) if u not in used]
            for k, uri in enumerate(fresh):
                used.add(uri)
                lane = step.lane + k // EVERY_PER_LANE
                out.append((Step(f"{step.id}/{uri}", uri, step.after, step.feeds, lane, step.preview, step.coloured,
                                 step.show, True, False, uri), registry.get(uri)))
        else:
            out.extend((s, c) for s, c in resolved if s is step)
    present = {s.id for s, _ in out}
    for s, _ in out:
        if s.after and s.after not in present:
            raise MissingComponents(spec.filename, [f"upstream step {s.after!r} of {s.id!r}"])
    return out


def url_of(uri: str, server: str = SERVER_URL) -> str:
    return f"{server.rstrip('/')}/{uri.strip('/')}"


# ----------------------------------------------------------------------------------------------
# building

_COLUMN_SOURCES = 230.0  # width of the column of sliders/panels left of a Hops component
_GAP = 40.0


def _slider_spec(p: dict, uri: str = "") -> tuple[float, float, float, bool, int]:
    """``(value, minimum, maximum, integer, digits)`` of the slider feeding input ``p`` of ``uri``.

    Raises
    ------
    ValueError
        The :data:`SLIDERS` entry leaves the declared range or its default leaves its own range.
    """
    integer = p["ParamType"] == "Integer"
    d = p.get("Default")
    lo, hi = p.get("Minimum"), p.get("Maximum")
    chosen = slider_of(uri, p)
    if chosen is not None:
        where = f"slider of {uri} {p['Name']}"
        if chosen.default is not None:
            d = chosen.default
        if (lo is not None and chosen.minimum < lo) or (hi is not None and chosen.maximum > hi):
            raise ValueError(f"{where}: [{chosen.minimum}, {chosen.maximum}] leaves the declared range [{lo}, {hi}]")
        lo, hi = chosen.minimum, chosen.maximum
        if not isinstance(d, (int, float)) or isinstance(d, bool) or not lo <= d <= hi:
            raise ValueError(f"{where}: default {d!r} outside [{lo}, {hi}]")
    if not isinstance(d, (int, float)) or isinstance(d, bool):
        d = lo if lo is not None else 0  # no default: give the input an entry in SLIDERS (the walk test checks)
    d = float(d)
    if lo is None:
        lo = 0.0 if d >= 0 else -2.0 * abs(d)
    if hi is None:
        hi = max(2.0 * abs(d), lo + (10.0 if integer else 1.0))
    lo, hi = float(lo), float(hi)
    if integer:
        lo, hi = math.floor(lo), math.ceil(hi)
    d = min(max(d, lo), hi)
    digits = 0 if integer else 3
    if not integer and d != 0:
        digits = min(8, max(3, 2 - math.floor(math.log10(abs(d)))))
    return d, lo, hi, integer, digits


def _default_text(p: dict) -> str:
    d = p.get("Default")
    if d is None:
        return ""
    if isinstance(d, bool):
        return "true" if d else "false"
    return str(d)


class _Builder:
    def __init__(self, spec: Spec, server: str):
        self.spec = spec
        self.server = server
        self.doc = ghx.Document(spec.filename, f"{spec.title}. {spec.description}")
        self.shared: dict[tuple[str, str], ghx.Placed] = {}
        self.hops: dict[str, ghx.Placed] = {}
        self.meta: dict[str, dict] = {}
        self.shared_y = 0.0

    def shared_param(self, kind: str, name: str) -> ghx.Source:
        key = (kind, name)
        if key not in self.shared:
            p = self.doc.add_param(kind, f"shared/{kind}/{name}", label=name, at=(0.0, self.shared_y))
            self.shared_y += 44.0
            self.shared[key] = p
        return self.shared[key].out(0)

    def upstream(self, step: Step, p: dict) -> ghx.Source | None:
        if not step.after:
            return None
        up, meta = self.hops[step.after], self.meta[step.after]
        kinds = {o["Name"]: o["ParamType"] for o in meta["Outputs"]}
        if kinds.get(p["Name"]) == p["ParamType"]:
            return up.out(p["Name"])
        if p["ParamType"] == "Mesh":
            for o in meta["Outputs"]:
                if o["ParamType"] == "Mesh":
                    return up.out(o["Name"])
        return None

    def add_step(self, step: Step, comp, x: float, y: float) -> tuple[float, float]:
        """Place ``step`` with its local sources at ``(x, y)``; returns the block's (width, height)."""
        meta = comp.metadata()
        url = url_of(comp.uri, self.server)
        sources: dict[str, ghx.Source] = {}
        members: list[ghx.Placed] = []
        sy = y
        for p in meta["Inputs"]:
            name, kind = p["Name"], p["ParamType"]
            how = step.feeds.get(name)
            access = ghx.access_of(p)
            role = f"{step.id}/src/{name}"
            if isinstance(how, tuple):
                src_step, out_name = how
                sources[name] = self.hops[src_step].out(out_name)
                continue
            if how is None:
                up = self.upstream(step, p)
                if up is not None:
                    sources[name] = up
                    continue
                if p.get("AtLeast", 1) == 0:
                    continue
                if kind in GEOMETRY_KINDS:
                    how = "param"
                elif access == "item" and kind in ("Number", "Integer"):
                    how = "slider"
                elif access == "item" and kind in ("Text", "Boolean"):
                    how = "panel"
                else:
                    continue
            if how == "none":
                continue
            if how == "param":
                sources[name] = self.shared_param(kind, name)
            elif how == "slider":
                value, lo, hi, integer, digits = _slider_spec(p, comp.uri)
                s = self.doc.add_slider(role, name, value, lo, hi, integer=integer, digits=digits, at=(x, sy))
                sources[name] = s.out(0)
                members.append(s)
                sy += 28.0
            elif how == "panel":
                s = self.doc.add_panel(role, _default_text(p), label=name, at=(x, sy), size=(200.0, 24.0),
                                       colour=(255, 255, 255, 255))
                sources[name] = s.out(0)
                members.append(s)
                sy += 32.0
            else:
                raise ValueError(f"{self.spec.filename}: step {step.id!r} input {name!r}: unknown feed {how!r}")
        hx = x + (_COLUMN_SOURCES if members else 0.0)
        h = self.doc.add_hops(f"{step.id}/hops", url, meta, sources=sources, at=(hx, y), nickname=comp.name)
        self.hops[step.id], self.meta[step.id] = h, meta
        members.append(h)
        ox = hx + h.bounds[2] + _GAP
        oy = y
        widest = 0.0
        for o in meta["Outputs"]:
            kind, lst = o["ParamType"], o.get("Access") == "list"
            role = f"{step.id}/show/{o['Name']}"
            if kind == "Mesh" and (step.preview or step.coloured):
                if step.coloured:
                    m = self.doc.add_param("Mesh", role, label="coloured preview", source=h.out(o["Name"]),
                                           at=(ox, oy))
                    members.append(m)
                    oy += 32.0
                else:
                    colour = self.doc.add_panel(f"{role}/colour", COLOURS[step.preview], label="colour",
                                                at=(ox, oy), size=(90.0, 24.0), colour=(255, 255, 255, 255))
                    prev = self.doc.add_preview(role, h.out(o["Name"]), colour.out(0), at=(ox + 110.0, oy))
                    members += [colour, prev]
                    oy += 52.0
                widest = max(widest, 180.0)
                continue
            if kind in GEOMETRY_KINDS or step.show == "none" or (lst and step.show != "all"):
                continue
            size = (160.0, 100.0) if lst else (160.0, 24.0)
            panel = self.doc.add_panel(role, "", label=o["Name"], source=h.out(o["Name"]), at=(ox, oy), size=size)
            members.append(panel)
            oy += size[1] + 8.0
            widest = max(widest, size[0])
        self.doc.add_group(f"{step.id}/group", step.label or comp.uri, members)
        height = max(sy - y, h.bounds[3], oy - y)
        return (ox - x) + widest, height


def build(spec: Spec, registry, server: str = SERVER_URL) -> ghx.Document:
    """The :class:`ghserver.ghx.Document` of ``spec`` with the components of ``registry``.

    Raises
    ------
    MissingComponents
        When a required component is not registered.
    """
    steps = resolve(spec, registry)
    b = _Builder(spec, server)
    # shared parameters first (left column): create them in input order so their layout is stable
    lanes: dict[int, list] = {}
    for step, comp in steps:
        lanes.setdefault(step.lane, []).append((step, comp))
    y = 0.0
    x0 = 200.0
    for lane in sorted(lanes):
        x, lane_h = x0, 0.0
        for step, comp in lanes[lane]:
            w, h = b.add_step(step, comp, x, y)
            x += w + 2 * _GAP
            lane_h = max(lane_h, h)
        y += lane_h + 80.0
    return b.doc


def render(spec: Spec, registry, server: str = SERVER_URL) -> str:
    """The ``.ghx`` text of ``spec``."""
    return build(spec, registry, server).to_ghx()


def write_definitions(out_dir: str | Path = DEFAULT_OUT, registry=None, server: str = SERVER_URL,
                      specs: tuple[Spec, ...] = SPECS) -> Report:
    """(Re)write every definition whose components exist; report the others.

    Parameters
    ----------
    out_dir : path
        Folder of the ``.ghx`` files (created if needed).
    registry : Registry, optional
        Default: :func:`ghserver.endpoints.build_registry`.
    server : str
        Base URL the Hops components point at.

    Returns
    -------
    Report
        ``written`` paths and ``missing`` ``{filename: [URIs]}`` of the skipped definitions.
    """
    if registry is None:
        from ghserver.endpoints import build_registry

        registry = build_registry()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written, missing = [], {}
    for spec in specs:
        try:
            doc = build(spec, registry, server)
        except MissingComponents as exc:
            missing[spec.filename] = exc.missing
            log.info("%s", exc)
            continue
        path = out / spec.filename
        ghx.save_ghx(doc.to_chunk(), path)
        written.append(path)
    return Report(written, missing)


def main(argv: list[str] | None = None) -> int:
    """``python -m ghserver.definitions [--out DIR] [--server URL]``: regenerate the shipped definitions."""
    ap = argparse.ArgumentParser(prog="python -m ghserver.definitions", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(DEFAULT_OUT), help="output folder (default: gh_definitions/)")
    ap.add_argument("--server", default=SERVER_URL, help=f"server base URL (default: {SERVER_URL})")
    args = ap.parse_args(argv)
    report = write_definitions(args.out, server=args.server)
    for p in report.written:
        print(f"wrote {p}")
    for name, uris in report.missing.items():
        print(f"skipped {name}: missing {', '.join(uris)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Components: a function from ``components/`` plus a short declaration.

Everything Hops needs to know about a component is derived from the function itself:

* the **name** is the function's name (for a published component also its URI's last part), the **description**
  the first paragraph of its docstring as plain text (inline markup such as ````x```` or ``:func:`a.b``` dropped:
  Hops shows it verbatim in tooltips; :func:`plain_text`); the raw text is kept for the HTML pages;
* the **inputs** are its parameters in signature order, their kinds from the annotations (see
  :mod:`components.core.types`), their defaults from the signature (falsy ones included), their descriptions from the
  docstring's Parameters section; ``X | None = None`` is an optional input;
* the **outputs** are the fields of the returned ``NamedTuple``, described in the docstring's Returns section.

A disagreement between signature, docstring and return type raises :class:`RegistrationError` when the
declaration is made, i.e. at import of :mod:`ghserver.endpoints`.
"""
from __future__ import annotations

import inspect
import json
import re
import types
import typing
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from components.core import types as ct

# Grasshopper TypeName of every kind we support (hops-protocol.md §1.3)
KINDS = ("Number", "Integer", "Boolean", "Text", "Point", "Vector", "Plane", "Line", "Curve", "Surface", "Mesh")
OUTPUT_KINDS = tuple(k for k in KINDS if k != "Surface")
INT_MAX = 2147483647


class RegistrationError(TypeError):
    """A component's signature, docstring and return type disagree, or a kind is unsupported."""


@dataclass(frozen=True)
class Param:
    """One input or output of a component."""

    name: str
    kind: str  # Grasshopper TypeName, one of KINDS
    access: str = "item"  # "item", "list" or "tree"
    description: str = ""
    nickname: str = ""
    optional: bool = False
    has_default: bool = False
    default: Any = None
    minimum: float | None = None
    maximum: float | None = None
    doc: str = ""  # the docstring's whole description of the param, with its markup (for the HTML pages)
    choices: tuple = ()  # the values a Text input accepts, when its docstring lists them as ``"a"`` or ``"b"``

    def input_schema(self) -> dict:
        """The InputParamSchema Hops reads (hops-protocol.md §1.2)."""
        d = {
            "Name": self.name,
            "Nickname": self.nickname or self.name,
            "Description": self.description or self.name,
            "ParamType": self.kind,
            "ResultType": self.kind,
            "Access": self.access,
        }
        if self.access == "tree":
            d.update(AtLeast=0 if self.optional else 1, AtMost=INT_MAX, TreeAccess=True)
        elif self.access == "list":
            d.update(AtLeast=0 if self.optional else 1, AtMost=INT_MAX, TreeAccess=False)
        else:
            d.update(AtLeast=0 if self.optional else 1, AtMost=1, TreeAccess=False)
        if self.has_default and self.default is not None:
            d["Default"] = _default_json(self.default)
        if self.minimum is not None:
            d["Minimum"] = self.minimum
        if self.maximum is not None:
            d["Maximum"] = self.maximum
        return d

    def output_schema(self) -> dict:
        return {
            "Name": self.name,
            "Nickname": self.nickname or self.name,
            "Description": self.description or self.name,
            "ParamType": self.kind,
            "ResultType": self.kind,
            "Access": self.access,
        }


def value_text(value) -> str:
    """A default value as JSON text (``0.001``, ``"diagonal"``, ``false``, ``[0.0, 1.0]``)."""
    return json.dumps(_default_json(value), ensure_ascii=False)


def range_text(p: Param) -> str:
    """``[lo, hi]`` of a Number/Integer input (``−∞``/``∞`` for an open end), ``""`` when it has none."""
    if p.minimum is None and p.maximum is None:
        return ""
    lo = "−∞" if p.minimum is None else f"{p.minimum:g}"
    hi = "∞" if p.maximum is None else f"{p.maximum:g}"
    return f"[{lo}, {hi}]"


def input_summary(p: Param) -> str:
    """Default, range and choices of an input as plain text: ``= 0.001, range [0, ∞]``, ``= "free", one of
    "free", "fixed"``, ``required`` (a solve needs it) or ``optional``."""
    if p.has_default and p.default is not None:
        parts = [f"= {value_text(p.default)}"]
    else:
        parts = ["optional" if p.optional else "required"]
    if range_text(p):
        parts.append(f"range {range_text(p)}")
    if p.choices:
        parts.append("one of " + ", ".join(value_text(c) for c in p.choices))
    return ", ".join(parts)


def _default_json(value):
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (tuple, list, np.ndarray)):
        arr = np.asarray(value).tolist()
        return arr
    return value


@dataclass
class Component:
    """A published component: the function, its URI and the derived metadata."""

    uri: str
    function: Callable
    name: str
    description: str
    inputs: list[Param]
    outputs: list[Param]
    context: tuple[str, ...] = ()  # parameters filled from the request (tolerances, units)
    warnings_field: bool = False
    category: str = "PQ"
    subcategory: str = ""
    fingerprint: str = field(default="", repr=False)
    doc: str = field(default="", repr=False)  # summary paragraph with its markup (for the HTML pages)
    notes: str = field(default="", repr=False)  # the docstring's Notes section with its markup

    def metadata(self) -> dict:
        """The JSON answered to ``GET /<uri>`` (IoResponseSchema plus ghhops-style extras)."""
        return {
            "Uri": "/" + self.uri,
            "Name": self.name,
            "Nickname": self.name,
            "Description": self.description,
            "Category": self.category,
            "Subcategory": self.subcategory,
            "Icon": None,
            "InputNames": [p.name for p in self.inputs],
            "OutputNames": [p.name for p in self.outputs],
            "Inputs": [p.input_schema() for p in self.inputs],
            "Outputs": [p.output_schema() for p in self.outputs],
            "Warnings": [],
            "Errors": [],
        }


# ----------------------------------------------------------------------------------------------
# docstring parsing (numpy style)

_SECTION = re.compile(r"^\s*([A-Z][A-Za-z ]+)\n\s*-{3,}\s*$", re.M)


def _sections(doc: str) -> dict[str, str]:
    doc = inspect.cleandoc(doc or "")
    out = {}
    matches = list(_SECTION.finditer(doc))
    for i, m in enumerate(matches):
        end = matches[i + 1].start() if i + 1 < len(matches) else len(doc)
        out[m.group(1).strip()] = doc[m.end():end]
    return out


def _entries(section: str) -> list[tuple[str, str, str]]:
    """``name : type`` entries of a Parameters/Returns section with their first description sentence."""
    return [(name, typ, first_sentence(desc)) for name, typ, desc in _full_entries(section)]


def _full_entries(section: str) -> list[tuple[str, str, str]]:
    """``name : type`` entries of a Parameters/Returns section with their whole description (markup kept)."""
    entries = []
    lines = section.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.strip() and not line.startswith((" ", "\t")):
            name, _, typ = line.partition(":")
            desc_lines = []
            i += 1
            while i < len(lines) and (not lines[i].strip() or lines[i].startswith((" ", "\t"))):
                desc_lines.append(lines[i].strip())
                i += 1
            desc = " ".join(x for x in desc_lines if x)
            entries.append((name.strip(), typ.strip(), desc))
        else:
            i += 1
    return entries


_ABBREVIATIONS = ("e.g.", "i.e.", "cf.", "vs.", "etc.", "al.", "approx.", "resp.", "Fig.", "Eq.", "No.")


def first_sentence(text: str) -> str:
    """The text up to the first full stop that ends a sentence: not one of an abbreviation (``e.g.``), nor one
    inside parentheses or an inline literal (````x.y````)."""
    for m in re.finditer(r"[.!?](?=\s|$)", text):
        head = text[:m.end()]
        if head.endswith(_ABBREVIATIONS) or head.count("``") % 2 or head.count("(") > head.count(")"):
            continue
        return head.strip()
    return text.strip()


# ----------------------------------------------------------------------------------------------
# inline docstring markup (reStructuredText subset): ``literal``, :role:`target`, *emphasis*, **strong**

_INLINE = re.compile(
    r"``(?P<code>.+?)``"
    r"|:(?P<role>[a-z]+(?::[a-z]+)?):`(?P<target>[^`]+)`"
    r"|\*\*(?P<strong>[^*\s](?:[^*]*[^*\s])?)\*\*"
    r"|(?<![\w*])\*(?P<emph>[^*\s](?:[^*]*[^*\s])?)\*(?![\w*])"
    r"|(?<![\w`])`(?P<interp>[^`\s](?:[^`]*[^`\s])?)`(?![\w`])"
)


def _role_text(role: str, target: str) -> str:
    """What a cross reference shows: ``Title <target>`` → the title, ``~a.b.c`` / ``a.b.c`` → ``c`` (a module
    keeps its full dotted name), a maths role its formula."""
    target = target.strip()
    m = re.fullmatch(r"(.+?)\s*<[^<>]+>", target)
    if m:
        return m.group(1).strip()
    target = target.lstrip("~!")
    if role in ("mod", "py:mod", "math", "file", "envvar", "option", "command", "samp"):
        return target
    return target.rstrip("()").rsplit(".", 1)[-1] + ("()" if target.endswith("()") else "")


def inline_markup(text: str) -> list[tuple[str, str]]:
    """Split docstring text into ``(kind, text)`` runs: ``"text"``, ``"code"`` (````x````, `` `x` ``, a
    ``:func:`` or other role), ``"emph"`` (``*x*``) and ``"strong"`` (``**x**``).

    >>> inline_markup("The mesh ``(V, F)``, see :func:`components.metrics.health.face_health`, *not* this.")
    [('text', 'The mesh '), ('code', '(V, F)'), ('text', ', see '), ('code', 'face_health'), ('text', ', '), ('emph', 'not'), ('text', ' this.')]
    """
    runs: list[tuple[str, str]] = []
    pos = 0
    for m in _INLINE.finditer(text):
        if m.start() > pos:
            runs.append(("text", text[pos:m.start()]))
        if m.group("code") is not None:
            runs.append(("code", m.group("code")))
        elif m.group("role") is not None:
            runs.append(("code", _role_text(m.group("role"), m.group("target"))))
        elif m.group("strong") is not None:
            runs.append(("strong", m.group("strong")))
        elif m.group("emph") is not None:
            runs.append(("emph", m.group("emph")))
        else:
            runs.append(("code", m.group("interp")))
        pos = m.end()
    if pos < len(text):
        runs.append(("text", text[pos:]))
    return runs


def plain_text(text: str) -> str:
    """Docstring text as plain text, the way Hops shows it (tooltips): inline markup dropped, whitespace
    collapsed.

    >>> plain_text('The mesh ``(V, F)``; ``"face"`` or *exact* (see :func:`~a.b.conical_check`).')
    'The mesh (V, F); "face" or exact (see conical_check).'
    """
    return " ".join("".join(t for _, t in inline_markup(text)).split())


# ----------------------------------------------------------------------------------------------
# annotations → kinds

_SCALARS = {float: "Number", int: "Integer", bool: "Boolean", str: "Text"}


def _kind_of(annotation, where: str) -> tuple[str, str, bool]:
    """Return ``(kind, access, optional)`` for an annotation."""
    optional = False
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(args) != 1 or len(args) == len(typing.get_args(annotation)):
            raise RegistrationError(f"{where}: unsupported union annotation {annotation!r}")
        annotation = args[0]
        optional = True
        origin = typing.get_origin(annotation)
    if origin is typing.Annotated:
        meta = annotation.__metadata__
        if len(meta) >= 2 and meta[0] in KINDS:
            return meta[0], meta[1], optional
        raise RegistrationError(f"{where}: Annotated type without a kind marker: {annotation!r}")
    if origin is ct.Tree:
        (inner,) = typing.get_args(annotation)
        kind, _, _ = _kind_of(inner, where)
        return kind, "tree", optional
    if annotation in _SCALARS:
        return _SCALARS[annotation], "item", optional
    if annotation is ct.Plane:
        return "Plane", "item", optional
    if annotation is ct.NurbsSurface:
        return "Surface", "item", optional
    raise RegistrationError(f"{where}: cannot map annotation {annotation!r} to a Grasshopper parameter kind")


def declare(
    function: Callable,
    uri: str,
    nicknames: dict[str, str] | None = None,
    ranges: dict[str, tuple[float | None, float | None]] | None = None,
    subcategory: str = "",
) -> Component:
    """Derive a component from ``function`` and check that signature, docstring and return type agree.

    Parameters
    ----------
    function : callable
        A published component function (see :mod:`components.core.types` for the annotation rules).
    uri : str
        Path the component is served at, without the leading slash (e.g. ``"metrics/planarity"``).
    nicknames : dict, optional
        Grasshopper nicknames for inputs/outputs by name (default: the name).
    ranges : dict, optional
        ``{input name: (minimum, maximum)}`` for Number/Integer inputs; Hops checks them client-side.
    subcategory : str
        Grasshopper subcategory shown in the catalogue.

    Raises
    ------
    RegistrationError
        On any disagreement, naming the function and the parameter.
    """
    nicknames = nicknames or {}
    ranges = ranges or {}
    fname = f"{function.__module__}.{function.__qualname__}"
    uri = uri.strip("/")
    if not re.fullmatch(r"[a-z0-9_]+(/[a-z0-9_]+)*", uri):
        raise RegistrationError(f"{fname}: invalid uri {uri!r} (lowercase words separated by '/')")
    doc = function.__doc__ or ""
    summary = inspect.cleandoc(doc).split("\n\n")[0].replace("\n", " ").strip()
    if not plain_text(summary):
        raise RegistrationError(f"{fname}: missing docstring summary line")
    sections = _sections(doc)
    try:
        hints = typing.get_type_hints(function, include_extras=True)
    except Exception as exc:  # unresolved forward references
        raise RegistrationError(f"{fname}: cannot resolve annotations ({exc})") from exc
    sig = inspect.signature(function)

    context = tuple(n for n in sig.parameters if n in ct.CONTEXT_PARAMETERS)
    sig_inputs = [p for n, p in sig.parameters.items() if n not in ct.CONTEXT_PARAMETERS]
    doc_params = [e for e in _full_entries(sections.get("Parameters", "")) if e[0] not in ct.CONTEXT_PARAMETERS]
    if [p.name for p in sig_inputs] != [e[0] for e in doc_params]:
        raise RegistrationError(
            f"{fname}: docstring Parameters {[e[0] for e in doc_params]} do not match the signature "
            f"{[p.name for p in sig_inputs]}"
        )
    inputs = []
    for p, (_, _, desc) in zip(sig_inputs, doc_params):
        if p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD):
            raise RegistrationError(f"{fname}: *args/**kwargs are not allowed ({p.name})")
        if p.name not in hints:
            raise RegistrationError(f"{fname}: parameter {p.name!r} has no annotation")
        kind, access, optional = _kind_of(hints[p.name], f"{fname}({p.name})")
        has_default = p.default is not inspect.Parameter.empty
        if optional and not (has_default and p.default is None):
            raise RegistrationError(f"{fname}: optional parameter {p.name!r} must default to None")
        if has_default and p.default is not None:
            _check_default(fname, p.name, kind, access, p.default)
        lo, hi = ranges.pop(p.name, (None, None))
        inputs.append(
            Param(
                name=p.name, kind=kind, access=access, description=plain_text(first_sentence(desc)),
                nickname=nicknames.get(p.name, ""), optional=optional or (has_default and p.default is None),
                has_default=has_default, default=p.default if has_default else None, minimum=lo, maximum=hi,
                doc=desc, choices=_choices(kind, access, desc, p.default if has_default else None),
            )
        )
    if ranges:
        raise RegistrationError(f"{fname}: ranges given for unknown inputs {sorted(ranges)}")

    result_type = hints.get("return")
    if not (isinstance(result_type, type) and issubclass(result_type, tuple) and hasattr(result_type, "_fields")):
        raise RegistrationError(f"{fname}: must be annotated to return a NamedTuple, got {result_type!r}")
    fields = list(result_type._fields)
    warnings_field = "warnings" in fields
    out_fields = [f for f in fields if f != "warnings"]
    doc_returns = [e for e in _full_entries(sections.get("Returns", "")) if e[0] != "warnings"]
    if out_fields != [e[0] for e in doc_returns]:
        raise RegistrationError(
            f"{fname}: docstring Returns {[e[0] for e in doc_returns]} do not match the NamedTuple fields {out_fields}"
        )
    field_hints = typing.get_type_hints(result_type, include_extras=True)
    outputs = []
    for fname_, (_, _, desc) in zip(out_fields, doc_returns):
        kind, access, _ = _kind_of(field_hints[fname_], f"{fname} -> {fname_}")
        if kind not in OUTPUT_KINDS:
            raise RegistrationError(f"{fname}: output {fname_!r} of kind {kind} cannot be returned to Grasshopper")
        outputs.append(Param(name=fname_, kind=kind, access=access, description=plain_text(first_sentence(desc)),
                             nickname=nicknames.get(fname_, ""), doc=desc))
    names = [p.name for p in inputs] + [p.name for p in outputs]
    unknown_nick = set(nicknames) - set(names)
    if unknown_nick:
        raise RegistrationError(f"{fname}: nicknames given for unknown params {sorted(unknown_nick)}")
    notes = inspect.cleandoc(sections.get("Notes", ""))
    comp = Component(
        uri=uri, function=function, name=function.__name__, description=plain_text(summary), inputs=inputs,
        outputs=outputs, context=context, warnings_field=warnings_field, subcategory=subcategory or uri.split("/")[0],
        doc=summary, notes=notes,
    )
    comp.fingerprint = repr([(p.name, p.kind, p.access) for p in inputs + outputs])
    return comp


_LITERAL = re.compile(r'``"([^"`]*)"``')


def _choices(kind: str, access: str, doc: str, default) -> tuple:
    """The values a Text input accepts, read from its description: the quoted literals (````"a"````, ````"b"````)
    when they all look like words and the default is one of them; ``()`` when they do not (a pattern such as
    ````"verdict_<metric>"````) or the input is not a Text item."""
    if kind != "Text" or access != "item":
        return ()
    found = tuple(dict.fromkeys(_LITERAL.findall(doc)))
    if len(found) < 2 or default not in found or not all(re.fullmatch(r"[A-Za-z0-9_.+-]+", v) for v in found):
        return ()
    return found


def _check_default(fname, name, kind, access, default):
    if access != "item":
        return
    expected = {"Number": (int, float), "Integer": (int,), "Boolean": (bool,), "Text": (str,)}.get(kind)
    if expected and not isinstance(default, expected):
        raise RegistrationError(f"{fname}: default of {name!r} ({default!r}) is not a {kind}")
    if kind == "Integer" and isinstance(default, bool):
        raise RegistrationError(f"{fname}: default of Integer {name!r} is a bool")


class Registry:
    """The set of published components, by URI."""

    def __init__(self, components: list[Component] = ()):
        self._by_uri: dict[str, Component] = {}
        for c in components:
            self.add(c)

    def add(self, component: Component) -> None:
        if component.uri in self._by_uri:
            raise RegistrationError(f"duplicate component uri {component.uri!r}")
        self._by_uri[component.uri] = component

    def get(self, uri: str) -> Component | None:
        return self._by_uri.get(uri.strip("/"))

    def __iter__(self):
        return iter(sorted(self._by_uri.values(), key=lambda c: c.uri))

    def __len__(self):
        return len(self._by_uri)

    def catalogue(self) -> list[dict]:
        """The ``GET /`` answer: one metadata object (with ``Uri``) per component."""
        return [c.metadata() for c in self]

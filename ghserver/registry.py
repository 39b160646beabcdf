"""Components: a function from ``components/`` plus a short declaration.

Everything Hops needs to know about a component is derived from the function itself:

* the **name** is the function's name, the **description** the first line of its docstring;
* the **inputs** are its parameters in signature order, their kinds from the annotations (see
  :mod:`components.core.types`), their defaults from the signature (falsy ones included), their descriptions from the
  docstring's Parameters section; ``X | None = None`` is an optional input;
* the **outputs** are the fields of the returned ``NamedTuple``, described in the docstring's Returns section.

A disagreement between signature, docstring and return type raises :class:`RegistrationError` when the
declaration is made, i.e. at import of :mod:`ghserver.endpoints`.
"""
from __future__ import annotations

import inspect
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
            entries.append((name.strip(), typ.strip(), _first_sentence(desc)))
        else:
            i += 1
    return entries


def _first_sentence(text: str) -> str:
    m = re.match(r"(.+?[.!?])(\s|$)", text)
    return (m.group(1) if m else text).strip()


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
    if not summary:
        raise RegistrationError(f"{fname}: missing docstring summary line")
    sections = _sections(doc)
    try:
        hints = typing.get_type_hints(function, include_extras=True)
    except Exception as exc:  # unresolved forward references
        raise RegistrationError(f"{fname}: cannot resolve annotations ({exc})") from exc
    sig = inspect.signature(function)

    context = tuple(n for n in sig.parameters if n in ct.CONTEXT_PARAMETERS)
    sig_inputs = [p for n, p in sig.parameters.items() if n not in ct.CONTEXT_PARAMETERS]
    doc_params = [e for e in _entries(sections.get("Parameters", "")) if e[0] not in ct.CONTEXT_PARAMETERS]
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
                name=p.name, kind=kind, access=access, description=desc, nickname=nicknames.get(p.name, ""),
                optional=optional or (has_default and p.default is None), has_default=has_default,
                default=p.default if has_default else None, minimum=lo, maximum=hi,
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
    doc_returns = [e for e in _entries(sections.get("Returns", "")) if e[0] != "warnings"]
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
        outputs.append(Param(name=fname_, kind=kind, access=access, description=desc,
                             nickname=nicknames.get(fname_, "")))
    names = [p.name for p in inputs] + [p.name for p in outputs]
    unknown_nick = set(nicknames) - set(names)
    if unknown_nick:
        raise RegistrationError(f"{fname}: nicknames given for unknown params {sorted(unknown_nick)}")
    comp = Component(
        uri=uri, function=function, name=function.__name__, description=summary, inputs=inputs, outputs=outputs,
        context=context, warnings_field=warnings_field, subcategory=subcategory or uri.split("/")[0],
    )
    comp.fingerprint = repr([(p.name, p.kind, p.access) for p in inputs + outputs])
    return comp


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

"""The registry derives metadata from functions and refuses disagreements at declaration time."""
from __future__ import annotations

import inspect
from typing import NamedTuple

import pytest

from components.core.types import Mesh, Numbers
from ghserver.registry import (RegistrationError, Registry, _entries, _sections, declare, first_sentence,
                               inline_markup, input_summary, plain_text)


class R(NamedTuple):
    out: float


def good(mesh: Mesh, count: int = 0, flag: bool = False, name: str = "", scale: float = 0.0,
         weights: Numbers | None = None) -> R:
    """Do a thing.

    Longer explanation that is not the summary.

    Parameters
    ----------
    mesh : Mesh
        The mesh. More words here.
    count : int
        How many.
    flag : bool
        A switch.
    name : str
        A name.
    scale : float
        A scale.
    weights : Numbers
        Optional weights.

    Returns
    -------
    out : float
        The result.
    """
    return R(1.0)


def test_metadata_derived_from_signature_and_docstring():
    c = declare(good, "test/good", nicknames={"mesh": "M"})
    meta = c.metadata()
    assert meta["Description"] == "Do a thing."
    assert meta["InputNames"] == ["mesh", "count", "flag", "name", "scale", "weights"]
    assert meta["OutputNames"] == ["out"]
    ins = {p["Name"]: p for p in meta["Inputs"]}
    assert ins["mesh"]["ParamType"] == "Mesh" and ins["mesh"]["Nickname"] == "M"
    assert ins["mesh"]["Description"] == "The mesh."
    assert (ins["mesh"]["AtLeast"], ins["mesh"]["AtMost"]) == (1, 1)
    assert "Default" not in ins["mesh"]
    # falsy defaults are sent (ghhops drops them)
    assert ins["count"]["Default"] == 0 and isinstance(ins["count"]["Default"], int)
    assert ins["flag"]["Default"] is False
    assert ins["name"]["Default"] == ""
    assert ins["scale"]["Default"] == 0.0
    # defaulted inputs keep item access (AtLeast 1, AtMost 1: Hops fills them from Default);
    # inputs defaulting to None are optional (AtLeast 0); list access is AtMost int.MaxValue
    assert (ins["count"]["AtLeast"], ins["count"]["AtMost"]) == (1, 1)
    assert ins["weights"]["ParamType"] == "Number"
    assert (ins["weights"]["AtLeast"], ins["weights"]["AtMost"]) == (0, 2147483647)
    assert meta["Outputs"] == [{"Name": "out", "Nickname": "out", "Description": "The result.",
                                "ParamType": "Number", "ResultType": "Number", "Access": "item"}]


def _variant(doc=None, annotations=None, ret=R, params=None):
    def f(mesh, count=1):
        return R(0.0)

    f.__doc__ = doc if doc is not None else good.__doc__
    sig = inspect.signature(good)
    if params is not None:
        sig = sig.replace(parameters=params)
    f.__signature__ = sig.replace(return_annotation=ret)
    f.__annotations__ = dict(good.__annotations__, **(annotations or {}), **{"return": ret})
    return f


def test_docstring_parameter_mismatch_fails():
    doc = good.__doc__.replace("    count : int\n        How many.\n", "")
    with pytest.raises(RegistrationError, match="do not match the signature"):
        declare(_variant(doc=doc), "t/a")


def test_docstring_parameter_order_mismatch_fails():
    doc = good.__doc__.replace("flag : bool\n        A switch.", "TMP").replace(
        "count : int\n        How many.", "flag : bool\n        A switch.").replace("TMP", "count : int\n        How many.")
    with pytest.raises(RegistrationError, match="do not match the signature"):
        declare(_variant(doc=doc), "t/b")


def test_returns_mismatch_fails():
    doc = good.__doc__.replace("out : float", "result : float")
    with pytest.raises(RegistrationError, match="do not match the NamedTuple"):
        declare(_variant(doc=doc), "t/c")


def test_return_must_be_namedtuple():
    with pytest.raises(RegistrationError, match="NamedTuple"):
        declare(_variant(ret=float), "t/d")


def test_unsupported_annotation_fails():
    with pytest.raises(RegistrationError, match="cannot map annotation"):
        declare(_variant(annotations={"count": dict}), "t/e")


def test_optional_needs_none_default():
    params = list(inspect.signature(good).parameters.values())
    params[1] = params[1].replace(annotation=int | None, default=3)
    with pytest.raises(RegistrationError, match="must default to None"):
        declare(_variant(params=params, annotations={"count": int | None}), "t/f")


def test_wrong_default_type_fails():
    params = list(inspect.signature(good).parameters.values())
    params[1] = params[1].replace(default="three")
    with pytest.raises(RegistrationError, match="is not a Integer"):
        declare(_variant(params=params), "t/g")


def test_missing_summary_and_bad_uri_fail():
    with pytest.raises(RegistrationError, match="summary"):
        declare(_variant(doc=""), "t/h")
    with pytest.raises(RegistrationError, match="invalid uri"):
        declare(good, "Bad URI!")


def test_duplicate_uri_fails():
    c = declare(good, "t/i")
    with pytest.raises(RegistrationError, match="duplicate"):
        Registry([c, c])


def test_ranges_and_nicknames_must_name_real_params():
    with pytest.raises(RegistrationError, match="ranges given for unknown"):
        declare(good, "t/j", ranges={"nope": (0, 1)})
    with pytest.raises(RegistrationError, match="nicknames given for unknown"):
        declare(good, "t/k", nicknames={"nope": "N"})


def test_context_parameters_are_not_inputs(echo_registry):
    meta = echo_registry.get("echo/scale").metadata()
    assert meta["InputNames"] == ["x", "factor"]
    assert meta["OutputNames"] == ["value", "doubled"]  # 'warnings' is not an output


def _check_component(c):
    """docstring == signature == metadata for one component."""
    fn = c.function
    sig = inspect.signature(fn)
    sections = _sections(fn.__doc__)
    doc_in = [e[0] for e in _entries(sections["Parameters"]) if e[0] not in c.context]
    sig_in = [n for n in sig.parameters if n not in c.context]
    meta = c.metadata()
    assert doc_in == sig_in == meta["InputNames"] == [p["Name"] for p in meta["Inputs"]]
    ret = sig.return_annotation
    ret = fn.__annotations__["return"] if isinstance(ret, str) else ret
    fields = [f for f in c.function.__annotations__ and _fields(fn) if f != "warnings"]
    doc_out = [e[0] for e in _entries(sections["Returns"]) if e[0] != "warnings"]
    assert doc_out == fields == meta["OutputNames"] == [p["Name"] for p in meta["Outputs"]]
    for p, name in zip(meta["Inputs"], sig_in):
        param = sig.parameters[name]
        if param.default is not inspect.Parameter.empty and param.default is not None:
            assert p["Default"] == param.default and type(p["Default"]) is type(param.default)
        assert p["ParamType"] in ("Number", "Integer", "Boolean", "Text", "Point", "Vector", "Plane", "Line",
                                  "Curve", "Surface", "Mesh")
        assert p["Name"] and p["Description"]
    assert meta["Description"] == plain_text(inspect.cleandoc(fn.__doc__).split("\n\n")[0])


def _fields(fn):
    import typing

    return list(typing.get_type_hints(fn)["return"]._fields)


def test_every_published_component_agrees_with_its_function():
    from ghserver.endpoints import build_registry

    reg = build_registry()
    assert len(reg) >= 1
    for c in reg:
        _check_component(c)


def test_every_echo_component_agrees_with_its_function(echo_registry):
    for c in echo_registry:
        _check_component(c)


# plain-text descriptions (Hops shows them verbatim), names, choices ---------------------------------------------


class MarkedResult(NamedTuple):
    mesh: Mesh
    value: float


def marked(mesh: Mesh, method: str = "face", tolerance: float = 1e-3) -> MarkedResult:
    """Offset a ``(V, F)`` mesh, see :func:`components.conical.cones.offset` and *Pottmann 2007*.

    Parameters
    ----------
    mesh : Mesh
        The planar-quad mesh ``(V, F)`` (e.g. a conical one). Second sentence with ``x.y``.
    method : str
        ``"face"``: planes moved (:class:`~components.core.types.Plane`); ``"vertex"``: vertices moved.
    tolerance : float
        Largest **accepted** error, 2 * 3 units.

    Returns
    -------
    mesh : Mesh
        The offset ``(V, F)``.
    value : float
        Largest error of :func:`Offset <components.conical.cones.offset>`, *model units*.
    """
    return MarkedResult(mesh, 0.0)


def test_metadata_descriptions_are_plain_text_and_pages_keep_the_markup():
    c = declare(marked, "t/marked", ranges={"tolerance": (0.0, None)})
    meta = c.metadata()
    assert meta["Description"] == "Offset a (V, F) mesh, see offset and Pottmann 2007."
    ins = {p["Name"]: p["Description"] for p in meta["Inputs"]}
    outs = {p["Name"]: p["Description"] for p in meta["Outputs"]}
    assert ins == {"mesh": "The planar-quad mesh (V, F) (e.g. a conical one).",
                   "method": '"face": planes moved (Plane); "vertex": vertices moved.',
                   "tolerance": "Largest accepted error, 2 * 3 units."}
    assert outs == {"mesh": "The offset (V, F).", "value": "Largest error of Offset, model units."}
    # the raw text stays for the HTML pages: whole description, markup intact
    assert c.doc.startswith("Offset a ``(V, F)`` mesh, see :func:")
    assert c.inputs[0].doc == "The planar-quad mesh ``(V, F)`` (e.g. a conical one). Second sentence with ``x.y``."
    assert c.inputs[1].choices == ("face", "vertex")
    assert c.inputs[0].choices == () and c.inputs[2].choices == ()
    assert input_summary(c.inputs[1]) == '= "face", one of "face", "vertex"'
    assert input_summary(c.inputs[2]) == "= 0.001, range [0, ∞]"
    assert input_summary(c.inputs[0]) == "required"


@pytest.mark.parametrize("text, runs", [
    ("a ``b`` c", [("text", "a "), ("code", "b"), ("text", " c")]),
    (":func:`~a.b.c` :mod:`ghserver.app` :class:`T <x.Y>`",
     [("code", "c"), ("text", " "), ("code", "ghserver.app"), ("text", " "), ("code", "T")]),
    ("*em* **strong** `interp`", [("emph", "em"), ("text", " "), ("strong", "strong"), ("text", " "),
                                  ("code", "interp")]),
    ("2 * 3 * 4, a*b, *args", [("text", "2 * 3 * 4, a*b, *args")]),
    ("unclosed ``code and `tick", [("text", "unclosed ``code and `tick")]),
    ("``|ω1 − ω2|`` and ``\"face\"``", [("code", "|ω1 − ω2|"), ("text", " and "), ("code", '"face"')]),
])
def test_inline_markup_runs(text, runs):
    assert inline_markup(text) == runs
    assert plain_text(text) == " ".join("".join(t for _, t in runs).split())


@pytest.mark.parametrize("text, first", [
    ("One. Two.", "One."),
    ("Mesh (e.g. a dome) here. Then.", "Mesh (e.g. a dome) here."),
    ("Uses ``a.b. c`` here. Then.", "Uses ``a.b. c`` here."),
    ("See (the note. inside) end. Then.", "See (the note. inside) end."),
    ("Liu et al. 2006 show it. Then.", "Liu et al. 2006 show it."),
    ("No full stop", "No full stop"),
])
def test_first_sentence_skips_abbreviations_literals_and_parentheses(text, first):
    assert first_sentence(text) == first


def _published():
    from ghserver.endpoints import build_registry

    return build_registry()


MARKUP = ("``", ":func:", ":class:", ":mod:", ":meth:", "`")


def test_published_metadata_is_plain_text_and_named_after_the_uri():
    """What Hops shows (the Description of the component and of every input and output) carries no docstring
    markup, and every published component's Name is its URI's last part."""
    for c in _published():
        meta = c.metadata()
        assert meta["Name"] == meta["Nickname"] == c.uri.rsplit("/", 1)[-1], c.uri
        texts = [meta["Description"]] + [p["Description"] for p in meta["Inputs"] + meta["Outputs"]]
        for t in texts:
            assert t and not any(m in t for m in MARKUP), f"{c.uri}: {t!r}"
            assert not t.endswith(("e.g.", "i.e.", "(e.g.")), f"{c.uri}: cut after an abbreviation: {t!r}"
            assert t.count("(") == t.count(")"), f"{c.uri}: cut inside parentheses: {t!r}"


def test_published_choices_are_values_the_function_knows():
    """A choice read from a docstring appears as a string literal in the function's module (it is tested there)."""
    import sys

    n = 0
    for c in _published():
        src = inspect.getsource(sys.modules[c.function.__module__])
        for p in c.inputs:
            if p.kind == "Text" and p.choices:
                n += 1
                assert p.default in p.choices
                for v in p.choices:
                    assert f'"{v}"' in src or f"'{v}'" in src, f"{c.uri} {p.name}: {v!r} not in the source"
    assert n >= 20


def test_angle_outputs_state_their_unit():
    """Angles are radians in the metrics and degrees where a designer reads them (kinks, worst corner): every
    published angle output says which."""
    for c in _published():
        for p in c.outputs:
            if p.kind == "Number" and set(p.name.split("_")) & {"angle", "angles", "kink", "kinks", "torsion"}:
                d = p.description.lower()
                assert "radian" in d or "degree" in d or "°" in d, f"{c.uri} {p.name}: {p.description!r}"

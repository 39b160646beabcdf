"""Grasshopper definition files: a tiny GH_IO archive model, its XML (``.ghx``) writer and reader, a reader for
binary ``.gh`` archives, and a builder for documents with Hops components.

A Grasshopper file is a GH_IO archive: a tree of **chunks** (a name, an optional index, typed **items** and
sub-chunks). ``.ghx`` is its XML form, ``.gh`` the same tree in GH_IO's binary form compressed with raw deflate
(``docs/hops-protocol.md`` §6). This module copies the conventions of the real files in ``shared/data/hops/``:

* ``<?xml …?>`` + ``<Archive name="Root">``; ``<items count=..>`` / ``<chunks count=..>`` are omitted when empty,
  an empty chunk is written ``<chunk name=".." />``; items are written sorted by name then index (every real file
  is sorted so);
* item elements carry ``name``, ``index`` (only when indexed), ``type_name``, ``type_code``; compound values are
  child elements (``gh_version`` → ``<Major>``, ``<Minor>``, ``<Revision>``; ``gh_drawing_rectanglef`` →
  ``<X>``, ``<Y>``, ``<W>``, ``<H>``; ``gh_drawing_pointf`` → ``<X>``, ``<Y>``; ``gh_drawing_color`` →
  ``<ARGB>a;r;g;b</ARGB>``; bitmaps → ``<bitmap length="n">base64</bitmap>``);
* numbers are written like .NET's round-trip format (``1`` not ``1.0``; singles with 7, else 9 significant
  digits), so reading and re-writing a Grasshopper-written file reproduces it.

The :class:`Document` builder writes what Grasshopper itself writes for number sliders, panels, floating geometry
parameters, groups, the Custom Preview component and Hops components (GUID ``c69bb52c-…``, library
``82cb7266-…``, ``RemoteDefinitionLocation``, ``RemoteSolveVersion`` 0.1.0, ``ParameterData`` with
``InputParam``/``OutputParam`` chunks). Wires are ``Source`` items holding the InstanceGuid of the feeding
object's output. Every InstanceGuid is a uuid5 of the document name and the object's role, so regenerating a
definition gives the same text.
"""
from __future__ import annotations

import base64
import re
import struct
import uuid
import zlib
from dataclasses import dataclass, field
from typing import Any, Iterator, NamedTuple
from xml.etree import ElementTree
from xml.sax.saxutils import escape, quoteattr

import numpy as np

# ----------------------------------------------------------------------------------------------
# GH_IO item types

TYPE_NAMES = {
    1: "gh_bool", 2: "gh_byte", 3: "gh_int32", 4: "gh_int64", 5: "gh_single", 6: "gh_double", 7: "gh_decimal",
    8: "gh_date", 9: "gh_guid", 10: "gh_string", 20: "gh_bytearray", 21: "gh_doublearray",
    30: "gh_drawing_point", 31: "gh_drawing_pointf", 32: "gh_drawing_size", 33: "gh_drawing_sizef",
    34: "gh_drawing_rectangle", 35: "gh_drawing_rectanglef", 36: "gh_drawing_color", 37: "gh_drawing_bitmap",
    50: "gh_point2d", 51: "gh_point3d", 52: "gh_point4d", 60: "gh_interval1d", 61: "gh_interval2d",
    70: "gh_line", 71: "gh_boundingbox", 72: "gh_plane", 80: "gh_version",
}
TYPE_CODES = {v: k for k, v in TYPE_NAMES.items()}

BOOL, INT32, SINGLE, DOUBLE, DATE, GUID, STRING = 1, 3, 5, 6, 8, 9, 10
POINT, POINTF, RECTANGLEF, COLOR, BITMAP, POINT3D, VERSION = 30, 31, 35, 36, 37, 51, 80

# child element names of compound values in GH_IO XML, with the number type of each field
_FIELDS = {
    POINT: (("X", "Y"), int),
    POINTF: (("X", "Y"), "single"),
    32: (("W", "H"), int),
    33: (("W", "H"), "single"),
    34: (("X", "Y", "W", "H"), int),
    RECTANGLEF: (("X", "Y", "W", "H"), "single"),
    50: (("X", "Y"), "double"),
    POINT3D: (("X", "Y", "Z"), "double"),
    52: (("X", "Y", "Z", "W"), "double"),
    60: (("A", "B"), "double"),
    VERSION: (("Major", "Minor", "Revision"), int),
}


class Raw(NamedTuple):
    """A value of a type this module does not model: the item's XML children (tag, text) or its text."""

    text: str | None = None
    children: tuple = ()


@dataclass
class Item:
    """A typed GH_IO item. ``index`` is None for plain items, an int for indexed ones (``Source[0]``)."""

    name: str
    type_code: int
    value: Any
    index: int | None = None

    @property
    def type_name(self) -> str:
        return TYPE_NAMES.get(self.type_code, f"gh_type{self.type_code}")


@dataclass
class Chunk:
    """A GH_IO chunk: a name, an optional index, items and sub-chunks (kept in insertion order)."""

    name: str
    index: int | None = None
    items: list[Item] = field(default_factory=list)
    chunks: list["Chunk"] = field(default_factory=list)

    # -- building
    def add(self, name: str, type_code: int, value: Any, index: int | None = None) -> "Chunk":
        """Add an item (replacing one with the same name and index); returns self for chaining."""
        self.items = [it for it in self.items if (it.name, it.index) != (name, index)]
        self.items.append(Item(name, type_code, value, index))
        return self

    def chunk(self, name: str, index: int | None = None) -> "Chunk":
        """Add and return a new sub-chunk."""
        c = Chunk(name, index)
        self.chunks.append(c)
        return c

    # -- reading
    def get(self, name: str, default: Any = None, *, index: int | None = None) -> Any:
        """Value of the item ``name`` (indexed items: ``index=k``), or ``default``."""
        for it in self.items:
            if it.name == name and it.index == index:
                return it.value
        return default

    def item(self, name: str, index: int | None = None) -> Item | None:
        for it in self.items:
            if it.name == name and it.index == index:
                return it
        return None

    def find(self, name: str, index: int | None = None) -> "Chunk | None":
        """First direct sub-chunk named ``name`` (with ``index`` when given)."""
        for c in self.chunks:
            if c.name == name and (index is None or c.index == index):
                return c
        return None

    def children(self, name: str) -> list["Chunk"]:
        """Every direct sub-chunk named ``name``."""
        return [c for c in self.chunks if c.name == name]

    def walk(self) -> Iterator["Chunk"]:
        """This chunk and all chunks below it, depth first."""
        yield self
        for c in self.chunks:
            yield from c.walk()

    def indexed(self, name: str) -> list[Any]:
        """Values of the indexed items ``name[0..]`` in index order."""
        its = sorted((it for it in self.items if it.name == name and it.index is not None), key=lambda i: i.index)
        return [it.value for it in its]


def _item_key(it: Item):
    return (it.name, -1 if it.index is None else it.index)


# ----------------------------------------------------------------------------------------------
# number formatting (.NET round-trip style, as GH_IO writes numbers)


def _dotnet_g(x: float, digits: int) -> str:
    if x == 0:
        return "0"
    return f"{x:.{digits}G}"


def format_double(x: float) -> str:
    """``x`` as .NET Framework's ``Double.ToString("R")``: 15 significant digits, 17 when 15 lose the value."""
    x = float(x)
    s = _dotnet_g(x, 15)
    return s if float(s) == x else _dotnet_g(x, 17)


def format_single(x: float) -> str:
    """``x`` rounded to float32, as ``Single.ToString("R")``: 7 significant digits, 9 when 7 lose the value."""
    v = np.float32(x)
    s = _dotnet_g(float(v), 7)
    return s if np.float32(s) == v else _dotnet_g(float(v), 9)


def _format_number(x, kind) -> str:
    if kind is int:
        return str(int(x))
    return format_single(x) if kind == "single" else format_double(x)


def _parse_number(text: str, kind):
    text = (text or "").strip()
    return int(text) if kind is int else float(text)


# ----------------------------------------------------------------------------------------------
# XML writer


def _item_lines(it: Item, depth: int) -> list[str]:
    ind = "  " * depth
    idx = f' index="{it.index}"' if it.index is not None else ""
    head = f'{ind}<item name={quoteattr(it.name)}{idx} type_name="{it.type_name}" type_code="{it.type_code}">'
    code, v = it.type_code, it.value
    if isinstance(v, Raw):
        if not v.children:
            return [head + escape(v.text or "") + "</item>"]
        body = [f"{ind}  <{tag}>{escape(text or '')}</{tag}>" for tag, text in v.children]
        return [head, *body, f"{ind}</item>"]
    if code in _FIELDS:
        names, kind = _FIELDS[code]
        body = [f"{ind}  <{n}>{_format_number(x, kind)}</{n}>" for n, x in zip(names, v)]
        return [head, *body, f"{ind}</item>"]
    if code == COLOR:
        return [head, f"{ind}  <ARGB>{';'.join(str(int(c)) for c in v)}</ARGB>", f"{ind}</item>"]
    if code in (BITMAP, 20):
        data = base64.b64encode(bytes(v)).decode("ascii")  # length = byte count of the decoded data
        return [head, f'{ind}  <bitmap length="{len(bytes(v))}">{data}</bitmap>', f"{ind}</item>"]
    if code == BOOL:
        text = "true" if v else "false"
    elif code == SINGLE:
        text = format_single(v)
    elif code == DOUBLE:
        text = format_double(v)
    elif code == GUID:
        text = str(uuid.UUID(str(v)))
    else:
        text = escape(str(v))
    return [head + text + "</item>"]


def _chunk_body(chunk: Chunk, depth: int, out: list[str]) -> None:
    ind = "  " * depth
    if chunk.items:
        out.append(f'{ind}<items count="{len(chunk.items)}">')
        for it in sorted(chunk.items, key=_item_key):
            out.extend(_item_lines(it, depth + 1))
        out.append(f"{ind}</items>")
    if chunk.chunks:
        out.append(f'{ind}<chunks count="{len(chunk.chunks)}">')
        for c in chunk.chunks:
            idx = f' index="{c.index}"' if c.index is not None else ""
            if not c.items and not c.chunks:
                out.append(f"{ind}  <chunk name={quoteattr(c.name)}{idx} />")
                continue
            out.append(f"{ind}  <chunk name={quoteattr(c.name)}{idx}>")
            _chunk_body(c, depth + 2, out)
            out.append(f"{ind}  </chunk>")
        out.append(f"{ind}</chunks>")


DEFAULT_COMMENTS = (
    "Grasshopper archive",
    "Written by ghserver.ghx from the component registry: regenerate with python -m ghserver.definitions",
)


def write_ghx(root: Chunk, comments: tuple[str, ...] = DEFAULT_COMMENTS) -> str:
    """The GH_IO XML text of the archive ``root`` (Grasshopper's layout: 2-space indent, LF, no final newline).

    Write it to disk with ``encoding="utf-8-sig"`` (Grasshopper writes a byte-order mark) or use
    :func:`save_ghx`.
    """
    out = ['<?xml version="1.0" encoding="utf-8" standalone="yes"?>', f"<Archive name={quoteattr(root.name)}>"]
    out.extend(f"  <!--{c}-->" for c in comments)
    _chunk_body(root, 1, out)
    out.append("</Archive>")
    return "\n".join(out)


def save_ghx(root: Chunk, path) -> None:
    """Write ``root`` as a ``.ghx`` file (UTF-8 with byte-order mark, like Grasshopper)."""
    with open(path, "w", encoding="utf-8-sig", newline="\n") as fh:
        fh.write(write_ghx(root))


# ----------------------------------------------------------------------------------------------
# XML reader


class GhxError(ValueError):
    """A ``.ghx``/``.gh`` archive that does not follow the GH_IO layout (counts, types, structure)."""


def _parse_item(el) -> Item:
    name = el.get("name")
    try:
        code = int(el.get("type_code"))
    except (TypeError, ValueError) as exc:
        raise GhxError(f"item {name!r} has no valid type_code") from exc
    tname = el.get("type_name")
    if code in TYPE_NAMES and tname != TYPE_NAMES[code]:
        raise GhxError(f"item {name!r}: type_name {tname!r} does not match type_code {code}")
    index = int(el.get("index")) if el.get("index") is not None else None
    kids = list(el)
    text = el.text or ""
    if code in _FIELDS and kids:
        names, kind = _FIELDS[code]
        tags = tuple(k.tag for k in kids)
        if tags != names:
            raise GhxError(f"item {name!r} ({TYPE_NAMES[code]}): children {tags} instead of {names}")
        value: Any = tuple(_parse_number(k.text, kind) for k in kids)
    elif code == COLOR and len(kids) == 1 and kids[0].tag == "ARGB":
        value = tuple(int(c) for c in kids[0].text.split(";"))
    elif code in (BITMAP, 20) and len(kids) == 1 and kids[0].tag == "bitmap":
        value = base64.b64decode(kids[0].text or "")
    elif kids:
        value = Raw(None, tuple((k.tag, k.text) for k in kids))
    elif code == BOOL:
        if text not in ("true", "false"):
            raise GhxError(f"item {name!r}: gh_bool text {text!r}")
        value = text == "true"
    elif code in (2, INT32, 4, DATE):
        value = int(text)
    elif code in (SINGLE, DOUBLE):
        value = float(text)
    elif code == GUID:
        value = str(uuid.UUID(text))
    elif code == STRING:
        value = text
    else:
        value = Raw(text, ())
    return Item(name, code, value, index)


def _parse_chunk(el, name: str | None = None) -> Chunk:
    idx = el.get("index")
    chunk = Chunk(name or el.get("name"), int(idx) if idx is not None else None)
    for part in el:
        if part.tag == "items":
            elems = [e for e in part if e.tag == "item"]
            if int(part.get("count", -1)) != len(elems):
                raise GhxError(f"chunk {chunk.name!r}: items count {part.get('count')} but {len(elems)} items")
            chunk.items = [_parse_item(e) for e in elems]
        elif part.tag == "chunks":
            elems = [e for e in part if e.tag == "chunk"]
            if int(part.get("count", -1)) != len(elems):
                raise GhxError(f"chunk {chunk.name!r}: chunks count {part.get('count')} but {len(elems)} chunks")
            chunk.chunks = [_parse_chunk(e) for e in elems]
        else:
            raise GhxError(f"chunk {chunk.name!r}: unexpected element <{part.tag}>")
    return chunk


def read_ghx(text: str | bytes) -> Chunk:
    """Parse GH_IO XML (a ``.ghx`` file's text) into its root :class:`Chunk`; checks every count.

    Raises
    ------
    GhxError
        When the XML is not a GH_IO archive or a count, type code or compound value is inconsistent.
    """
    if isinstance(text, bytes):
        text = text.decode("utf-8-sig")
    text = text.lstrip("\ufeff")
    try:
        root = ElementTree.fromstring(text)
    except ElementTree.ParseError as exc:
        raise GhxError(f"not XML: {exc}") from exc
    if root.tag != "Archive":
        raise GhxError(f"root element is <{root.tag}>, expected <Archive>")
    return _parse_chunk(root, root.get("name", "Root"))


def load_ghx(path) -> Chunk:
    with open(path, "rb") as fh:
        return read_ghx(fh.read())


# ----------------------------------------------------------------------------------------------
# binary reader (.gh = raw-deflate GH_IO binary archive)


class _Bin:
    def __init__(self, data: bytes):
        self.data, self.pos = data, 0

    def take(self, n: int) -> bytes:
        if self.pos + n > len(self.data):
            raise GhxError(f"binary archive truncated at byte {self.pos}")
        b = self.data[self.pos:self.pos + n]
        self.pos += n
        return b

    def unpack(self, fmt: str):
        return struct.unpack("<" + fmt, self.take(struct.calcsize("<" + fmt)))

    def string(self) -> str:
        n = shift = 0
        while True:
            (b,) = self.take(1)
            n |= (b & 0x7F) << shift
            shift += 7
            if not b & 0x80:
                break
        return self.take(n).decode("utf-8")

    def item(self) -> Item:
        name = self.string()
        (index,) = self.unpack("i")
        (code,) = self.unpack("i")
        if code == BOOL:
            value: Any = self.take(1)[0] != 0
        elif code == 2:
            value = self.take(1)[0]
        elif code == INT32:
            (value,) = self.unpack("i")
        elif code in (4, DATE):
            (value,) = self.unpack("q")
        elif code == SINGLE:
            (value,) = self.unpack("f")
        elif code == DOUBLE:
            (value,) = self.unpack("d")
        elif code == GUID:
            value = str(uuid.UUID(bytes_le=self.take(16)))
        elif code == STRING:
            value = self.string()
        elif code in (20, BITMAP):
            (n,) = self.unpack("i")
            value = self.take(n)
        elif code in _FIELDS:
            names, kind = _FIELDS[code]
            fmt = {int: "i", "single": "f", "double": "d"}[kind] * len(names)
            value = self.unpack(fmt)
        elif code == COLOR:
            (argb,) = self.unpack("I")
            value = ((argb >> 24) & 255, (argb >> 16) & 255, (argb >> 8) & 255, argb & 255)
        elif code in (70, 71):
            value = Raw(None, tuple(("v", repr(x)) for x in self.unpack("6d")))
        elif code == 72:
            value = Raw(None, tuple(("v", repr(x)) for x in self.unpack("9d")))
        else:
            raise GhxError(f"item {name!r}: binary type code {code} is not supported")
        return Item(name, code, value, None if index == -1 else index)

    def chunk(self) -> Chunk:
        name = self.string()
        index, n_items, n_chunks = self.unpack("iii")
        c = Chunk(name, None if index == -1 else index)
        c.items = [self.item() for _ in range(n_items)]
        c.chunks = [self.chunk() for _ in range(n_chunks)]
        return c


def read_gh(data: bytes) -> Chunk:
    """Decode a binary ``.gh`` file (raw-deflate GH_IO archive) into the same chunk tree :func:`read_ghx` gives."""
    try:
        raw = zlib.decompress(data, -15)
    except zlib.error as exc:
        raise GhxError(f"not a raw-deflate GH_IO archive: {exc}") from exc
    reader = _Bin(raw)
    root = reader.chunk()
    if reader.pos != len(raw):
        raise GhxError(f"{len(raw) - reader.pos} trailing bytes after the archive")
    return root


# ----------------------------------------------------------------------------------------------
# Grasshopper object catalogue (GUIDs and default texts, from real files and GH's own catalogue)

HOPS_GUID = "c69bb52c-88ba-4640-b69f-188d111029e8"
HOPS_LIBRARY_ID = "82cb7266-a8bc-4d3e-99f6-b91504c7117f"
HOPS_VERSION = "0.16.14"
GH_PLUGIN_VERSION = (1, 0, 7)
ARCHIVE_VERSION = (0, 2, 2)
REMOTE_SOLVE_VERSION = (0, 1, 0)


class ParamType(NamedTuple):
    guid: str
    name: str  # GH Name (also the Hops ParamType / GH TypeName)
    nickname: str
    description: str  # GH's default description of the parameter


PARAM_TYPES = {
    "Number": ParamType("3e8ca6be-fda8-4aaf-b5c0-3c54c8bb7312", "Number", "Num",
                        "Contains a collection of floating point numbers"),
    "Integer": ParamType("2e3ab970-8545-46bb-836c-1c11e5610bce", "Integer", "Int",
                         "Contains a collection of integer numbers"),
    "Boolean": ParamType("cb95db89-6165-43b6-9c41-5702bc5bf137", "Boolean", "Bool",
                         "Contains a collection of boolean values"),
    "Text": ParamType("3ede854e-c753-40eb-84cb-b48008f14fd4", "Text", "Txt",
                      "Contains a collection of text fragments"),
    "Point": ParamType("fbac3e32-f100-4292-8692-77240a42fd1a", "Point", "Pt",
                       "Contains a collection of three-dimensional points"),
    "Vector": ParamType("16ef3e75-e315-4899-b531-d3166b42dac9", "Vector", "Vec",
                        "Contains a collection of three-dimensional vectors"),
    "Plane": ParamType("4f8984c4-7c7a-4d69-b0a2-183cbb330d20", "Plane", "Pl",
                       "Contains a collection of three-dimensional axis-systems"),
    "Line": ParamType("8529dbdf-9b6f-42e9-8e1f-c7a2bde56a70", "Line", "Ln",
                      "Contains a collection of line segments"),
    "Curve": ParamType("d5967b9f-e8ee-436b-a8ad-29fdcecf32d5", "Curve", "Crv",
                       "Contains a collection of generic curves"),
    "Surface": ParamType("deaf8653-5528-4286-807c-3de8b8dad781", "Surface", "Srf",
                         "Contains a collection of generic surfaces"),
    "Mesh": ParamType("1e936df3-0eea-4246-8549-514cb8862b7a", "Mesh", "Mesh",
                      "Contains a collection of polygon meshes"),
}
PARAM_KIND_BY_GUID = {p.guid: k for k, p in PARAM_TYPES.items()}

SLIDER_GUID = "57da07bd-ecab-415d-9d86-af36d7073abc"
PANEL_GUID = "59e0b89a-e487-49f8-bab8-b5bab16be14c"
GROUP_GUID = "c552a431-af5b-46a9-a8a4-0fcbc27ef596"
CUSTOM_PREVIEW_GUID = "537b0419-bbc2-4ff4-bf08-afe526367b2c"

ACCESS_CODES = {"item": 0, "list": 1, "tree": 2}  # GH_ParamAccess; written only when not item


def access_of(schema: dict) -> str:
    """Hops' access rule for an input schema (``AccessFromInput``, hops-protocol.md §1.2)."""
    if schema.get("TreeAccess"):
        return "tree"
    lo, hi = schema.get("AtLeast", 1), schema.get("AtMost", 2147483647)
    if lo == 1 and hi == 1:
        return "item"
    if lo == -1 and hi == -1:
        return "tree"
    return "list"


# ----------------------------------------------------------------------------------------------
# document builder

_NAMESPACE = uuid.UUID("6f1d5a52-4c1e-5b0c-9d62-0d0c6a1f7e31")  # fixed: GUIDs stay stable across runs
_DATE_TICKS = 638712864000000000  # 2025-01-01T00:00:00, fixed so regeneration is diff-stable


class Source(NamedTuple):
    """An output that can feed an input: the InstanceGuid of the output parameter and its kind."""

    guid: str
    kind: str | None = None
    label: str = ""


@dataclass
class Placed:
    """An object added to a :class:`Document`."""

    role: str
    chunk: Chunk  # the Object chunk
    guid: str  # InstanceGuid of the object
    bounds: tuple[float, float, float, float]
    outputs: list[Source] = field(default_factory=list)
    output_names: list[str] = field(default_factory=list)
    inputs: dict[str, Chunk] = field(default_factory=dict)  # input name -> InputParam / param_input chunk

    def out(self, which: int | str = 0) -> Source:
        """The output ``which`` (index or name)."""
        if isinstance(which, str):
            if which not in self.output_names:
                raise KeyError(f"{self.role} has no output {which!r} (outputs: {self.output_names})")
            which = self.output_names.index(which)
        return self.outputs[which]


def _attributes(parent: Chunk, bounds, pivot=None, extra=None) -> Chunk:
    a = parent.chunk("Attributes")
    x, y, w, h = bounds
    a.add("Bounds", RECTANGLEF, (x, y, w, h))
    a.add("Pivot", POINTF, pivot if pivot is not None else (x + w / 2, y + h / 2))
    for name, code, value in extra or ():
        a.add(name, code, value)
    return a


def _text_width(text: str, per_char: float = 6.0, pad: float = 8.0) -> float:
    return float(round(len(text) * per_char + pad))


def _as_sources(value) -> list[Source]:
    """Normalise a wire spec: Source, (Placed, index/name), or a list of those."""
    if isinstance(value, list):
        return [s for v in value for s in _as_sources(v)]
    if isinstance(value, tuple) and len(value) == 2 and isinstance(value[0], Placed):
        return [value[0].out(value[1])]
    if isinstance(value, Source):
        return [value]
    raise TypeError(f"not a wire source: {value!r}")


def _add_sources(container: Chunk, sources) -> None:
    for k, s in enumerate(sources):
        container.add("Source", GUID, s.guid, index=k)
    container.add("SourceCount", INT32, len(sources))


class Document:
    """A Grasshopper document under construction.

    Parameters
    ----------
    name : str
        File name (``metrics_analysis.ghx``); also the seed of every InstanceGuid.
    description : str
        Shown in Grasshopper's document properties.
    hops_version : str
        Version of the Hops plug-in recorded in the ``GHALibraries`` chunk.
    """

    def __init__(self, name: str, description: str = "", hops_version: str = HOPS_VERSION):
        self.name = name
        self.description = description
        self.hops_version = hops_version
        self.objects: list[Placed] = []
        self._roles: set[str] = set()

    # -- identity and bookkeeping
    def guid(self, role: str) -> str:
        """Deterministic InstanceGuid for ``role`` (uuid5 of the document name and the role)."""
        return str(uuid.uuid5(_NAMESPACE, f"{self.name}/{role}"))

    def _object(self, role: str, type_guid: str, type_name: str, lib: str | None = None) -> tuple[Chunk, Chunk]:
        if role in self._roles:
            raise ValueError(f"duplicate object role {role!r} in {self.name}")
        self._roles.add(role)
        obj = Chunk("Object")
        obj.add("GUID", GUID, type_guid)
        if lib:
            obj.add("Lib", GUID, lib)
        obj.add("Name", STRING, type_name)
        return obj, obj.chunk("Container")

    def _place(self, p: Placed) -> Placed:
        self.objects.append(p)
        return p

    def __getitem__(self, role: str) -> Placed:
        for p in self.objects:
            if p.role == role:
                return p
        raise KeyError(role)

    # -- objects
    def add_slider(self, role: str, label: str, value: float, minimum: float, maximum: float,
                   integer: bool = False, digits: int = 3, at=(0.0, 0.0), width: float = 200.0) -> Placed:
        """A Number Slider (``Interval`` 1 = integer slider, 0 = floating point)."""
        if not minimum <= value <= maximum:
            raise ValueError(f"slider {label!r}: value {value} outside [{minimum}, {maximum}]")
        obj, c = self._object(role, SLIDER_GUID, "Number Slider")
        guid = self.guid(role)
        c.add("Description", STRING, "Numeric slider for single values")
        c.add("InstanceGuid", GUID, guid)
        c.add("Name", STRING, "Number Slider")
        c.add("NickName", STRING, label)
        c.add("Optional", BOOL, False)
        c.add("SourceCount", INT32, 0)
        bounds = (float(at[0]), float(at[1]), float(width), 20.0)
        _attributes(c, bounds, pivot=(bounds[0], bounds[1]))
        s = c.chunk("Slider")
        s.add("Digits", INT32, 0 if integer else digits)
        s.add("GripDisplay", INT32, 1)
        s.add("Interval", INT32, 1 if integer else 0)
        s.add("Max", DOUBLE, float(maximum))
        s.add("Min", DOUBLE, float(minimum))
        s.add("SnapCount", INT32, 0)
        s.add("Value", DOUBLE, float(value))
        kind = "Integer" if integer else "Number"
        return self._place(Placed(role, obj, guid, bounds, [Source(guid, kind, label)], [label]))

    def add_panel(self, role: str, text: str = "", label: str = "Panel", source: Source | None = None,
                  at=(0.0, 0.0), size=(160.0, 60.0), colour=(255, 255, 250, 90)) -> Placed:
        """A Panel: holds ``text`` (an input) or shows the data of ``source`` (an output display)."""
        obj, c = self._object(role, PANEL_GUID, "Panel")
        guid = self.guid(role)
        c.add("Description", STRING, "A panel for custom notes and text values")
        c.add("InstanceGuid", GUID, guid)
        c.add("Name", STRING, "Panel")
        c.add("NickName", STRING, label)
        c.add("Optional", BOOL, False)
        c.add("ScrollRatio", DOUBLE, 0.0)
        _add_sources(c, [source] if source else [])
        c.add("UserText", STRING, text)
        bounds = (float(at[0]), float(at[1]), float(size[0]), float(size[1]))
        _attributes(c, bounds, pivot=(bounds[0], bounds[1]),
                    extra=[("MarginLeft", INT32, 0), ("MarginRight", INT32, 0), ("MarginTop", INT32, 0)])
        props = c.chunk("PanelProperties")
        props.add("Colour", COLOR, tuple(colour))
        props.add("DrawIndices", BOOL, True)
        props.add("DrawPaths", BOOL, True)
        props.add("Multiline", BOOL, True)
        props.add("SpecialCodes", BOOL, False)
        props.add("Stream", BOOL, False)
        props.add("Wrap", BOOL, True)
        return self._place(Placed(role, obj, guid, bounds, [Source(guid, "Text", label)], [label]))

    def add_param(self, kind: str, role: str, label: str | None = None, source: Source | None = None,
                  at=(0.0, 0.0)) -> Placed:
        """A floating parameter of ``kind`` ("Mesh", "Curve", "Surface", "Point", …) to reference Rhino geometry."""
        if kind not in PARAM_TYPES:
            raise ValueError(f"unknown parameter kind {kind!r}; known: {', '.join(PARAM_TYPES)}")
        pt = PARAM_TYPES[kind]
        obj, c = self._object(role, pt.guid, pt.name)
        guid = self.guid(role)
        label = label or pt.nickname
        c.add("Description", STRING, pt.description)
        c.add("InstanceGuid", GUID, guid)
        c.add("Name", STRING, pt.name)
        c.add("NickName", STRING, label)
        c.add("Optional", BOOL, False)
        _add_sources(c, [source] if source else [])
        bounds = (float(at[0]), float(at[1]), max(50.0, _text_width(label, 7.0, 16.0)), 24.0)
        _attributes(c, bounds)
        return self._place(Placed(role, obj, guid, bounds, [Source(guid, kind, label)], [label]))

    def add_preview(self, role: str, geometry: Source | list[Source], material: Source | None = None,
                    at=(0.0, 0.0)) -> Placed:
        """A Custom Preview component drawing ``geometry`` with ``material`` (e.g. a Panel with ``255,80,80``)."""
        obj, c = self._object(role, CUSTOM_PREVIEW_GUID, "Custom Preview")
        guid = self.guid(role)
        c.add("Description", STRING, "Allows for customized geometry previews")
        c.add("InstanceGuid", GUID, guid)
        c.add("Name", STRING, "Custom Preview")
        c.add("NickName", STRING, "Preview")
        x, y = float(at[0]), float(at[1])
        bounds = (x, y, 70.0, 44.0)
        _attributes(c, bounds)
        geos = geometry if isinstance(geometry, list) else [geometry]
        inputs = {}
        for i, (name, nick, desc, srcs) in enumerate([
            ("Geometry", "G", "Geometry to preview", geos),
            ("Material", "M", "The material override", [material] if material else []),
        ]):
            p = c.chunk("param_input", i)
            p.add("Description", STRING, desc)
            p.add("InstanceGuid", GUID, self.guid(f"{role}/in/{name}"))
            p.add("Name", STRING, name)
            p.add("NickName", STRING, nick)
            p.add("Optional", BOOL, False)
            _add_sources(p, srcs)
            _attributes(p, (x + 2, y + 2 + 20 * i, 15.0, 20.0))
            inputs[name] = p
        return self._place(Placed(role, obj, guid, bounds, [], [], inputs))

    def add_group(self, role: str, label: str, members: list[Placed], colour=(150, 170, 135, 255)) -> Placed:
        """A Group around ``members`` with ``label`` as its name on the canvas."""
        obj, c = self._object(role, GROUP_GUID, "Group")
        guid = self.guid(role)
        c.add("Border", INT32, 1)
        c.add("Colour", COLOR, tuple(colour))
        c.add("Description", STRING, "A group of Grasshopper objects")
        for k, m in enumerate(members):
            c.add("ID", GUID, m.guid, index=k)
        c.add("ID_Count", INT32, len(members))
        c.add("InstanceGuid", GUID, guid)
        c.add("Name", STRING, "Group")
        c.add("NickName", STRING, label)
        c.chunk("Attributes")
        return self._place(Placed(role, obj, guid, (0.0, 0.0, 0.0, 0.0)))

    def add_hops(self, role: str, url: str, metadata: dict, sources: dict[str, Source | list[Source]] | None = None,
                 at=(0.0, 0.0), nickname: str | None = None) -> Placed:
        """A Hops component pointing at ``url`` with the parameters of the server's ``metadata``.

        Parameters
        ----------
        role : str
            Unique role of the object in the document (seeds its GUIDs).
        url : str
            ``RemoteDefinitionLocation``, e.g. ``http://127.0.0.1:5000/metrics/planarity``.
        metadata : dict
            The server's answer to ``GET url`` (``Description``, ``Inputs``, ``Outputs`` with ``Name``,
            ``Nickname``, ``Description``, ``ParamType``, ``AtLeast``/``AtMost``/``TreeAccess``).
        sources : dict
            ``{input name: source or [source, ...]}`` wires, a source being a :class:`Source` or an
            ``(object, output index or name)`` pair; other inputs stay unconnected (Hops then uses the server's
            ``Default``).
        """
        sources = {k: _as_sources(v) for k, v in (sources or {}).items()}
        ins, outs = metadata.get("Inputs", []), metadata.get("Outputs", [])
        names = [p["Name"] for p in ins]
        unknown = set(sources) - set(names)
        if unknown:
            raise KeyError(f"{url}: no input(s) {sorted(unknown)}; inputs are {names}")
        for p in ins + outs:
            if p["ParamType"] not in PARAM_TYPES:
                raise ValueError(f"{url}: parameter {p['Name']!r} has unsupported ParamType {p['ParamType']!r}")
        obj, c = self._object(role, HOPS_GUID, "Hops", lib=HOPS_LIBRARY_ID)
        guid = self.guid(role)
        c.add("CacheResultsInMemory", BOOL, True)
        c.add("CacheSolveResults", BOOL, True)
        c.add("Description", STRING, metadata.get("Description") or "")
        c.add("InstanceGuid", GUID, guid)
        c.add("Name", STRING, "Hops")
        c.add("NickName", STRING, nickname or metadata.get("Name") or "Hops")
        c.add("RemoteDefinitionLocation", STRING, url)
        c.add("RemoteSolveVersion", VERSION, REMOTE_SOLVE_VERSION)
        c.add("ShowInput_Enabled", BOOL, False)
        c.add("ShowInput_Path", BOOL, False)
        c.add("SynchronousSolve", BOOL, True)

        # layout: Grasshopper recomputes it on load; these are plausible values in its style
        x, y = float(at[0]), float(at[1])
        rows = max(len(ins), len(outs), 1)
        h = 20.0 * rows + 4.0
        w_in = max([_text_width(p.get("Nickname") or p["Name"]) for p in ins] or [14.0])
        w_out = max([_text_width(p.get("Nickname") or p["Name"]) for p in outs] or [14.0])
        w = w_in + w_out + 28.0
        bounds = (x, y, w, h)
        _attributes(c, bounds)
        pd = c.chunk("ParameterData")
        pd.add("InputCount", INT32, len(ins))
        for i, p in enumerate(ins):
            pd.add("InputId", GUID, PARAM_TYPES[p["ParamType"]].guid, index=i)
        pd.add("OutputCount", INT32, len(outs))
        for i, p in enumerate(outs):
            pd.add("OutputId", GUID, PARAM_TYPES[p["ParamType"]].guid, index=i)
        inputs, outputs = {}, []
        for i, p in enumerate(ins):
            ch = pd.chunk("InputParam", i)
            access = access_of(p)
            if access != "item":
                ch.add("Access", INT32, ACCESS_CODES[access])
            ch.add("Description", STRING, p.get("Description") or p["Name"])
            ch.add("InstanceGuid", GUID, self.guid(f"{role}/in/{p['Name']}"))
            ch.add("Name", STRING, p["Name"])
            ch.add("NickName", STRING, p.get("Nickname") or p["Name"])
            ch.add("Optional", BOOL, p.get("AtLeast", 1) == 0)
            _add_sources(ch, sources.get(p["Name"], []))
            hi = (h - 4.0) / max(len(ins), 1)
            _attributes(ch, (x + 2, y + 2 + i * hi, w_in, hi))
            inputs[p["Name"]] = ch
        for i, p in enumerate(outs):
            ch = pd.chunk("OutputParam", i)
            og = self.guid(f"{role}/out/{p['Name']}")
            ch.add("Access", INT32, ACCESS_CODES["tree"])  # Hops outputs are always tree access
            # Hops ignores an output's Description and shows Grasshopper's default text (hops-protocol.md §1.2)
            ch.add("Description", STRING, PARAM_TYPES[p["ParamType"]].description)
            ch.add("InstanceGuid", GUID, og)
            ch.add("Name", STRING, p["Name"])
            ch.add("NickName", STRING, p.get("Nickname") or p["Name"])
            ch.add("Optional", BOOL, False)
            ch.add("SourceCount", INT32, 0)
            ho = (h - 4.0) / max(len(outs), 1)
            _attributes(ch, (x + w - w_out - 2, y + 2 + i * ho, w_out, ho))
            outputs.append(Source(og, p["ParamType"], p["Name"]))
        return self._place(Placed(role, obj, guid, bounds, outputs, [p["Name"] for p in outs], inputs))

    # -- archive
    def to_chunk(self) -> Chunk:
        """The whole GH_IO archive (root chunk)."""
        root = Chunk("Root")
        root.add("ArchiveVersion", VERSION, ARCHIVE_VERSION)
        d = root.chunk("Definition")
        d.add("plugin_version", VERSION, GH_PLUGIN_VERSION)
        hdr = d.chunk("DocumentHeader")
        hdr.add("DocumentID", GUID, self.guid("document"))
        hdr.add("Preview", STRING, "Shaded")
        hdr.add("PreviewMeshType", INT32, 1)
        hdr.add("PreviewNormal", COLOR, (100, 150, 0, 0))
        hdr.add("PreviewSelected", COLOR, (100, 0, 150, 0))
        props = d.chunk("DefinitionProperties")
        props.add("Date", DATE, _DATE_TICKS)
        props.add("Description", STRING, self.description)
        props.add("Name", STRING, self.name)
        props.chunk("Revisions").add("RevisionCount", INT32, 0)
        proj = props.chunk("Projection")
        proj.add("Target", POINT, (0, 0))
        proj.add("Zoom", SINGLE, 0.85)
        props.chunk("Views").add("ViewCount", INT32, 0)
        d.chunk("RcpLayout").add("GroupCount", INT32, 0)
        libs = d.chunk("GHALibraries")
        uses_hops = any(p.chunk.get("GUID") == HOPS_GUID for p in self.objects)
        libs.add("Count", INT32, 1 if uses_hops else 0)
        if uses_hops:
            lib = libs.chunk("Library", 0)
            v = self.hops_version
            lib.add("AssemblyFullName", STRING, f"Hops, Version={v}.0, Culture=neutral, PublicKeyToken=null")
            lib.add("AssemblyVersion", STRING, f"{v}.0")
            lib.add("Author", STRING, "Robert McNeel & Associates")
            lib.add("Id", GUID, HOPS_LIBRARY_ID)
            lib.add("Name", STRING, "Hops")
            lib.add("Version", STRING, v)
        objs = d.chunk("DefinitionObjects")
        objs.add("ObjectCount", INT32, len(self.objects))
        for i, p in enumerate(self.objects):
            p.chunk.index = i
            objs.chunks.append(p.chunk)
        return root

    def to_ghx(self) -> str:
        return write_ghx(self.to_chunk())


# ----------------------------------------------------------------------------------------------
# reading definitions back


class HopsParam(NamedTuple):
    name: str
    nickname: str
    kind: str | None  # ParamType from the InputId/OutputId type GUID (None if unknown)
    type_guid: str
    access: str
    optional: bool
    instance_guid: str
    sources: tuple[str, ...]


class HopsInfo(NamedTuple):
    url: str
    instance_guid: str
    description: str
    inputs: tuple[HopsParam, ...]
    outputs: tuple[HopsParam, ...]


def definition_objects(root: Chunk) -> list[Chunk]:
    """The ``Object`` chunks of a definition archive."""
    d = root.find("Definition")
    objs = d.find("DefinitionObjects") if d else None
    if objs is None:
        raise GhxError("archive has no Definition/DefinitionObjects chunk")
    return objs.children("Object")


def _hops_param(chunk: Chunk, type_guid: str) -> HopsParam:
    access = {v: k for k, v in ACCESS_CODES.items()}.get(chunk.get("Access", default=0), "item")
    return HopsParam(chunk.get("Name"), chunk.get("NickName"), PARAM_KIND_BY_GUID.get(type_guid), type_guid, access,
                     bool(chunk.get("Optional", default=False)), chunk.get("InstanceGuid"), tuple(chunk.indexed("Source")))


def hops_components(root: Chunk) -> list[HopsInfo]:
    """Every Hops component of a definition: URL, inputs and outputs (names, kinds, wires)."""
    found = []
    for obj in definition_objects(root):
        if obj.get("GUID") != HOPS_GUID:
            continue
        c = obj.find("Container")
        pd = c.find("ParameterData") if c else None
        if c is None or pd is None:
            raise GhxError("Hops object without Container/ParameterData")
        in_ids, out_ids = pd.indexed("InputId"), pd.indexed("OutputId")
        ins = [_hops_param(ch, in_ids[ch.index]) for ch in pd.children("InputParam")]
        outs = [_hops_param(ch, out_ids[ch.index]) for ch in pd.children("OutputParam")]
        found.append(HopsInfo(c.get("RemoteDefinitionLocation"), c.get("InstanceGuid"), c.get("Description"),
                              tuple(ins), tuple(outs)))
    return found


def uri_of(url: str) -> str:
    """The component URI of a Hops URL: ``http://127.0.0.1:5000/metrics/planarity`` → ``metrics/planarity``."""
    m = re.match(r"^[a-z]+://[^/]+/(.*)$", url)
    return (m.group(1) if m else url).strip("/")

"""Hostile inputs for the abuse tests and ``benchmarks/abuse.py``: decompression bombs, huge JSON, slow clients.

A *mesh bomb* is a genuine rhino3dm/RhinoCommon mesh archive (chunk CRCs, buffer CRCs and zlib streams all
valid) whose vertex buffers are zlib-compressed zeros: a few kilobytes of request declare and inflate to
gigabytes. The zlib streams are built without compressing gigabytes: after a full flush deflate starts afresh,
so one compressed block of zeros repeats verbatim.
"""
from __future__ import annotations

import json
import struct
import zlib

from ghserver._onmesh import (_EMPTY_FBOX, _EMPTY_TBOX, _I32, _IDENTITY_XFORM, _JSON_VERSION, _MESH_MAJOR,
                              _MESH_MINOR, _MESH_UUID, _TCODE_ANONYMOUS, _TCODE_CLASS, _TCODE_CLASS_DATA,
                              _TCODE_CLASS_END, _TCODE_CLASS_UUID, _U32, _UNSET8, _UNSET_BBOX, _WRITE_ARCHIVE,
                              _WRITE_OPENNURBS, _Writer)

BLOCK = 16 * 2**20
_ZERO_BLOCK = bytes(BLOCK)
_cache: dict = {}


def _block_stream():
    """``(header + first block, a repeated block)`` of a zlib stream of zeros cut by full flushes."""
    if "blocks" not in _cache:
        co = zlib.compressobj(9)
        first = co.compress(_ZERO_BLOCK) + co.flush(zlib.Z_FULL_FLUSH)
        again = co.compress(_ZERO_BLOCK) + co.flush(zlib.Z_FULL_FLUSH)
        _cache["blocks"] = first, again
    return _cache["blocks"]


def zero_stream(n: int) -> bytes:
    """A valid zlib stream inflating to ``n`` zero bytes (about n / 1000 bytes long)."""
    if n <= 4 * BLOCK:
        return zlib.compress(bytes(n), 9)
    first, again = _block_stream()
    q, r = divmod(n, BLOCK)
    co = zlib.compressobj(9)
    co.compress(_ZERO_BLOCK)
    co.flush(zlib.Z_FULL_FLUSH)  # the state after the first block: the tail below continues from it
    tail = co.compress(bytes(r)) + co.flush(zlib.Z_FINISH)
    adler = (((n % 65521) << 16) | 1)  # adler32 of n zeros: a stays 1, b counts the bytes
    return first + again * (q - 1) + tail[:-4] + struct.pack(">I", adler)


def zero_crc(n: int) -> int:
    """CRC-32 of ``n`` zero bytes."""
    crc = 0
    q, r = divmod(n, BLOCK)
    for _ in range(q):
        crc = zlib.crc32(_ZERO_BLOCK, crc)
    return zlib.crc32(bytes(r), crc)


def _zero_buffer(w: _Writer, n: int) -> None:
    """An openNURBS compressed buffer holding ``n`` zero bytes."""
    w.write(_U32.pack(n))
    w.write(struct.pack("<IB", zero_crc(n), 1))
    w.begin(_TCODE_ANONYMOUS)
    w.write(zero_stream(n))
    w.end()


def mesh_bomb(vcount: int, double: bool = True) -> dict:
    """A valid ON_Mesh archive (``Mesh.Encode()`` dict) of ``vcount`` vertices at the origin and no faces, whose
    vertex buffers (float, and double when ``double``) are compressed zeros: it inflates to 12 (+ 24) bytes
    per vertex."""
    import base64

    w = _Writer()
    w.begin(_TCODE_CLASS)
    w.begin(_TCODE_CLASS_UUID)
    w.write(_MESH_UUID)
    w.end()
    w.begin(_TCODE_CLASS_DATA)
    w.write(bytes([_MESH_MAJOR << 4 | _MESH_MINOR]) + struct.pack("<ii", vcount, 0) + _UNSET8 + bytes(16)
            + _EMPTY_FBOX + _EMPTY_FBOX + _EMPTY_TBOX + _I32.pack(-1) + bytes(5))
    w.write(_I32.pack(4))  # face index size; no faces follow
    _zero_buffer(w, 12 * vcount)
    w.write(bytes(12))  # no normals, texture coordinates, curvatures
    w.write(bytes(4))  # no colours
    w.write(bytes(4 + 16 + 4))  # texture rotation, mapping id, no surface parameters
    w.begin(_TCODE_ANONYMOUS)
    w.write(struct.pack("<ii", 1, 1) + bytes(20) + _IDENTITY_XFORM + bytes(4))
    w.end()
    w.write(bytes(3) + b"\x00")  # manifold/oriented/solid, no n-gons
    if double:
        w.write(b"\x01")
        w.begin(_TCODE_ANONYMOUS)
        w.write(struct.pack("<ii", 1, 0) + _U32.pack(vcount))
        _zero_buffer(w, 24 * vcount)
        w.end()
    else:
        w.write(b"\x00")
    w.write(_UNSET_BBOX)
    w.end()
    w.short(_TCODE_CLASS_END, 0)
    w.end()
    return {"version": _JSON_VERSION, "archive3dm": _WRITE_ARCHIVE, "opennurbs": _WRITE_OPENNURBS,
            "data": base64.b64encode(w.getvalue()).decode("ascii")}


def mesh_item(blob: dict) -> dict:
    return {"type": "Rhino.Geometry.Mesh", "data": json.dumps(blob)}


def solve_body(pointer: str, trees: list) -> bytes:
    body = {"absolutetolerance": 0.001, "angletolerance": 1.0, "modelunits": "Meters", "dataversion": 7,
            "algo": None, "pointer": pointer, "cachesolve": True, "values": trees, "warnings": [], "errors": []}
    return json.dumps(body).encode()


def bomb_body(pointer: str, name: str, vcount: int, copies: int = 1) -> bytes:
    """A solve request with ``copies`` mesh bombs of ``vcount`` vertices in one branch of input ``name``."""
    item = mesh_item(mesh_bomb(vcount))
    return solve_body(pointer, [{"ParamName": name, "InnerTree": {"{0}": [item] * copies}}])


def empty_objects_body(mb: float) -> bytes:
    """A request of ``mb`` megabytes of ``{},{},…``: 26 times its size once parsed by ``json.loads``."""
    n = int(mb * 2**20 / 3)
    return b'{"pointer": "echo/scale", "values": [' + b"{}," * (n - 1) + b"{}]}"


def long_integer_body(digits: int = 5000) -> bytes:
    """A request whose top-level ``absolutetolerance`` is an integer of ``digits`` digits."""
    return b'{"pointer": "echo/scale", "absolutetolerance": ' + b"7" * digits + b', "values": []}'

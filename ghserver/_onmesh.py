"""Direct numpy codec for the openNURBS binary archive of an ``ON_Mesh``.

rhino3dm's ``CommonObject.Encode()`` (and RhinoCommon's ``ToJSON``, used by
Grasshopper Hops) wraps one object in a dict::

    {"version": 10000, "archive3dm": 60, "opennurbs": <int>,
     "data": "<base64 of the ON_BinaryArchive::WriteObject() bytes>"}

Building or reading a mesh through rhino3dm costs a per-vertex Python loop,
so this module reads and writes those bytes directly with numpy, ``struct``
and ``zlib``.  It never imports rhino3dm.

Format summary (3dm archive version >= 50: little endian, 8-byte chunk values)
---------------------------------------------------------------------------
A *chunk* is ``uint32 typecode`` + ``int64 value``.  When the typecode's
``TCODE_SHORT`` bit (0x80000000) is clear, the value is the byte length of
the body that follows; if the typecode also has the ``TCODE_CRC`` bit
(0x8000), the last 4 bytes of the body are the zlib CRC-32 of the chunk's
*own* bytes, i.e. the body without the CRC and without any nested chunk
(headers included).  An object is written as::

    TCODE_OPENNURBS_CLASS (0x00027FFA)              no CRC
      TCODE_OPENNURBS_CLASS_UUID (0x0002FFFB)       16-byte class UUID + CRC
      TCODE_OPENNURBS_CLASS_DATA (0x0002FFFC)       ON_Mesh::Write() + CRC
      [TCODE_OPENNURBS_CLASS_USERDATA chunks]       (rejected here)
      TCODE_OPENNURBS_CLASS_END (0x80027FFF)        short chunk, value 0

``ON_Mesh::Write`` (chunk version 3.8 in archives >= 60) stores counts,
legacy domains and float boxes, the face array as 4 indices per face in 1, 2
or 4 byte integers (depending on the vertex count), the float vertices and
optional normals, texture coordinates, curvatures and colours as
*compressed buffers*, surface parameters, a mapping-tag chunk, a few flags,
optional n-gons, optional double precision vertices (a sub-chunk holding one
more compressed buffer) and the vertex bounding box.

A compressed buffer is ``uint32 size``; when non-zero it is followed by
``uint32 crc32(uncompressed)`` and a method byte: 0 = raw bytes follow,
1 = an anonymous chunk (0x40008000) holding a zlib stream plus the chunk CRC.
openNURBS compresses buffers larger than 128 bytes unless the archive was
told not to (``ON_BinaryArchive::SetUseBufferCompression(false)``); readers
accept either method for any size.

Vertex colours are an array of ``ON_Color``, 4 bytes per vertex in the byte
order red, green, blue, *transparency* (``ON_Color::kRedByteIndex`` = 0 ...
``kAlphaByteIndex`` = 3 on every platform; openNURBS' "alpha" byte is 0 for
opaque).  rhino3dm and RhinoCommon report ``alpha = 255 - byte``, so
``VertexColors.Add(r, g, b)`` stores ``r g b 00`` and reads back as
``(r, g, b, 255)``.  The buffer is written only when there is one colour per
vertex.
"""
from __future__ import annotations

import base64
import binascii
import logging
import struct
import zlib
from typing import NamedTuple

import numpy as np

__all__ = ["TooLarge", "mesh_counts", "object_archive", "read_mesh", "read_mesh_colors", "write_mesh"]

logger = logging.getLogger(__name__)

# ---------------------------------------------------------------------------
# constants of the 3dm format
# ---------------------------------------------------------------------------
_TCODE_SHORT = 0x80000000
_TCODE_CRC = 0x00008000
_TCODE_CLASS = 0x00027FFA
_TCODE_CLASS_UUID = 0x0002FFFB
_TCODE_CLASS_DATA = 0x0002FFFC
_TCODE_CLASS_USERDATA = 0x00027FFD
_TCODE_CLASS_END = 0x80027FFF
_TCODE_ANONYMOUS = 0x40008000

#: ON_Mesh class id {4ED7D4E4-E947-11d3-BFE5-0010830122F0} in archive byte order.
_MESH_UUID = struct.pack("<IHH8s", 0x4ED7D4E4, 0xE947, 0x11D3, bytes.fromhex("BFE50010830122F0"))

_JSON_VERSION = 10000
#: Archive versions whose mesh record this module understands (V6, V7, V8).
_READ_ARCHIVES = (60, 70, 80)
_WRITE_ARCHIVE = 60
#: ON_Mesh::Read only reads the mapping tag and later fields from archives
#: written by openNURBS 200606010 or newer (as an unsigned 32-bit number).
_MIN_OPENNURBS = 200606010
#: openNURBS version number that rhino3dm 8.x puts in the ``"opennurbs"`` field.
_WRITE_OPENNURBS = -1869833980

_MESH_MAJOR = 3
_MESH_MINOR = 8  # 3.8: double precision vertex chunk + vertex bounding box

_ON_UNSET_VALUE = -1.23432101234321e308
_UNSET8 = struct.pack("<8d", *([_ON_UNSET_VALUE] * 8))
_UNSET_BBOX = struct.pack("<6d", *([_ON_UNSET_VALUE] * 6))
_EMPTY_FBOX = struct.pack("<6f", 1.0, 1.0, 1.0, -1.0, -1.0, -1.0)
_EMPTY_TBOX = struct.pack("<4f", 1.0, 1.0, -1.0, -1.0)
_IDENTITY_XFORM = np.eye(4, dtype="<f8").tobytes()

#: Buffers up to this many bytes are always stored raw by openNURBS.
_MIN_COMPRESS = 128

_U32 = struct.Struct("<I")
_I32 = struct.Struct("<i")
_HEADER = struct.Struct("<Iq")


class _Invalid(Exception):
    """Raised internally when the archive is not one this module fully understands."""


class TooLarge(ValueError):
    """The archive declares more vertices or faces than the caller allows (raised before any allocation).

    ``what`` is ``"vertices"`` or ``"faces"``, ``count`` the declared number and ``key`` the limit's name
    (``"max_vertices"`` / ``"max_faces"``), ``limit`` its value.
    """

    def __init__(self, what: str, count: int, key: str, limit: int):
        super().__init__(f"{count} {what} is more than the limit of {limit}")
        self.what, self.count, self.key, self.limit = what, count, key, limit


# ---------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------
class _Frame:
    """Bookkeeping of one open chunk while reading."""

    __slots__ = ("typecode", "end", "crc", "seg_start")

    def __init__(self, typecode: int, end: int, has_crc: bool, seg_start: int):
        self.typecode = typecode
        self.end = end
        self.crc = 0 if has_crc else None
        self.seg_start = seg_start


class _Reader:
    """Cursor over archive bytes that tracks nested chunks and their CRCs.

    Parameters
    ----------
    buf : bytes
        The whole archive.

    Notes
    -----
    The CRC of a chunk covers only its own bytes, so the reader accumulates
    contiguous *segments* of the innermost chunk and folds a segment into the
    running CRC whenever a nested chunk starts or the chunk ends.
    """

    def __init__(self, buf: bytes):
        self.buf = buf
        self.mv = memoryview(buf)
        self.pos = 0
        self.stack: list[_Frame] = []

    # -- primitives ---------------------------------------------------------
    def _limit(self) -> int:
        if self.stack:
            f = self.stack[-1]
            return f.end - (4 if f.crc is not None else 0)
        return len(self.buf)

    def take(self, n: int) -> int:
        """Reserve ``n`` bytes inside the current chunk and return their offset."""
        if n < 0 or self.pos + n > self._limit():
            raise _Invalid("read past the end of a chunk")
        p = self.pos
        self.pos = p + n
        return p

    def u8(self) -> int:
        return self.buf[self.take(1)]

    def flag(self) -> bool:
        b = self.u8()
        if b > 1:
            raise _Invalid("bool byte is neither 0 nor 1")
        return b == 1

    def u32(self) -> int:
        return _U32.unpack_from(self.buf, self.take(4))[0]

    def i32(self) -> int:
        return _I32.unpack_from(self.buf, self.take(4))[0]

    def raw(self, n: int) -> memoryview:
        p = self.take(n)
        return self.mv[p:p + n]

    def skip(self, n: int) -> None:
        self.take(n)

    # -- chunks ---------------------------------------------------------------
    def _fold(self) -> None:
        """Fold the pending segment of the innermost chunk into its CRC."""
        if self.stack:
            f = self.stack[-1]
            if f.crc is not None and self.pos > f.seg_start:
                f.crc = zlib.crc32(self.mv[f.seg_start:self.pos], f.crc)
            f.seg_start = self.pos

    def begin(self, expected: int | None = None) -> tuple[int, int]:
        """Start reading a chunk; return ``(typecode, value)``.

        For a long chunk a frame is pushed and :meth:`end` must be called;
        short chunks are complete after this call.
        """
        self._fold()
        start = self.pos
        if start + 12 > self._limit():
            raise _Invalid("truncated chunk header")
        typecode, value = _HEADER.unpack_from(self.buf, start)
        if expected is not None and typecode != expected:
            raise _Invalid(f"expected chunk 0x{expected:08X}, found 0x{typecode:08X}")
        self.pos = start + 12
        if typecode & _TCODE_SHORT:
            if self.stack:
                self.stack[-1].seg_start = self.pos
            return typecode, value
        has_crc = bool(typecode & _TCODE_CRC)
        if value < (4 if has_crc else 0) or self.pos + value > self._limit():
            raise _Invalid("chunk length out of range")
        self.stack.append(_Frame(typecode, self.pos + value, has_crc, self.pos))
        return typecode, value

    def end(self, *, exact: bool = True) -> None:
        """Finish the innermost chunk, verifying its CRC.

        Parameters
        ----------
        exact : bool
            Require that the whole body was consumed (``True``), or skip the
            rest of the chunk without checking its CRC (``False``; used for
            chunks that are not parsed).
        """
        f = self.stack[-1]
        body_end = f.end - (4 if f.crc is not None else 0)
        if exact:
            if self.pos != body_end:
                raise _Invalid("chunk not fully consumed")
            if f.crc is not None:
                self._fold()
                if _U32.unpack_from(self.buf, body_end)[0] != f.crc:
                    raise _Invalid(f"CRC mismatch in chunk 0x{f.typecode:08X}")
        self.stack.pop()
        self.pos = f.end
        if self.stack:
            self.stack[-1].seg_start = self.pos

    def skip_chunk(self, expected: int) -> None:
        """Skip one complete long chunk (structure checked, content not parsed)."""
        typecode, _ = self.begin(expected)
        if typecode & _TCODE_SHORT:
            raise _Invalid("expected a long chunk")
        self.end(exact=False)

    # -- compressed buffers --------------------------------------------------
    def compressed_buffer(self, expected_size: int | None, *, decode: bool = True):
        """Read one openNURBS compressed buffer.

        Parameters
        ----------
        expected_size : int or None
            Required uncompressed size when the stored size is non-zero
            (``None``: any size).
        decode : bool
            Return the uncompressed bytes (``True``) or only check the
            structure and the chunk CRC of a buffer whose content is not
            needed (``False``).

        Returns
        -------
        bytes, memoryview or None
            The uncompressed bytes (a view into the archive for raw buffers),
            or ``None`` for an empty buffer or when ``decode`` is false.
        """
        size = self.u32()
        if size == 0:
            return None
        if expected_size is not None and size != expected_size:
            raise _Invalid("compressed buffer has the wrong size")
        crc = self.u32()
        method = self.u8()
        if method == 0:
            data = self.raw(size)
            if zlib.crc32(data) != crc:
                raise _Invalid("compressed buffer CRC mismatch")
            return data if decode else None
        if method != 1:
            raise _Invalid("unknown buffer compression method")
        _, length = self.begin(_TCODE_ANONYMOUS)
        comp = self.raw(length - 4)
        self.end()  # verifies the CRC of the compressed bytes
        if not decode:
            return None
        inflater = zlib.decompressobj()
        data = inflater.decompress(comp, size + 1)
        if len(data) != size or not inflater.eof:
            raise _Invalid("compressed buffer does not inflate to its size")
        if zlib.crc32(data) != crc:
            raise _Invalid("compressed buffer CRC mismatch")
        return data


def _decode_payload(obj: dict) -> bytes:
    """Validate the JSON envelope and return the archive bytes."""
    if not isinstance(obj, dict):
        raise _Invalid("not a dict")
    version = obj.get("version")
    archive = obj.get("archive3dm")
    if type(version) is not int or version != _JSON_VERSION:
        raise _Invalid(f"unsupported envelope version {version!r}")
    if type(archive) is not int or archive not in _READ_ARCHIVES:
        raise _Invalid(f"unsupported archive3dm {archive!r}")
    opennurbs = obj.get("opennurbs")
    if type(opennurbs) is not int or (opennurbs & 0xFFFFFFFF) < _MIN_OPENNURBS:
        # older writers lack fields that ON_Mesh::Read only expects from newer ones
        raise _Invalid(f"unsupported opennurbs version {opennurbs!r}")
    data = obj.get("data")
    if not isinstance(data, str):
        raise _Invalid("data is not a string")
    # binascii accepts an ASCII str without copying it; strict mode rejects
    # anything that is not canonical base64
    return binascii.a2b_base64(data, strict_mode=True)


def _check_counts(vcount: int, fcount: int, limits: dict | None) -> None:
    """Raise :class:`TooLarge` when declared counts pass ``limits`` (``max_vertices``, ``max_faces``)."""
    for count, what, key in ((vcount, "vertices", "max_vertices"), (fcount, "faces", "max_faces")):
        limit = (limits or {}).get(key)
        if limit and count > limit:
            raise TooLarge(what, count, key, limit)


def _read_mesh_record(r: _Reader, colors: bool = False, limits: dict | None = None):
    """Parse the body of a ``TCODE_OPENNURBS_CLASS_DATA`` chunk holding an ON_Mesh.

    Returns ``(V, F, C)``; ``C`` is ``None`` unless ``colors`` is true and the
    mesh has vertex colours (then ``(n, 4)`` uint8 RGBA, alpha 255 = opaque).
    The declared counts are checked against ``limits`` before anything is
    inflated or allocated.
    """
    buf = r.buf
    version = r.u8()
    if (version >> 4, version & 15) != (_MESH_MAJOR, _MESH_MINOR):
        raise _Invalid(f"unsupported ON_Mesh chunk version {version >> 4}.{version & 15}")
    vcount = r.i32()
    fcount = r.i32()
    if vcount < 0 or fcount < 0:
        raise _Invalid("negative counts")
    _check_counts(vcount, fcount, limits)
    # packed texture domain, surface domain (4 intervals), surface scale (2 doubles),
    # float vertex box (6 floats), normal box (6 floats), texture box (4 floats),
    # closed flag (int)
    r.skip(64 + 16 + 24 + 24 + 16 + 4)
    if r.u8():  # mesh parameters
        r.skip_chunk(_TCODE_ANONYMOUS)
    for _ in range(4):  # curvature statistics
        if r.u8():
            r.skip_chunk(_TCODE_ANONYMOUS)

    # face array
    isize = r.i32()
    dtype = {1: "<u1", 2: "<u2", 4: "<i4"}.get(isize)
    if dtype is None:
        raise _Invalid(f"bad face index size {isize}")
    p = r.take(4 * isize * fcount)
    F = np.frombuffer(buf, dtype=dtype, count=4 * fcount, offset=p).reshape(fcount, 4).astype(np.int64)

    # vertices, normals, texture coordinates, curvatures, colours
    fV = None
    C = None
    if vcount > 0:
        data = r.compressed_buffer(12 * vcount)
        if data is None:
            raise _Invalid("mesh has vertices but no vertex buffer")
        fV = np.frombuffer(data, dtype="<f4").reshape(vcount, 3)
        for elem in (12, 8, 16):  # normals, texture coordinates, curvatures
            r.compressed_buffer(elem * vcount, decode=False)
        data = r.compressed_buffer(4 * vcount, decode=colors)
        if data is not None:
            C = np.frombuffer(data, dtype=np.uint8).reshape(vcount, 4).copy()
            C[:, 3] = 255 - C[:, 3]  # openNURBS transparency -> alpha

    r.skip(4)  # packed texture rotation flag
    r.skip(16)  # texture mapping id
    if vcount > 0:
        r.compressed_buffer(16 * vcount, decode=False)  # surface parameters
    _read_mapping_tag(r)
    r.skip(3)  # manifold, oriented, solid
    ngons = _read_ngons(r) if r.flag() else None
    dV = None
    if r.flag():
        dV = _read_double_vertices(r)
    r.skip(48)  # vertex bounding box

    if dV is None:
        V = fV.astype(np.float64) if fV is not None else np.zeros((0, 3))
    else:
        if dV.shape[0] != vcount:
            raise _Invalid("double precision vertex count differs from vertex count")
        _check_double_vertices(dV, fV)
        V = dV
    return V, _polygon_faces(F, ngons, vcount), C


def _read_mapping_tag(r: _Reader) -> None:
    """Read (and discard) the ``ON_MappingTag`` chunk."""
    r.begin(_TCODE_ANONYMOUS)
    major, minor = r.i32(), r.i32()
    if major != 1 or minor not in (0, 1):
        raise _Invalid("unsupported mapping tag version")
    r.skip(16 + 4 + 128)  # mapping id, mapping crc, mesh transformation
    if minor == 1:
        r.skip(4)  # mapping type
    r.end()


#: n-gons with more corners are read as their faces (see :func:`_polygon_faces`)
MAX_NGON_CORNERS = 32


def _unique_rows(K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The distinct rows of an ``(r, 2)`` integer array (sorted) and how often each occurs (``np.unique(axis=0)``,
    without its slow sort of row records)."""
    K = K[np.lexsort((K[:, 1], K[:, 0]))]
    new = np.r_[True, (K[1:] != K[:-1]).any(axis=1)] if len(K) else np.zeros(0, dtype=bool)
    at = np.flatnonzero(new)
    return K[at], np.diff(np.r_[at, len(K)])


class _Ngons(NamedTuple):
    """N-gons as flat arrays: per n-gon its vertex and face counts, then all vertex and all face indices."""

    nv: np.ndarray
    nf: np.ndarray
    vi: np.ndarray
    fi: np.ndarray


def _read_ngons(r: _Reader) -> _Ngons:
    """Read the n-gon chunk (per n-gon ``nv, nf``, its outer boundary's ``nv`` vertices in order, its ``nf``
    faces; uint32 all)."""
    _, length = r.begin(_TCODE_ANONYMOUS)
    r.i32()
    r.i32()  # chunk version
    count = r.u32()
    rest = length - 4 - 12  # the body after version and count, less the CRC
    if rest < 0 or rest % 4:
        raise _Invalid("n-gon chunk length")
    words = np.frombuffer(r.buf, dtype="<u4", count=rest // 4, offset=r.take(rest)).astype(np.int64)
    w = words.tolist()  # the records have their own lengths: one pass over plain ints
    nv, nf, starts, at = [], [], [], 0
    for _ in range(count):
        if at >= len(w):
            raise _Invalid("n-gon chunk truncated")
        if w[at] == 0:  # an empty n-gon: its count only
            at += 1
            continue
        if at + 2 > len(w):
            raise _Invalid("n-gon chunk truncated")
        nv.append(w[at])
        nf.append(w[at + 1])
        starts.append(at + 2)
        at += 2 + w[at] + w[at + 1]
    if at != len(w):
        raise _Invalid("n-gon records do not fill their chunk")
    r.end()
    nv, nf, starts = (np.array(x, dtype=np.int64) for x in (nv, nf, starts))
    vpos = np.repeat(starts - np.r_[0, np.cumsum(nv)[:-1]], nv) + np.arange(int(nv.sum()))
    fpos = np.repeat(starts + nv - np.r_[0, np.cumsum(nf)[:-1]], nf) + np.arange(int(nf.sum()))
    return _Ngons(nv, nf, words[vpos], words[fpos])


def _polygon_faces(F: np.ndarray, ngons: _Ngons | None, vcount: int) -> np.ndarray:
    """``F (m, 4)`` with the faces of every n-gon replaced by one polygon face (its boundary vertices, run as its
    faces run), at the place of its first face, padded by repeating each face's last vertex to the largest corner
    count.

    An n-gon is used only when it is a simple polygon over its faces: every index in range, three to
    :data:`MAX_NGON_CORNERS` distinct boundary vertices (a larger one, a whole flat region rather than a panel,
    would widen every row of ``F``), faces in no other n-gon, and the edges its faces do not share with each other
    are exactly the consecutive pairs of its boundary (no hole, no stray face, no edge of three faces); others are
    ignored (their faces kept), as openNURBS skips a corrupt n-gon. One-face n-gons (Rhino may make one for every
    face) change nothing.
    """
    m = len(F)
    if ngons is None or len(ngons.nv) == 0 or m == 0:
        return F
    nv, nf, vi, fi = ngons
    g = len(nv)
    gv, gf = np.repeat(np.arange(g), nv), np.repeat(np.arange(g), nf)
    ok = (nv >= 3) & (nv <= MAX_NGON_CORNERS) & (nf >= 2)  # one face: the face itself
    ok &= np.bincount(gv, weights=vi >= vcount, minlength=g) == 0
    ok &= np.bincount(gf, weights=fi >= m, minlength=g) == 0
    vkey = gv * (vcount + 1) + np.minimum(vi, vcount)  # distinct vertices within an n-gon (out of range: vcount)
    s = np.sort(vkey)
    ok[s[1:][s[1:] == s[:-1]] // (vcount + 1)] = False
    # a face in two n-gons (or twice in one): neither is used
    cf = ok[gf]
    faces, seen = np.unique(fi[cf], return_counts=True)
    shared = np.isin(fi, faces[seen > 1]) & cf
    ok[gf[shared]] = False
    # the outline: the faces' unshared edges are the boundary's edges
    cf = ok[gf]
    A = F[fi[cf]]
    a, b, ge = A.ravel(), np.roll(A, -1, axis=1).ravel(), np.repeat(gf[cf], 4)
    real = a != b  # a triangle's repeated corner is no edge
    a, b, ge = a[real], b[real], ge[real]
    n = np.int64(max(vcount, 1))
    edges, count = _unique_rows(np.stack([ge, np.minimum(a, b) * n + np.maximum(a, b)], axis=1))
    ok[edges[count > 2, 0]] = False
    cv = ok[gv]
    start = np.r_[0, np.cumsum(nv)[:-1]]
    nxt = np.arange(len(vi)) + 1
    nxt[start + nv - 1] = start  # each boundary vertex's successor, around its own n-gon
    ring = np.stack([gv, np.minimum(vi, vi[nxt]) * n + np.maximum(vi, vi[nxt])], axis=1)[cv]
    border = edges[count == 1]
    border = border[ok[border[:, 0]]]
    both, twice = _unique_rows(np.concatenate([border, ring]))
    ok[both[twice != 2, 0]] = False  # an edge of the outline or of the faces' border only
    if not ok.any():
        return F
    # each n-gon's first boundary edge, run the way its faces run: forward; else the boundary is reversed
    v0, v1 = vi[start], vi[start + 1]
    forward = np.zeros(g, dtype=bool)
    forward[ge[(a == v0[ge]) & (b == v1[ge])]] = True
    # the polygon rows
    good = np.flatnonzero(ok)
    owner = np.full(m, -1, dtype=np.int64)
    owner[fi[ok[gf]]] = gf[ok[gf]]
    first = np.full(g, m, dtype=np.int64)
    np.minimum.at(first, owner[owner >= 0], np.flatnonzero(owner >= 0))
    rows = (owner < 0) | (np.arange(m) == first[np.maximum(owner, 0)])  # plain faces and each n-gon's first face
    k = max(4, int(nv[good].max()))
    out = np.empty((m, k), dtype=np.int64)
    out[:, :4] = F
    out[:, 4:] = F[:, 3:4]
    sel = ok[gv]
    pos = (np.arange(len(vi)) - start[gv])[sel]
    rev = ~forward[gv[sel]]
    pos = np.where(rev, nv[gv[sel]] - 1 - pos, pos)
    r = first[gv[sel]]
    last = np.where(forward[good], vi[start[good] + nv[good] - 1], vi[start[good]])
    out[first[good]] = last[:, None]
    out[r, pos] = vi[sel]
    return out[rows]


def _read_double_vertices(r: _Reader) -> np.ndarray:
    """Read the double precision vertex chunk (version 1.x)."""
    r.begin(_TCODE_ANONYMOUS)
    major, minor = r.i32(), r.i32()
    if major != 1 or minor != 0:
        raise _Invalid("unsupported double precision vertex chunk version")
    count = r.u32()
    dV = np.zeros((0, 3))
    if count:
        data = r.compressed_buffer(24 * count)
        if data is None:
            raise _Invalid("double precision vertex buffer is empty")
        dV = np.frombuffer(data, dtype="<f8").reshape(count, 3).copy()
    r.end()
    return dV


def _check_double_vertices(dV: np.ndarray, fV: np.ndarray | None) -> None:
    """Reject archives whose double and float vertices disagree.

    openNURBS discards the double precision vertices in that case (relative
    tolerance 1e-6 in float arithmetic); rather than imitate that edge case,
    the archive is left to the rhino3dm fallback.
    """
    if fV is None or dV.shape[0] == 0:
        return
    fd = dV.astype(np.float32)
    if np.array_equal(fd, fV):  # the usual case: float copy rounded from the doubles
        return
    with np.errstate(all="ignore"):
        diff = np.abs(fd - fV).max(axis=1)
        scale = np.abs(fV).max(axis=1).astype(np.float64)
        ok = diff.astype(np.float64) <= scale * 1.0e-6
    if not bool(ok.all()):
        raise _Invalid("float and double precision vertices disagree")


def _read(obj: dict, colors: bool, name: str, limits: dict | None = None):
    """Shared body of :func:`read_mesh` and :func:`read_mesh_colors`."""
    try:
        buf = _decode_payload(obj)
        r = _Reader(buf)
        _, length = r.begin(_TCODE_CLASS)
        if r.pos + length != len(buf):
            raise _Invalid("object chunk does not span the whole payload")
        _, length = r.begin(_TCODE_CLASS_UUID)
        if length != 20 or bytes(r.raw(16)) != _MESH_UUID:
            raise _Invalid("not an ON_Mesh")
        r.end()
        r.begin(_TCODE_CLASS_DATA)
        result = _read_mesh_record(r, colors, limits)
        r.end()
        typecode, value = r.begin()  # a short chunk is complete after begin()
        if typecode != _TCODE_CLASS_END or value != 0:
            # TCODE_OPENNURBS_CLASS_USERDATA or anything else: leave it to rhino3dm
            raise _Invalid(f"unsupported chunk 0x{typecode:08X} after mesh data")
        r.end()  # TCODE_OPENNURBS_CLASS, which spans the whole payload
        return result
    except _Invalid as exc:
        logger.debug("%s: falling back (%s)", name, exc)
    except TooLarge:
        raise  # over the caller's limits: no fallback may decode it again
    except (ValueError, TypeError, KeyError, IndexError, OverflowError,
            struct.error, zlib.error, binascii.Error) as exc:  # defensive: never raise on garbage
        logger.debug("%s: falling back (%s: %s)", name, type(exc).__name__, exc)
    return None


def read_mesh(obj: dict, limits: dict | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """Read vertices and faces from a JSON-encoded openNURBS mesh.

    Parameters
    ----------
    obj : dict
        ``{"version", "archive3dm", "opennurbs", "data"}`` as produced by
        rhino3dm's ``Mesh.Encode()`` or sent by RhinoCommon/Hops.
    limits : dict, optional
        ``max_vertices`` / ``max_faces``: declared counts beyond them raise
        :class:`TooLarge` before any buffer is inflated or allocated.

    Returns
    -------
    tuple of numpy.ndarray or None
        ``(V, F)`` with ``V`` of shape ``(n, 3)`` float64 (the double
        precision vertices when the archive holds them, else the float
        vertices) and ``F`` of shape ``(m, 4)`` int64 (triangles stored as
        ``(a, b, c, c)``), or ``(m, k)`` when the mesh has n-gons: each
        n-gon is one face of its boundary vertices, padded by repeating its
        last vertex (see :func:`_polygon_faces`).  ``None`` when the data is
        not an ON_Mesh in a layout this reader fully understands and verifies (unknown versions,
        user data, CRC or length mismatch, truncation, garbage); the caller
        should then fall back to rhino3dm.  Raises only :class:`TooLarge`
        (counts over ``limits``) and ``MemoryError``; neither should be
        decoded again by a fallback.

    Notes
    -----
    Normals, texture coordinates, colours, surface parameters, curvatures
    and mesh parameters are checked structurally and skipped; use
    :func:`read_mesh_colors` to get the vertex colours as well.
    """
    result = _read(obj, False, "read_mesh", limits)
    return None if result is None else result[:2]


#: offsets in an ON_Mesh object archive: class chunk (12), uuid chunk (12 + 16 + 4 CRC), class data chunk (12),
#: then the ON_Mesh chunk version byte and the vertex and face counts (int32 each)
_COUNTS_AT = 12 + 12 + 20 + 12
_PREFIX_CHARS = 4 * ((_COUNTS_AT + 9 + 2) // 3)


def mesh_counts(obj) -> tuple[int, int] | None:
    """The vertex and face counts an ON_Mesh archive declares, read from its first bytes only.

    Cheap (about 90 base64 characters are decoded, nothing is inflated), so a server can refuse an oversized
    mesh, or a request whose meshes add up to too much, before decoding any of them. ``None`` when the
    payload does not start like an ON_Mesh record of chunk version 3.x (the full readers then decide).
    Never raises.

    >>> import numpy as np
    >>> mesh_counts(write_mesh(np.zeros((5, 3)), [[0, 1, 2, 3], [1, 2, 3, 4]]))
    (5, 2)
    """
    try:
        data = obj.get("data") if isinstance(obj, dict) else None
        if not isinstance(data, str):
            return None
        head = binascii.a2b_base64(data[:_PREFIX_CHARS])
        if len(head) < _COUNTS_AT + 9:
            return None
        t0, _ = _HEADER.unpack_from(head, 0)
        t1, n1 = _HEADER.unpack_from(head, 12)
        t2, _ = _HEADER.unpack_from(head, 44)
        if (t0, t1, n1, t2) != (_TCODE_CLASS, _TCODE_CLASS_UUID, 20, _TCODE_CLASS_DATA) or head[24:40] != _MESH_UUID:
            return None
        if head[_COUNTS_AT] >> 4 != _MESH_MAJOR:
            return None
        vcount, fcount = struct.unpack_from("<ii", head, _COUNTS_AT + 1)
        if vcount < 0 or fcount < 0:
            return None
        return vcount, fcount
    except (ValueError, TypeError, struct.error, binascii.Error):
        return None


def object_archive(obj) -> bool:
    """Whether an encoded object's ``data`` starts like an openNURBS object archive: a class chunk that fits in the
    payload, then the class id chunk (20 bytes). Every object rhino3dm encodes does (meshes, curves, surfaces,
    Breps, points); random bytes that happen to be valid base64 do not, and rhino3dm's decoder can spin on them for
    tens of seconds before it gives up, so a server checks this first. Reads about 40 base64 characters; never
    raises.

    >>> object_archive(write_mesh(np.zeros((3, 3)), [[0, 1, 2, 2]])), object_archive({"data": "QUJDRA" * 20})
    (True, False)
    """
    try:
        data = obj.get("data") if isinstance(obj, dict) else None
        if not isinstance(data, str):
            return False
        head = binascii.a2b_base64(data[:40])
        t0, n0 = _HEADER.unpack_from(head, 0)
        t1, n1 = _HEADER.unpack_from(head, 12)
        return (t0 == _TCODE_CLASS and t1 == _TCODE_CLASS_UUID and n1 == 20
                and 0 < n0 <= 3 * len(data) // 4 - 12)
    except (ValueError, TypeError, struct.error, binascii.Error):
        return False


def read_mesh_colors(obj: dict, limits: dict | None = None
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None] | None:
    """Like :func:`read_mesh`, plus the per-vertex colours.

    Returns
    -------
    tuple or None
        ``(V, F, C)``: ``V`` and ``F`` as from :func:`read_mesh`; ``C`` is a
        ``(n, 4)`` uint8 array of RGBA colours (alpha 255 = opaque, as
        rhino3dm's ``mesh.VertexColors[i]`` reports them) or ``None`` when
        the mesh has no vertex colours.  ``None`` instead of the tuple
        whenever :func:`read_mesh` returns ``None``.  Never raises.
    """
    return _read(obj, True, "read_mesh_colors", limits)


# ---------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------
class _Writer:
    """Append-only archive writer with openNURBS chunk bookkeeping."""

    def __init__(self):
        self.parts: list[bytes] = []
        self.size = 0
        # open chunks: [header part index, body start, typecode, crc or None]
        self.stack: list[list] = []

    def write(self, b: bytes) -> None:
        self.parts.append(b)
        self.size += len(b)
        if self.stack:
            f = self.stack[-1]
            if f[3] is not None:
                f[3] = zlib.crc32(b, f[3])

    def begin(self, typecode: int) -> None:
        self.parts.append(b"")  # header, filled in by end()
        self.size += 12
        crc = 0 if typecode & _TCODE_CRC else None
        self.stack.append([len(self.parts) - 1, self.size, typecode, crc])

    def begin_versioned(self, major: int, minor: int) -> None:
        self.begin(_TCODE_ANONYMOUS)
        self.write(struct.pack("<ii", major, minor))

    def end(self) -> None:
        idx, start, typecode, crc = self.stack[-1]
        if crc is not None:
            self.write(_U32.pack(crc))
        self.stack.pop()
        self.parts[idx] = _HEADER.pack(typecode, self.size - start)

    def short(self, typecode: int, value: int = 0) -> None:
        self.parts.append(_HEADER.pack(typecode, value))
        self.size += 12

    def compressed_buffer(self, data: bytes, level: int | None) -> None:
        """Write an openNURBS compressed buffer (raw when ``level`` is None or data is small)."""
        self.write(_U32.pack(len(data)))
        if not data:
            return
        if level is None or len(data) <= _MIN_COMPRESS:
            self.write(struct.pack("<IB", zlib.crc32(data), 0))
            self.write(data)
        else:
            self.write(struct.pack("<IB", zlib.crc32(data), 1))
            self.begin(_TCODE_ANONYMOUS)
            self.write(zlib.compress(data, level))
            self.end()

    def getvalue(self) -> bytes:
        return b"".join(self.parts)


def _as_mesh_arrays(V, F) -> tuple[np.ndarray, np.ndarray]:
    """Validate and normalise the inputs of :func:`write_mesh`."""
    V = np.ascontiguousarray(V, dtype="<f8")
    if V.ndim != 2 or V.shape[1] != 3:
        raise ValueError(f"V must have shape (n, 3), got {V.shape}")
    if not np.isfinite(V).all():
        raise ValueError("V contains non-finite coordinates")
    if V.size and np.abs(V).max() > np.finfo(np.float32).max:
        raise ValueError("V exceeds the single precision range used by openNURBS")
    F = np.asarray(F)
    if F.ndim != 2 or F.shape[1] not in (3, 4):
        raise ValueError(f"F must have shape (m, 3) or (m, 4), got {F.shape}")
    if F.size and not np.issubdtype(F.dtype, np.integer):
        raise ValueError("F must hold integer vertex indices")
    if F.shape[1] == 3:
        F = np.concatenate([F, F[:, 2:3]], axis=1)
    n = V.shape[0]
    if n >= 2**31 or F.shape[0] >= 2**31:
        raise ValueError("mesh too large for the 3dm format")
    if F.size and (F.min() < 0 or F.max() >= n):
        raise ValueError("face index out of range")
    return V, F


def _ngon_bytes(ngons, vcount: int, fcount: int) -> bytes | None:
    """The body of the n-gon chunk after its version: count, then per n-gon ``nv, nf, vi..., fi...`` (uint32);
    None without n-gons. ``ngons``: ``[(vi, fi), ...]`` or :class:`_Ngons`."""
    if ngons is None or len(ngons) == 0 or (isinstance(ngons, _Ngons) and len(ngons.nv) == 0):
        return None
    if not isinstance(ngons, _Ngons):
        pairs = [(np.asarray(v, dtype=np.int64).ravel(), np.asarray(f, dtype=np.int64).ravel()) for v, f in ngons]
        ngons = _Ngons(np.array([len(v) for v, _ in pairs], dtype=np.int64),
                       np.array([len(f) for _, f in pairs], dtype=np.int64),
                       np.concatenate([v for v, _ in pairs]), np.concatenate([f for _, f in pairs]))
    nv, nf, vi, fi = (np.asarray(x, dtype=np.int64) for x in ngons)
    if (nv < 3).any() or (nf < 1).any():
        raise ValueError("an n-gon needs at least 3 vertices and 1 face")
    if len(vi) != nv.sum() or len(fi) != nf.sum():
        raise ValueError("n-gon counts do not match their indices")
    if vi.min() < 0 or vi.max() >= vcount or fi.min() < 0 or fi.max() >= fcount:
        raise ValueError("n-gon index out of range")
    size = 2 + nv + nf
    start = np.r_[0, np.cumsum(size)[:-1]] + 1  # after the count
    out = np.empty(1 + int(size.sum()), dtype="<u4")
    out[0] = len(nv)
    out[start] = nv
    out[start + 1] = nf
    out[np.repeat(start + 2 - np.r_[0, np.cumsum(nv)[:-1]], nv) + np.arange(len(vi))] = vi
    out[np.repeat(start + 2 + nv - np.r_[0, np.cumsum(nf)[:-1]], nf) + np.arange(len(fi))] = fi
    return out.tobytes()


def _as_color_bytes(colors, n: int) -> bytes:
    """Validate ``colors`` of :func:`write_mesh`; return the ``ON_Color`` array bytes."""
    C = np.asarray(colors)
    if C.ndim != 2 or C.shape[1] not in (3, 4):
        raise ValueError(f"colors must have shape (n, 3) or (n, 4), got {C.shape}")
    if C.shape[0] != n:
        raise ValueError(f"colors has {C.shape[0]} rows for {n} vertices")
    if C.dtype != np.uint8:
        if C.size and not np.issubdtype(C.dtype, np.integer):
            raise ValueError(f"colors must be uint8 (or integers 0..255), got {C.dtype}")
        if C.size and (C.min() < 0 or C.max() > 255):
            raise ValueError("colors out of the range 0..255")
    out = np.zeros((n, 4), dtype=np.uint8)  # transparency 0 = opaque when no alpha is given
    out[:, :3] = C[:, :3]
    if C.shape[1] == 4:
        np.subtract(255, C[:, 3], out=out[:, 3], casting="unsafe")  # alpha -> openNURBS transparency
    return out.tobytes()


def write_mesh(V, F, colors=None, *, ngons=None, compress_level: int | None = None) -> dict:
    """Encode vertices and faces as a JSON-ready openNURBS mesh.

    The result has the layout of rhino3dm's ``Mesh.Encode()`` for a mesh with
    double precision vertices (archive 60, ON_Mesh chunk version 3.8, no
    normals, no user data); ``rhino3dm.CommonObject.Decode`` and RhinoCommon
    read it back with exactly these vertices, faces and colours.

    Parameters
    ----------
    V : array_like, shape (n, 3)
        Vertex coordinates, stored in double precision plus the float copy
        openNURBS keeps alongside (rounded to nearest).
    F : array_like of int, shape (m, 4) or (m, 3)
        Faces; a triangle is ``(a, b, c, c)``, an ``(m, 3)`` array is padded
        that way.
    colors : array_like of uint8, shape (n, 3) or (n, 4), optional
        Per-vertex RGB or RGBA colours (alpha 255 = opaque, the default for
        RGB), as rhino3dm's ``mesh.VertexColors[i]`` reports them.  Integer
        arrays with values 0..255 are accepted too; floats are rejected.
    ngons : sequence of (vi, fi), optional
        N-gons: each one's outer boundary vertex indices in order and the
        indices of the faces (of ``F``) it is made of, written as openNURBS
        writes ``ON_Mesh::m_Ngon`` (Rhino shows and exports them as one
        polygon; :func:`read_mesh` gives them back as one face).
    compress_level : int or None, optional
        ``None`` (default) stores the vertex buffers raw, as openNURBS does
        for an archive with buffer compression disabled; this is several
        times faster to write but about 1.5-2x larger.  An integer 1-9 zlib
        compresses buffers over 128 bytes like openNURBS (rhino3dm uses 9).

    Returns
    -------
    dict
        ``{"version": 10000, "archive3dm": 60, "opennurbs": int, "data": str}``.

    Raises
    ------
    ValueError
        On malformed input: wrong shapes, non-finite or out-of-float-range
        coordinates, face indices out of range, a colour count other than
        the vertex count, colours that are not integers 0..255.
    """
    V, F = _as_mesh_arrays(V, F)
    vcount, fcount = V.shape[0], F.shape[0]
    cbytes = None if colors is None else _as_color_bytes(colors, vcount)
    nbytes = _ngon_bytes(ngons, vcount, fcount)
    if compress_level is not None and not 0 <= compress_level <= 9:
        raise ValueError("compress_level must be None or 0..9")

    w = _Writer()
    w.begin(_TCODE_CLASS)
    w.begin(_TCODE_CLASS_UUID)
    w.write(_MESH_UUID)
    w.end()
    w.begin(_TCODE_CLASS_DATA)
    w.write(
        bytes([_MESH_MAJOR << 4 | _MESH_MINOR])
        + struct.pack("<ii", vcount, fcount)
        + _UNSET8  # packed texture domain, surface domain
        + bytes(16)  # surface scale
        + _EMPTY_FBOX + _EMPTY_FBOX + _EMPTY_TBOX  # vertex, normal, texture boxes (unset)
        + _I32.pack(-1)  # closed: unknown
        + bytes(5)  # no mesh parameters, no curvature statistics
    )
    if vcount < 256:
        isize, dtype = 1, "<u1"
    elif vcount < 65536:
        isize, dtype = 2, "<u2"
    else:
        isize, dtype = 4, "<i4"
    w.write(_I32.pack(isize))
    if fcount:
        w.write(np.ascontiguousarray(F, dtype=dtype).tobytes())
    if vcount:
        w.compressed_buffer(V.astype("<f4").tobytes(), compress_level)
        w.write(bytes(12))  # no normals, texture coordinates, curvatures
        if cbytes is None:
            w.write(bytes(4))  # no colours
        else:
            w.compressed_buffer(cbytes, compress_level)
    w.write(bytes(4 + 16))  # packed texture rotation, texture mapping id
    if vcount:
        w.write(bytes(4))  # no surface parameters
    # mapping tag 1.1: nil id, crc 0, identity transformation, type 0
    w.begin_versioned(1, 1)
    w.write(bytes(20) + _IDENTITY_XFORM + bytes(4))
    w.end()
    w.write(bytes(3))  # manifold / oriented / solid: unknown
    if nbytes is None:
        w.write(b"\x00")  # no n-gons
    else:
        w.write(b"\x01")
        w.begin_versioned(1, 0)
        w.write(nbytes)
        w.end()
    if vcount:
        # double precision vertices (openNURBS writes none for an empty mesh)
        w.write(b"\x01")
        w.begin_versioned(1, 0)
        w.write(_U32.pack(vcount))
        w.compressed_buffer(V.tobytes(), compress_level)
        w.end()
    else:
        w.write(b"\x00")
    w.write(_UNSET_BBOX)  # vertex bounding box: computed on demand by the reader
    w.end()  # class data
    w.short(_TCODE_CLASS_END, 0)
    w.end()  # class
    return {
        "version": _JSON_VERSION,
        "archive3dm": _WRITE_ARCHIVE,
        "opennurbs": _WRITE_OPENNURBS,
        "data": base64.b64encode(w.getvalue()).decode("ascii"),
    }

"""rhino3dm ⇄ plain Python values. The only module of the project that imports rhino3dm.

* Mesh ⇄ ``(V, F)``: ``V (n, 3) float64`` (double-precision vertices), ``F (m, 4) int64`` with triangles as
  ``(a, b, c, c)``; a face with more than four corners is written as a triangle fan grouped into one n-gon (Rhino
  meshes hold triangles and quads; n-gons name the polygons they make up), and an n-gon is read back as one face
  of its boundary vertices (``F (m, k)``, padded by repeating a face's last vertex). Meshes are read and written
  through the openNURBS archive directly (:mod:`ghserver._onmesh`) when its layout is recognised, through rhino3dm
  objects otherwise.
* Curve ⇄ polyline ``(n, 3)`` array (PolylineCurve, LineCurve, polyline-shaped NURBS of degree 1) or
  :class:`components.core.types.NurbsCurve` (everything else, through ``ToNurbsCurve``).
* Surface → :class:`components.core.types.NurbsSurface` (a NurbsSurface, any Surface, or a one-face Brep).

Errors are :class:`DecodeError` with a message that says what was wrong; the protocol layer prefixes the input's
name.
"""
from __future__ import annotations

import binascii
import json
import logging
import struct
from pathlib import Path
from typing import NamedTuple

import numpy as np
import rhino3dm

from components.core.errors import InputError
from components.core.mesh import face_centroids, face_sizes, read_mesh, read_stl, triangulate
from components.core.types import NurbsCurve, NurbsSurface
from components.fabrication.nodes import beam_meshes
from components.fabrication.panels import closed_polylines, placed_outlines
from components.surfaces.generators import surface_mesh

log = logging.getLogger(__name__)

try:  # fast archive reader/writer (pure numpy); optional until it lands
    from ghserver import _onmesh
except ImportError:  # pragma: no cover
    _onmesh = None


class DecodeError(ValueError):
    """A geometry blob could not be decoded into the expected type."""


class TooLargeError(DecodeError):
    """A geometry blob declares more than the server's limits allow; refused before it is decoded (HTTP 413).

    ``key`` names the limit (``max_vertices``, ``max_faces``, ``max_inflated_mb``).
    """

    status = 413

    def __init__(self, message: str, key: str):
        super().__init__(message)
        self.key = key


#: bytes a rhino3dm decode may inflate from compressed buffers, per allowed vertex of the request (double and float
#: vertices, normals, texture coordinates, curvatures, colours, surface parameters: 92 bytes; rounded up)
INFLATED_BYTES_PER_VERTEX = 100
_ZLIB_BUFFER = b"\x01" + struct.pack("<I", 0x40008000)  # method byte 1 + the anonymous chunk holding the stream


def inflated_size(raw: bytes) -> int:
    """Upper bound of the bytes openNURBS inflates when reading the archive ``raw``.

    Every zlib-compressed buffer of an openNURBS archive is written as ``uint32 size, uint32 crc, 0x01`` followed
    by an anonymous chunk (typecode 0x40008000, int64 length) whose body starts with a zlib header, and the
    reader allocates ``size`` bytes for it. Summing ``size`` over every occurrence of that byte pattern bounds
    the memory a decode inflates to (an unrelated occurrence only adds to the bound), without inflating anything.

    >>> import zlib
    >>> stream = zlib.compress(bytes(1000))
    >>> inflated_size(struct.pack("<II", 1000, 0) + _ZLIB_BUFFER + struct.pack("<q", len(stream) + 4) + stream)
    1000
    """
    total = 0
    i = raw.find(_ZLIB_BUFFER, 8)
    while i >= 0:
        head = raw[i + 13:i + 15]
        # zlib header: compression method 8 (deflate), window <= 32K, header checksum a multiple of 31
        if len(head) == 2 and head[0] & 0x0F == 8 and head[0] >> 4 <= 7 and (head[0] << 8 | head[1]) % 31 == 0:
            total += struct.unpack_from("<I", raw, i - 8)[0]
        i = raw.find(_ZLIB_BUFFER, i + 1)
    return total


def check_inflated_size(blob: dict, limits: dict | None) -> None:
    """Refuse (:class:`TooLargeError`) an archive whose compressed buffers would inflate past the limit."""
    limit_mb = (limits or {}).get("max_inflated_mb")
    if not limit_mb:
        return
    try:
        raw = binascii.a2b_base64(blob["data"])
    except (binascii.Error, ValueError):
        raise DecodeError("geometry data field 'data' is not base64") from None
    size = inflated_size(raw)
    if size > limit_mb * 2**20:
        raise TooLargeError(f"geometry data would inflate to {size / 2**20:.0f} MB, more than the server's limit of "
                            f"{limit_mb:g} MB for one request (ghserver serve --max-vertices)", "max_inflated_mb")


def _limit_flag(key: str) -> str:
    return {"max_vertices": "--max-vertices", "max_faces": "--max-faces"}.get(key, key)


def check_mesh_counts(counts: tuple[int, int] | None, limits: dict | None) -> None:
    """Refuse (:class:`TooLargeError`) declared ``(vertices, faces)`` beyond ``max_vertices`` / ``max_faces``."""
    if counts is None:
        return
    for count, what, key in ((counts[0], "vertices", "max_vertices"), (counts[1], "faces", "max_faces")):
        limit = (limits or {}).get(key)
        if limit and count > limit:
            raise TooLargeError(f"{count} {what} is more than the server's limit of {limit} "
                                f"(ghserver serve {_limit_flag(key)})", key)


def mesh_counts(data) -> tuple[int, int] | None:
    """Vertex and face counts an encoded mesh declares (JSON text or dict), without decoding it; ``None`` when
    they cannot be read cheaply (not an ON_Mesh archive this server recognises)."""
    if _onmesh is None:
        return None
    try:
        return _onmesh.mesh_counts(parse_blob(data))
    except DecodeError:
        return None


# ----------------------------------------------------------------------------------------------
# CommonObject JSON


def parse_blob(data) -> dict:
    """The ``{"version", "archive3dm", "opennurbs", "data"}`` dict of an encoded rhino3dm object.

    ``data`` is the JSON text Hops sends (or the dict itself, as some clients send).
    """
    if isinstance(data, str):
        try:
            data = json.loads(data)
        except json.JSONDecodeError as exc:
            raise DecodeError(f"geometry data is not JSON ({exc.msg} at position {exc.pos})") from None
        except (ValueError, RecursionError) as exc:  # an integer of more than 4300 digits, deep nesting
            raise DecodeError(f"geometry data is not an encoded Rhino object ({type(exc).__name__})") from None
    if not isinstance(data, dict):
        raise DecodeError(f"geometry data must be an encoded Rhino object, got {type(data).__name__}")
    missing = [k for k in ("archive3dm", "opennurbs", "data") if k not in data]
    if missing:
        raise DecodeError(f"geometry data lacks {', '.join(missing)} (not an encoded Rhino object)")
    for key in ("archive3dm", "opennurbs", "version"):
        if key in data and not (isinstance(data[key], int) and not isinstance(data[key], bool)):
            try:
                data = dict(data, **{key: int(str(data[key]))})
            except ValueError:
                raise DecodeError(f"geometry data field {key!r} must be an integer") from None
    if not isinstance(data["data"], str):
        raise DecodeError("geometry data field 'data' must be a base64 string")
    return data


def decode_object(data, limits: dict | None = None):
    """Decode an encoded Rhino object (JSON text or dict) with rhino3dm; never returns None.

    With ``limits`` (``max_inflated_mb``), an archive whose compressed buffers would inflate past it is refused
    (:class:`TooLargeError`) before rhino3dm reads it.
    """
    blob = parse_blob(data)
    if _onmesh is not None and not _onmesh.object_archive(blob):  # before rhino3dm, which can spin on random bytes
        raise DecodeError("geometry data could not be decoded (not a Rhino object archive)")
    check_inflated_size(blob, limits)
    try:
        obj = rhino3dm.CommonObject.Decode(blob)
    except Exception as exc:  # rhino3dm raises RuntimeError/TypeError on malformed fields
        raise DecodeError(f"geometry data could not be decoded ({type(exc).__name__})") from None
    if obj is None:
        raise DecodeError("geometry data could not be decoded (corrupt or unsupported archive)")
    return obj


def encode_object(obj) -> str:
    """JSON text of a rhino3dm object, as Hops expects it in ``data``."""
    return json.dumps(obj.Encode())


# ----------------------------------------------------------------------------------------------
# meshes


def mesh_to_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` of a rhino3dm Mesh, object by object (slow; rhino3dm does not expose n-gons: they come as their
    faces). :func:`rhino_mesh_arrays` reads the mesh's archive instead."""
    pts = mesh.Vertices.ToPoint3dArray()
    V = np.array([(p.X, p.Y, p.Z) for p in pts], dtype=np.float64).reshape(-1, 3)
    faces = mesh.Faces
    F = np.array([faces[i] for i in range(len(faces))], dtype=np.int64).reshape(-1, 4)
    return V, F


def rhino_mesh_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` of a rhino3dm Mesh (read from a .3dm file, decoded by a client), its n-gons as polygon faces:
    through its archive when the fast reader knows the layout, else :func:`mesh_to_arrays`."""
    if _onmesh is not None:
        arrays = _onmesh.read_mesh(mesh.Encode())
        if arrays is not None:
            return arrays
    return mesh_to_arrays(mesh)


def decode_mesh(data, limits: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` from an encoded Rhino mesh (JSON text or dict).

    ``limits`` (``max_vertices``, ``max_faces``, ``max_inflated_mb``) are checked on the counts the archive
    declares, before anything is inflated or allocated; what the fast reader refuses for its size (or for
    running out of memory) is never handed to the rhino3dm fallback.

    Raises
    ------
    TooLargeError
        The mesh declares more than ``limits`` allow.
    DecodeError
        Not JSON, not a Rhino object, corrupt, or not a mesh.
    """
    blob = parse_blob(data)
    if _onmesh is not None:
        try:
            arrays = _onmesh.read_mesh(blob, limits)
        except _onmesh.TooLarge as exc:
            raise TooLargeError(f"{exc.count} {exc.what} is more than the server's limit of {exc.limit} "
                                f"(ghserver serve {_limit_flag(exc.key)})", exc.key) from None
        if arrays is not None:
            return arrays
        check_mesh_counts(_onmesh.mesh_counts(blob), limits)
    obj = decode_object(blob, limits)
    if not isinstance(obj, rhino3dm.Mesh):
        raise DecodeError(f"expected a Mesh, got a {type(obj).__name__}")
    check_mesh_counts((len(obj.Vertices), len(obj.Faces)), limits)
    return mesh_to_arrays(obj)


def _rhino_faces(F: np.ndarray):
    """Faces as Rhino holds them: quads and triangles ``(m, 4)`` in the faces' order, each face of more than four
    corners as its triangle fan; and the n-gons that give each fan back as one polygon (its corners, its fan's
    rows: ``_onmesh._Ngons``), as Rhino's own n-gons do (None without such faces)."""
    F = np.asarray(F, dtype=np.int64)
    if F.shape[1] == 4:
        return F, None
    if F.shape[1] == 3:
        return np.concatenate([F, F[:, 2:3]], axis=1), None
    sizes = face_sizes(F)
    rows = np.where(sizes <= 4, 1, sizes - 2)  # a face's rows: itself, or its fan, in the faces' order
    start = np.concatenate([[0], np.cumsum(rows)[:-1]])
    out = np.empty((int(rows.sum()), 4), dtype=np.int64)
    small = sizes <= 4
    out[start[small]] = F[small, :4]  # a triangle's padding is its last vertex again
    out[start[sizes == 3], 3] = F[sizes == 3, 2]
    big = np.flatnonzero(~small)
    if not len(big):
        return out, None
    T, J = triangulate(F[big])  # J: the row of F[big] of each triangle, fans in corner order
    order = np.argsort(J, kind="stable")
    T, J = T[order], J[order]
    at = start[big][J] + (np.arange(len(J)) - np.searchsorted(J, J))  # the fan's k-th triangle at start + k
    out[at, :3] = T
    out[at, 3] = T[:, 2]
    nv = sizes[big]
    vi = F[big][np.arange(F.shape[1])[None, :] < nv[:, None]]  # each polygon's corners, row by row
    return out, _onmesh_ngons(nv, nv - 2, vi, at)


def _onmesh_ngons(nv, nf, vi, fi):
    return None if _onmesh is None else _onmesh._Ngons(nv, nf, vi, fi)


def arrays_to_mesh(V, F, colors=None):
    """A rhino3dm Mesh with double-precision vertices; faces of more than four corners are n-gons of fans."""
    V = np.asarray(V, dtype=np.float64)
    F4, ngons = _rhino_faces(F)
    if ngons is not None:  # rhino3dm cannot add n-gons: decode the archive written with them
        C = None if colors is None else _rgb8(np.asarray(colors)[:, :3])
        return rhino3dm.CommonObject.Decode(_onmesh.write_mesh(V, F4, C, ngons=ngons))
    mesh = rhino3dm.Mesh()
    mesh.Vertices.UseDoublePrecisionVertices = True
    add = mesh.Vertices.AddPoint3d
    for x, y, z in V.tolist():
        add(x, y, z)
    addf = mesh.Faces.AddFace
    for a, b, c, d in F4.tolist():
        addf(a, b, c, d)
    if colors is not None:
        addc = mesh.VertexColors.Add
        for r, g, b in np.asarray(colors)[:, :3].astype(int).tolist():
            addc(r, g, b)
    return mesh


def _rgb8(colors) -> np.ndarray:
    """Colours as uint8 (others rounded and clipped to 0..255)."""
    colors = np.asarray(colors)
    return colors if colors.dtype == np.uint8 else np.clip(np.rint(colors), 0, 255).astype(np.uint8)


def encode_mesh(V, F, colors=None) -> str:
    """JSON text of a Rhino mesh holding ``(V, F)`` (and per-vertex RGB ``colors`` (n, 3) uint8 if given); faces of
    more than four corners are n-gons (triangle fans grouped as one polygon, which :func:`decode_mesh` reads back
    as the polygon)."""
    V = np.asarray(V, dtype=np.float64)
    if colors is not None:
        colors = _rgb8(colors)
    if _onmesh is not None:
        F4, ngons = _rhino_faces(F)
        return json.dumps(_onmesh.write_mesh(V, F4, colors, ngons=ngons))
    return encode_object(arrays_to_mesh(V, F, colors))


# ----------------------------------------------------------------------------------------------
# curves and surfaces


def _points4(points_list, count: int) -> np.ndarray:
    P = np.empty((count, 4))
    for i in range(count):
        p = points_list[i]
        P[i] = (p.X, p.Y, p.Z, p.W)
    return P


def curve_to_value(obj):
    """A Python curve value from a rhino3dm curve: polyline array or :class:`NurbsCurve`."""
    if isinstance(obj, rhino3dm.LineCurve):
        return np.array([[obj.PointAtStart.X, obj.PointAtStart.Y, obj.PointAtStart.Z],
                         [obj.PointAtEnd.X, obj.PointAtEnd.Y, obj.PointAtEnd.Z]])
    if isinstance(obj, rhino3dm.PolylineCurve):
        pts = [obj.Point(i) for i in range(obj.PointCount)]
        return np.array([(p.X, p.Y, p.Z) for p in pts], dtype=np.float64)
    if not isinstance(obj, rhino3dm.Curve):
        raise DecodeError(f"expected a Curve, got a {type(obj).__name__}")
    nc = obj if isinstance(obj, rhino3dm.NurbsCurve) else obj.ToNurbsCurve()
    if nc is None:
        raise DecodeError(f"the {type(obj).__name__} has no NURBS form")
    n = len(nc.Points)
    H = _points4(nc.Points, n)  # homogeneous (x·w, y·w, z·w, w)
    w = H[:, 3].copy()
    if np.any(w <= 0):
        raise DecodeError("curve has a non-positive control point weight")
    P = H[:, :3] / w[:, None]
    knots = np.array(nc.Knots.ToList(), dtype=np.float64)
    return NurbsCurve(degree=int(nc.Degree), points=P, weights=w, knots=knots, periodic=bool(nc.IsPeriodic))


def decode_curve(data, limits: dict | None = None):
    return curve_to_value(decode_object(data, limits))


def value_to_curve(value):
    """A rhino3dm curve from a polyline array or :class:`NurbsCurve`."""
    if isinstance(value, NurbsCurve):
        P = np.asarray(value.points, dtype=np.float64)
        w = np.asarray(value.weights, dtype=np.float64)
        k = np.asarray(value.knots, dtype=np.float64)
        rational = bool(np.any(w != 1.0))
        nc = rhino3dm.NurbsCurve(3, rational, int(value.degree) + 1, len(P))
        for i, (p, wi) in enumerate(zip(P.tolist(), w.tolist())):
            nc.Points[i] = rhino3dm.Point4d(p[0] * wi, p[1] * wi, p[2] * wi, wi)
        for i, ki in enumerate(k.tolist()):
            nc.Knots[i] = ki
        return nc
    P = np.asarray(value, dtype=np.float64)
    if P.ndim != 2 or P.shape[1] != 3 or len(P) < 2:
        raise ValueError(f"a polyline needs shape (n >= 2, 3), got {P.shape}")
    return rhino3dm.PolylineCurve([rhino3dm.Point3d(*p) for p in P.tolist()])


def encode_curve(value) -> str:
    return encode_object(value_to_curve(value))


def decode_surface(data, limits: dict | None = None) -> NurbsSurface:
    """A :class:`NurbsSurface` from an encoded NurbsSurface, Surface or one-face Brep."""
    obj = decode_object(data, limits)
    if isinstance(obj, rhino3dm.Brep):
        if len(obj.Faces) != 1:
            raise DecodeError(f"expected a surface, got a Brep with {len(obj.Faces)} faces")
        obj = obj.Faces[0].UnderlyingSurface()
    if not isinstance(obj, rhino3dm.Surface):
        raise DecodeError(f"expected a Surface, got a {type(obj).__name__}")
    ns = obj if isinstance(obj, rhino3dm.NurbsSurface) else obj.ToNurbsSurface()
    if ns is None:
        raise DecodeError(f"the {type(obj).__name__} has no NURBS form")
    nu, nv = ns.Points.CountU, ns.Points.CountV
    H = np.empty((nu, nv, 4))
    for i in range(nu):
        for j in range(nv):
            p = ns.Points[i, j]
            H[i, j] = (p.X, p.Y, p.Z, p.W)
    w = H[..., 3].copy()
    if np.any(w <= 0):
        raise DecodeError("surface has a non-positive control point weight")
    return NurbsSurface(
        degree_u=int(ns.Degree(0)), degree_v=int(ns.Degree(1)), points=H[..., :3] / w[..., None], weights=w,
        knots_u=np.array(ns.KnotsU.ToList(), dtype=np.float64), knots_v=np.array(ns.KnotsV.ToList(), dtype=np.float64),
    )


def value_to_surface(value: NurbsSurface):
    """A rhino3dm NurbsSurface from a :class:`NurbsSurface` (used by tests and the client)."""
    P = np.asarray(value.points, dtype=np.float64)
    w = np.asarray(value.weights, dtype=np.float64)
    nu, nv = P.shape[:2]
    rational = bool(np.any(w != 1.0))
    ns = rhino3dm.NurbsSurface.Create(3, rational, value.degree_u + 1, value.degree_v + 1, nu, nv)
    for i in range(nu):
        for j in range(nv):
            x, y, z = P[i, j]
            wi = w[i, j]
            ns.Points[i, j] = rhino3dm.Point4d(x * wi, y * wi, z * wi, wi)
    for i, k in enumerate(np.asarray(value.knots_u, dtype=float).tolist()):
        ns.KnotsU[i] = k
    for i, k in enumerate(np.asarray(value.knots_v, dtype=float).tolist()):
        ns.KnotsV[i] = k
    return ns


def encode_surface(value: NurbsSurface) -> str:
    return encode_object(value_to_surface(value))


def to_value(obj):
    """Python value of any supported rhino3dm object (used by the client for outputs and inputs)."""
    if isinstance(obj, rhino3dm.Mesh):
        return rhino_mesh_arrays(obj)
    if isinstance(obj, rhino3dm.Curve):
        return curve_to_value(obj)
    if isinstance(obj, (rhino3dm.Surface, rhino3dm.Brep)):
        return decode_surface(obj.Encode())
    if isinstance(obj, rhino3dm.Point3d):
        return np.array([obj.X, obj.Y, obj.Z])
    if isinstance(obj, rhino3dm.Point):
        loc = obj.Location
        return np.array([loc.X, loc.Y, loc.Z])
    raise DecodeError(f"unsupported rhino3dm object {type(obj).__name__}")


def is_rhino_object(value) -> bool:
    return isinstance(value, (rhino3dm.CommonObject, rhino3dm.Point3d, rhino3dm.Vector3d))


def decode_point_object(data, limits: dict | None = None) -> np.ndarray:
    """Point from an encoded ``Rhino.Geometry.Point`` (what the Geometry param sends for points)."""
    obj = decode_object(data, limits)
    if isinstance(obj, rhino3dm.Point):
        loc = obj.Location
        return np.array([loc.X, loc.Y, loc.Z])
    raise DecodeError(f"expected a Point, got a {type(obj).__name__}")


# ----------------------------------------------------------------------------------------------
# fabrication model (ghserver fabricate)

#: layer name → colour (RGBA) of the .3dm written by ``write_3dm``
LAYERS_3DM = {
    "panels": (90, 160, 210, 255),
    "labels": (40, 40, 40, 255),
    "node_axes": (210, 60, 60, 255),
    "beams": (150, 150, 150, 255),
    "flat_panels": (40, 160, 160, 255),
    "sheets": (120, 120, 120, 255),
}


def write_3dm(path, fab, units: str | None = None):
    """The fabrication model as a Rhino file: every panel, its label, the node axes, the beams and the flat layout.

    Layers (:data:`LAYERS_3DM`): ``panels`` (one mesh per panel, named by its label), ``labels`` (a TextDot with
    the label at every panel's centre), ``node_axes`` (a line per vertex, one beam height along its axis to the
    inside), ``beams`` (a box mesh per edge), ``flat_panels`` (the closed flat outlines on their sheets, laid out
    beside the model) and ``sheets`` (the sheets' rectangles). Returns the path.

    Parameters
    ----------
    path : str or Path
        The ``.3dm`` file to write.
    fab : components.fabrication.export.Fabrication
        From :func:`components.fabrication.export.fabrication`.
    units : str, optional
        The model's unit system by Rhino's name (``"Meters"``, ``"Millimeters"``, ...; :func:`file_units`); None:
        the file says it has none.
    """
    model = rhino3dm.File3dm()
    _set_units(model, units)
    index = {}
    for name, colour in LAYERS_3DM.items():
        layer = rhino3dm.Layer()
        layer.Name = name
        layer.Color = colour
        index[name] = model.Layers.Add(layer)

    def attrs(layer, name=""):
        a = rhino3dm.ObjectAttributes()
        a.LayerIndex = index[layer]
        if name:
            a.Name = name
        return a

    V, F, flat = fab.V, fab.F, fab.flat
    for f, label in enumerate(flat.labels):
        n = int(flat.sizes[f])
        model.Objects.AddMesh(arrays_to_mesh(V[F[f, :n]], np.arange(n)[None, :]), attrs("panels", label))
    for label, c in zip(flat.labels, face_centroids(V, F).tolist()):
        model.Objects.AddTextDot(label, rhino3dm.Point3d(*c), attrs("labels", label))
    used = np.unique(F)
    for v in used.tolist():
        a, b = V[v], V[v] - fab.beam_height * fab.supports.axes[v]
        model.Objects.AddLine(rhino3dm.Point3d(*a.tolist()), rhino3dm.Point3d(*b.tolist()), attrs("node_axes"))
    for Vb, Fb in beam_meshes(V, fab.frames, fab.supports.axes, fab.beam_height, fab.beam_width):
        model.Objects.AddMesh(arrays_to_mesh(Vb, Fb), attrs("beams"))
    lay = fab.layout
    lo, hi = V.min(axis=0), V.max(axis=0)
    shift = np.array([hi[0] + 0.2 * (hi[0] - lo[0]) - lay.sheet_origin[0, 0], lo[1], lo[2]])
    placed = placed_outlines(flat, lay)
    for label, c in zip(flat.labels, closed_polylines(placed, flat.sizes)):
        model.Objects.AddCurve(value_to_curve(c + shift), attrs("flat_panels", label))
    W, H = lay.sheet_width, lay.sheet_height
    rect = np.array([[0.0, 0, 0], [W, 0, 0], [W, H, 0], [0, H, 0], [0, 0, 0]])
    for s, (ox, oy) in enumerate(lay.sheet_origin.tolist()):
        model.Objects.AddCurve(value_to_curve(rect + np.array([ox, oy, 0.0]) + shift), attrs("sheets", f"sheet {s}"))
    path = Path(path)
    if not model.Write(str(path), 7):
        raise OSError(f"{path}: rhino3dm could not write the file")
    return path


# ----------------------------------------------------------------------------------------------
# model files: .3dm in and out, and the reader the command line uses for every mesh format


class ModelMesh(NamedTuple):
    """A mesh read from a model file, with what the reader did to it and the model's units."""

    V: np.ndarray
    F: np.ndarray
    notes: tuple
    units: str | None = None  # Rhino's name of the .3dm's unit system ("Millimeters", ...); None: not given


def file_units(model) -> str | None:
    """The unit system of a read ``File3dm`` by Rhino's name (``"Meters"``, ``"Millimeters"``, ...), or None when the
    file has none (``None``, ``Unset``) or custom units."""
    name = model.Settings.ModelUnitSystem.name
    return None if name in ("None", "Unset", "CustomUnits") else name


def _set_units(model, units: str | None):
    """Give a ``File3dm`` being written the unit system named ``units`` (Rhino's name), or none when None: rhino3dm
    writes millimetres by default, which would scale a metre model by 1000 when Rhino opens it."""
    unitless = getattr(rhino3dm.UnitSystem, "None")  # (a keyword: not an attribute name in Python's syntax)
    model.Settings.ModelUnitSystem = getattr(rhino3dm.UnitSystem, units, unitless) if units else unitless


#: grid segments per direction when a .3dm surface is meshed (:func:`read_3dm`)
SURFACE_SEGMENTS = 40


def _object_label(model, obj) -> str:
    attrs = obj.Attributes
    layer = model.Layers[attrs.LayerIndex].FullPath if 0 <= attrs.LayerIndex < len(model.Layers) else "?"
    kind = type(obj.Geometry).__name__
    return f"{kind} {attrs.Name!r} on layer {layer!r}" if attrs.Name else f"{kind} on layer {layer!r}"


def read_3dm(path, layer: str | None = None, name: str | None = None,
             segments: int = SURFACE_SEGMENTS) -> ModelMesh:
    """The mesh of the one mesh, NURBS surface or one-face Brep in a Rhino ``.3dm`` file.

    A surface (or the untrimmed surface of a one-face Brep) is meshed exactly on the surface by
    :func:`components.surfaces.generators.surface_mesh` with ``segments`` × ``segments`` grid cells. When the file
    holds several such objects, ``layer`` (a layer's name or full path) and/or ``name`` (the object's name) pick one;
    otherwise the error lists them.

    Raises
    ------
    InputError
        Not a readable .3dm file, no mesh or surface in it (after the filters), or several of them.
    """
    path = Path(path)
    model = rhino3dm.File3dm.Read(str(path))
    if model is None:
        raise InputError("mesh", f"{path.name}: not a readable Rhino .3dm file")
    found = []
    for obj in model.Objects:
        geo = obj.Geometry
        if isinstance(geo, rhino3dm.Brep) and len(geo.Faces) != 1:
            continue
        if not isinstance(geo, (rhino3dm.Mesh, rhino3dm.Surface, rhino3dm.Brep)):
            continue
        attrs = obj.Attributes
        lay = model.Layers[attrs.LayerIndex] if 0 <= attrs.LayerIndex < len(model.Layers) else None
        if layer is not None and (lay is None or layer not in (lay.Name, lay.FullPath)):
            continue
        if name is not None and attrs.Name != name:
            continue
        found.append(obj)
    picked = " matching " + " and ".join(f"{k} {v!r}" for k, v in (("--layer", layer), ("--object", name))
                                         if v is not None) if (layer or name) else ""
    if not found:
        raise InputError("mesh", f"{path.name}: no mesh, NURBS surface or one-face Brep{picked} (of "
                                 f"{len(model.Objects)} object(s) in the file)")
    if len(found) > 1:
        listed = "; ".join(_object_label(model, o) for o in found[:20])
        raise InputError("mesh", f"{path.name}: {len(found)} meshes/surfaces{picked}, pick one with --layer and/or "
                                 f"--object: {listed}")
    obj = found[0]
    geo = obj.Geometry
    label = _object_label(model, obj)
    units = file_units(model)
    if isinstance(geo, rhino3dm.Mesh):
        V, F = rhino_mesh_arrays(geo)
        notes = (f"{path.name}: {label}, {len(V):,} vertices, {len(F):,} faces",)
        if np.array_equal(V, V.astype(np.float32)):  # (rhino3dm reports double-precision vertices either way)
            notes += _single_precision_note(path.name, "the mesh's coordinates are all single-precision numbers (a "
                                            "mesh written without double-precision vertices)", V,
                                            "export it near the origin (or with double-precision vertices)")
        return ModelMesh(V, F, notes, units)
    surface = decode_surface(geo.Encode())
    res = surface_mesh(surface, segments, segments)
    V, T = res.mesh
    note = (f"{path.name}: {label} meshed on the surface with {res.segments_u} × {res.segments_v} cells "
            f"({len(V):,} vertices, {len(T):,} triangles)")
    if isinstance(geo, rhino3dm.Brep):
        note += "; the Brep face's trims are ignored (its whole underlying surface is meshed)"
    return ModelMesh(V, T, (note,), units)


def read_model(path, layer: str | None = None, name: str | None = None,
               segments: int = SURFACE_SEGMENTS) -> ModelMesh:
    """A mesh from any model file the command line accepts: ``.3dm`` (:func:`read_3dm`), ``.stl`` (welded,
    :func:`components.core.mesh.read_stl`), ``.obj``, ``.off`` or ``.ply``.

    ``layer`` and ``name`` only apply to ``.3dm`` files; an error says so for other formats.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".3dm":
        return read_3dm(path, layer=layer, name=name, segments=segments)
    if layer is not None or name is not None:
        raise InputError("mesh", f"{path.name}: --layer and --object only apply to .3dm files")
    if suffix == ".stl":
        s = read_stl(path)
        note = (f"{path.name}: {s.corners:,} STL corners welded into {len(s.V):,} vertices at {s.tolerance:.3g} "
                f"(1e-6 × the bounding-box diagonal)")
        if s.dropped:
            note += f"; {s.dropped} triangle(s) collapsed by the weld were dropped"
        binary = _binary_stl(path)
        notes = (note,) + (_single_precision_note(path.name, "binary STL stores single-precision coordinates", s.V,
                                                  "export the model near the origin (or as .3dm / .obj)")
                           if binary else ())
        return ModelMesh(s.V, s.F, notes)
    V, F = read_mesh(path)
    return ModelMesh(V, F, ())


def _binary_stl(path) -> bool:
    """Whether the STL file at ``path`` is binary (its size is the 84-byte header plus 50 bytes a triangle)."""
    data = Path(path).read_bytes()
    return len(data) >= 84 and len(data) == 84 + 50 * int.from_bytes(data[80:84], "little")


def _single_precision_note(file: str, stored: str, V: np.ndarray, advice: str) -> tuple:
    """A note when single-precision coordinates round the model ``V`` by more than 1e-7 of its size (site
    coordinates: at 5e6 a float32 is rounded to 0.5 units), else nothing: the model was rounded where it was
    written, and exactly planar panels can come back as not planar."""
    if not len(V):
        return ()
    size = float(np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
    far = float(np.abs(V).max())
    step = float(np.spacing(np.float32(far)))
    if size <= 0 or step <= 1e-7 * size:
        return ()
    return (f"{file}: {stored}: at up to {far:.4g} they are rounded by up to {step / 2:.3g} ({step / 2 / size:.2g} "
            f"× the model's size); {advice} to keep its precision",)


def write_meshes_3dm(path, meshes, colours: dict | None = None, units: str | None = None) -> Path:
    """Write meshes to a Rhino ``.3dm`` file, one layer per group.

    Parameters
    ----------
    path : str or Path
        The file to write.
    meshes : iterable of (layer, name, V, F)
        Layers are created in the order they first appear; every mesh is one object named ``name`` (n-gons are
        written as triangle fans).
    colours : dict, optional
        Layer name → RGBA colour.
    units : str, optional
        The meshes' unit system by Rhino's name (:func:`file_units`); None: the file says it has none.
    """
    model = rhino3dm.File3dm()
    _set_units(model, units)
    index = {}
    for layer, name, V, F in meshes:
        if layer not in index:
            lay = rhino3dm.Layer()
            lay.Name = layer
            if colours and layer in colours:
                lay.Color = colours[layer]
            index[layer] = model.Layers.Add(lay)
        a = rhino3dm.ObjectAttributes()
        a.LayerIndex = index[layer]
        a.Name = name
        model.Objects.AddMesh(arrays_to_mesh(V, F), a)
    path = Path(path)
    if not model.Write(str(path), 7):
        raise OSError(f"could not write {path}")
    return path

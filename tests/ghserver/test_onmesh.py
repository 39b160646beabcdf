"""Round trips of the numpy openNURBS mesh codec (ghserver._onmesh) against rhino3dm itself."""
from __future__ import annotations

import base64
import json
import struct
import zlib

import numpy as np
import pytest

rhino3dm = pytest.importorskip("rhino3dm")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from ghserver._onmesh import _check_double_vertices, _Invalid, read_mesh, read_mesh_colors, write_mesh  # noqa: E402

from tests.conftest import data_file  # noqa: E402


# ----------------------------------------------------------------------------------------------
# helpers


def rh_view(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces exactly as rhino3dm reports them."""
    V = np.array([(p.X, p.Y, p.Z) for p in mesh.Vertices.ToPoint3dArray()], dtype=np.float64).reshape(-1, 3)
    faces = mesh.Faces
    F = np.array([tuple(faces[i]) for i in range(len(faces))], dtype=np.int64).reshape(-1, 4)
    return V, F


def rh_mesh(V, F, *, double: bool = True):
    """A rhino3dm Mesh built vertex by vertex (double precision or float-only)."""
    mesh = rhino3dm.Mesh()
    mesh.Vertices.UseDoublePrecisionVertices = double
    for x, y, z in np.asarray(V, dtype=float).tolist():
        if double:
            mesh.Vertices.AddPoint3d(x, y, z)
        else:
            mesh.Vertices.Add(x, y, z)
    for face in np.asarray(F).tolist():
        if face[2] == face[3]:
            mesh.Faces.AddFace(face[0], face[1], face[2])
        else:
            mesh.Faces.AddFace(*face)
    return mesh


def rh_colors(mesh) -> np.ndarray:
    """Vertex colours as rhino3dm reports them: ``(n, 4)`` uint8 RGBA, alpha 255 = opaque."""
    vc = mesh.VertexColors
    return np.array([vc[i] for i in range(len(vc))], dtype=np.uint8).reshape(-1, 4)


def rh_set_colors(mesh, C) -> None:
    """Colour a rhino3dm mesh: RGB through ``VertexColors.Add``, RGBA through item assignment."""
    C = np.asarray(C)
    for r, g, b in C[:, :3].tolist():
        mesh.VertexColors.Add(r, g, b)
    if C.shape[1] == 4:
        for i, c in enumerate(C.tolist()):
            mesh.VertexColors[i] = tuple(c)


def random_colors(n: int, channels: int, seed: int = 5) -> np.ndarray:
    C = np.random.default_rng(seed).integers(0, 256, size=(n, channels), dtype=np.uint8)
    if n >= 2:  # make sure the extremes occur
        C[0], C[1] = 0, 255
    return C


def rgba(C) -> np.ndarray:
    C = np.asarray(C, dtype=np.uint8)
    return C if C.shape[1] == 4 else np.concatenate([C, np.full((len(C), 1), 255, np.uint8)], axis=1)


def decode(obj) -> tuple[np.ndarray, np.ndarray]:
    mesh = rhino3dm.CommonObject.Decode(obj)
    assert isinstance(mesh, rhino3dm.Mesh)
    return rh_view(mesh)


def assert_same(got, expected) -> None:
    assert got is not None
    V, F = got
    Ve, Fe = expected
    assert V.dtype == np.float64 and V.shape == Ve.shape
    assert F.dtype == np.int64 and F.shape == Fe.shape
    np.testing.assert_array_equal(V, Ve)
    np.testing.assert_array_equal(F, Fe)


def grid(nu: int, nv: int, offset: float = 5e4) -> tuple[np.ndarray, np.ndarray]:
    """Wavy quad grid with coordinates around ``offset`` (double precision matters)."""
    u, v = np.meshgrid(np.linspace(0, 1, nu), np.linspace(0, 1, nv), indexing="ij")
    V = np.stack([offset + 123.456789 * u, offset + 98.7654321 * v, np.sin(5 * u) * np.cos(3 * v) / 3],
                 axis=-1).reshape(-1, 3)
    idx = np.arange(nu * nv).reshape(nu, nv)
    F = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], axis=-1).reshape(-1, 4)
    return V, F


def soup(n_tri: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    V = rng.uniform(-5e4, 5e4, size=(3 * n_tri, 3)) + rng.uniform(-1, 1, size=(3 * n_tri, 3)) * 1e-7
    T = rng.permutation(3 * n_tri).reshape(n_tri, 3)
    return V, np.concatenate([T, T[:, 2:3]], axis=1)


def mixed(n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Quad grid with every third quad split into two triangles."""
    V, Q = grid(n, n)
    rng = np.random.default_rng(seed)
    faces = []
    for k, q in enumerate(Q.tolist()):
        if k % 3 == 0:
            faces += [[q[0], q[1], q[2], q[2]], [q[0], q[2], q[3], q[3]]]
        else:
            faces.append(q)
    F = np.array(faces, dtype=np.int64)
    return V, F[rng.permutation(len(F))]


def payload(obj: dict) -> bytes:
    return base64.b64decode(obj["data"])


def with_payload(obj: dict, data: bytes) -> dict:
    return {**obj, "data": base64.b64encode(data).decode("ascii")}


CASES = {
    "one triangle": (np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2, 2]])),
    "one quad": (np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), np.array([[0, 1, 2, 3]])),
    "grid 6x5 (uint8 indices)": grid(6, 5),
    "grid 16x16 (256 vertices, uint16 indices)": grid(16, 16),
    "mixed 30x30": mixed(30),
    "soup 200": soup(200),
    "grid 256x257 (65792 vertices, int32 indices)": grid(256, 257),
}


# ----------------------------------------------------------------------------------------------
# read_mesh on rhino3dm's own encoding


@pytest.mark.parametrize("name", list(CASES))
def test_read_rhino3dm_double_precision(name):
    V, F = CASES[name]
    mesh = rh_mesh(V, F)
    expected = rh_view(mesh)
    np.testing.assert_array_equal(expected[0], V)  # rhino3dm keeps the doubles exactly
    assert_same(read_mesh(mesh.Encode()), expected)


@pytest.mark.parametrize("name", ["one quad", "grid 6x5 (uint8 indices)", "mixed 30x30", "soup 200"])
def test_read_rhino3dm_float_only(name):
    V, F = CASES[name]
    mesh = rh_mesh(V, F, double=False)
    expected = rh_view(mesh)
    got = read_mesh(mesh.Encode())
    assert_same(got, expected)
    np.testing.assert_array_equal(got[0], V.astype(np.float32).astype(np.float64))


def test_read_rhino3dm_100k_compressed():
    V, F = grid(317, 317)  # 100489 vertices
    mesh = rh_mesh(V, F)
    obj = mesh.Encode()
    data = payload(obj)
    assert len(data) < 0.8 * (V.nbytes * 1.5 + F.shape[0] * 16)  # rhino3dm compressed the buffers
    assert_same(read_mesh(json.loads(json.dumps(obj))), (V, F))


def test_read_empty_mesh():
    got = read_mesh(rhino3dm.Mesh().Encode())
    assert got is not None
    assert got[0].shape == (0, 3) and got[1].shape == (0, 4)


def test_read_returns_writable_arrays():
    V, F = read_mesh(write_mesh(*CASES["soup 200"]))
    V[0, 0] += 1.0
    F[0, 0] += 1


# ----------------------------------------------------------------------------------------------
# write_mesh read back by rhino3dm


@pytest.mark.parametrize("level", [None, 1, 9])
@pytest.mark.parametrize("name", list(CASES))
def test_write_decoded_by_rhino3dm(name, level):
    V, F = CASES[name]
    obj = write_mesh(V, F, compress_level=level)
    assert set(obj) == {"version", "archive3dm", "opennurbs", "data"}
    assert obj["archive3dm"] == 60
    mesh = rhino3dm.CommonObject.Decode(json.loads(json.dumps(obj)))
    assert isinstance(mesh, rhino3dm.Mesh)
    assert mesh.IsValid
    assert_same(rh_view(mesh), (V, F))
    # the single precision copy is the rounded double, as openNURBS keeps it
    fpts = mesh.Vertices.ToPoint3fArray()
    np.testing.assert_array_equal(np.array([(p.X, p.Y, p.Z) for p in fpts], dtype=np.float32),
                                  V.astype(np.float32))
    # rhino3dm re-encodes it consistently, and we read that back
    again = mesh.Encode()
    assert_same(read_mesh(again), (V, F))
    assert_same(read_mesh(obj), (V, F))
    bbox = mesh.GetBoundingBox()
    np.testing.assert_array_equal([bbox.Min.X, bbox.Min.Y, bbox.Min.Z], V.min(axis=0))
    np.testing.assert_array_equal([bbox.Max.X, bbox.Max.Y, bbox.Max.Z], V.max(axis=0))


@pytest.mark.parametrize("name", ["one triangle", "one quad", "grid 6x5 (uint8 indices)", "soup 200"])
def test_write_matches_rhino3dm_bytes(name):
    """With rhino3dm's compression level the archive is byte for byte what rhino3dm writes."""
    V, F = CASES[name]
    assert_same_envelope(write_mesh(V, F, compress_level=9), rh_mesh(V, F).Encode())


def test_write_empty_matches_rhino3dm():
    assert_same_envelope(write_mesh(np.zeros((0, 3)), np.zeros((0, 4), dtype=int), compress_level=9),
                         rhino3dm.Mesh().Encode())


def assert_same_envelope(ours: dict, theirs: dict) -> None:
    """Same archive bytes and versions; the openNURBS build number may differ between rhino3dm releases."""
    assert isinstance(ours["opennurbs"], int)
    assert {k: v for k, v in ours.items() if k != "opennurbs"} == {k: v for k, v in theirs.items() if k != "opennurbs"}


def test_write_100k_roundtrip_exact():
    rng = np.random.default_rng(7)
    V, F = grid(317, 317)
    V = V + rng.uniform(-1, 1, V.shape) * 1e-6  # full 53-bit mantissas around 5e4
    for level in (None, 6):
        got = decode(write_mesh(V, F, compress_level=level))
        assert_same(got, (V, F))
        err = np.abs(got[0] - V).max() / np.abs(V).max()
        assert err <= 1e-9


def test_write_pads_triangles():
    V, F = CASES["soup 200"]
    assert write_mesh(V, F[:, :3]) == write_mesh(V, F)


def test_uncompressed_is_larger_but_equivalent():
    V, F = grid(40, 40)
    raw, comp = write_mesh(V, F), write_mesh(V, F, compress_level=9)
    assert len(raw["data"]) > len(comp["data"])
    assert_same(read_mesh(raw), (V, F))
    assert_same(read_mesh(comp), (V, F))


@pytest.mark.parametrize(
    "V, F",
    [
        (np.zeros((3, 2)), [[0, 1, 2, 2]]),
        (np.zeros((3, 3)), [[0, 1]]),
        (np.zeros((3, 3)), [[0, 1, 3, 3]]),
        (np.zeros((3, 3)), [[0, -1, 2, 2]]),
        (np.array([[0, 0, np.nan], [1, 0, 0], [0, 1, 0]]), [[0, 1, 2, 2]]),
        (np.array([[0, 0, 1e300], [1, 0, 0], [0, 1, 0]]), [[0, 1, 2, 2]]),
        (np.zeros((3, 3)), [[0.0, 1.0, 2.0, 2.0]]),
    ],
)
def test_write_rejects_bad_input(V, F):
    with pytest.raises(ValueError):
        write_mesh(V, np.asarray(F))


# ----------------------------------------------------------------------------------------------
# property test

coord = st.floats(min_value=-1e7, max_value=1e7, allow_nan=False, allow_infinity=False)


@st.composite
def random_meshes(draw):
    n = draw(st.integers(min_value=3, max_value=300))
    V = np.array(draw(st.lists(st.tuples(coord, coord, coord), min_size=n, max_size=n)), dtype=np.float64)
    m = draw(st.integers(min_value=0, max_value=200))
    seed = draw(st.integers(min_value=0, max_value=2**32 - 1))
    rng = np.random.default_rng(seed)
    F = np.empty((m, 4), dtype=np.int64)
    for k in range(m):
        if n >= 4 and rng.random() < 0.5:
            F[k] = rng.choice(n, size=4, replace=False)  # quad
        else:
            F[k, :3] = rng.choice(n, size=3, replace=False)  # triangle (a, b, c, c)
            F[k, 3] = F[k, 2]
    return V, F


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(random_meshes(), st.sampled_from([None, 1, 9]))
def test_property_roundtrip(mesh, level):
    V, F = mesh
    obj = write_mesh(V, F, compress_level=level)
    assert_same(read_mesh(obj), (V, F))
    rh = rhino3dm.CommonObject.Decode(obj)
    assert_same(rh_view(rh), (V, F))
    assert_same(read_mesh(rh.Encode()), (V, F))


# ----------------------------------------------------------------------------------------------
# extra mesh data: normals, colours, user data, n-gons


def test_mesh_with_normals_and_colours():
    V, F = grid(12, 9)
    mesh = rh_mesh(V, F)
    assert mesh.Normals.ComputeNormals()
    for i in range(len(V)):
        mesh.VertexColors.Add(i % 256, (3 * i) % 256, 7)
    assert len(mesh.Normals) == len(V) and len(mesh.VertexColors) == len(V)
    obj = mesh.Encode()
    assert_same(read_mesh(obj), rh_view(rhino3dm.CommonObject.Decode(obj)))
    assert_same(read_mesh(obj), (V, F))
    V2, F2, C = read_mesh_colors(obj)
    assert_same((V2, F2), (V, F))
    np.testing.assert_array_equal(C, rh_colors(rhino3dm.CommonObject.Decode(obj)))
    assert C[5].tolist() == [5, 15, 7, 255]


def test_mesh_with_explicit_normals_small():
    V, F = CASES["one quad"]
    mesh = rh_mesh(V, F)
    for _ in range(4):
        mesh.Normals.Add(0.0, 0.0, 1.0)
    assert_same(read_mesh(mesh.Encode()), (V, F))


def test_mesh_with_user_data_falls_back():
    """User data (here a user string) is not parsed: the rhino3dm path applies."""
    V, F = CASES["one quad"]
    mesh = rh_mesh(V, F)
    mesh.SetUserString("key", "value")
    obj = mesh.Encode()
    assert rhino3dm.CommonObject.Decode(obj).GetUserString("key") == "value"
    assert read_mesh(obj) is None


def _ngon_chunk(ngons: list[tuple[list[int], list[int]]]) -> bytes:
    body = struct.pack("<iiI", 1, 0, len(ngons))
    for vi, fi in ngons:
        body += struct.pack(f"<II{len(vi)}I{len(fi)}I", len(vi), len(fi), *vi, *fi)
    body += struct.pack("<I", zlib.crc32(body))
    return struct.pack("<Iq", 0x40008000, len(body)) + body


def test_mesh_with_ngons_is_read():
    """An n-gon record (as RhinoCommon may send) makes its faces one polygon face; rhino3dm keeps the faces."""
    V = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]])
    F = np.array([[0, 1, 2, 3], [1, 4, 5, 2]])
    obj = write_mesh(V, F)  # uncompressed, so the layout below is fixed
    data = payload(obj)
    start = 12 + 32 + 12  # CLASS header, UUID chunk, DATA header
    (length,) = struct.unpack_from("<q", data, start - 8)
    body = data[start:start + length - 4]
    # tail of the mesh record: tag chunk (176), 3 flags, ngon flag, dV flag, dV chunk, bbox (48)
    dv_len = 12 + 8 + 4 + 4 + 4 + 1 + 24 * len(V) + 4
    dv_start = len(body) - 48 - dv_len
    flag = dv_start - 2
    tag_start = flag - 3 - 176
    assert body[flag] == 0 and body[flag + 1] == 1
    assert body[tag_start:tag_start + 4] == struct.pack("<I", 0x40008000)
    new_body = body[:flag] + b"\x01" + _ngon_chunk([([0, 1, 4, 5, 2, 3], [0, 1])]) + body[flag + 1:]
    # the record's CRC covers its own bytes only, not the nested chunks
    direct = (body[:tag_start] + body[tag_start + 176:flag] + b"\x01"
              + body[flag + 1:dv_start] + body[dv_start + dv_len:])
    chunk = struct.pack("<Iq", 0x0002FFFC, len(new_body) + 4) + new_body + struct.pack("<I", zlib.crc32(direct))
    inner = data[12:start - 12] + chunk + data[start + length:]
    patched = with_payload(obj, struct.pack("<Iq", 0x00027FFA, len(inner)) + inner)

    rh = rhino3dm.CommonObject.Decode(patched)
    assert isinstance(rh, rhino3dm.Mesh)
    assert_same(rh_view(rh), (V, F))
    assert_same(read_mesh(patched), (V, np.array([[0, 1, 4, 5, 2, 3]])))


# ----------------------------------------------------------------------------------------------
# vertex colours


COLOR_CASES = ["one triangle", "one quad", "grid 6x5 (uint8 indices)", "grid 16x16 (256 vertices, uint16 indices)",
               "soup 200", "grid 256x257 (65792 vertices, int32 indices)"]


def test_rhino3dm_colour_conventions():
    """rhino3dm reports ON_Color as (r, g, b, 255 - transparency byte); Add(r, g, b) is opaque."""
    V, F = CASES["one triangle"]
    mesh = rh_mesh(V, F)
    for c in [(10, 20, 30), (40, 50, 60), (70, 80, 90)]:
        mesh.VertexColors.Add(*c)
    mesh.VertexColors[1] = (41, 51, 61, 4)
    assert len(mesh.VertexColors) == 3
    assert mesh.VertexColors[0] == (10, 20, 30, 255) and mesh.VertexColors[1] == (41, 51, 61, 4)
    data = payload(mesh.Encode())
    assert bytes([10, 20, 30, 0, 41, 51, 61, 251, 70, 80, 90, 0]) in data


@pytest.mark.parametrize("channels", [3, 4])
@pytest.mark.parametrize("level", [None, 1, 9])
@pytest.mark.parametrize("name", COLOR_CASES)
def test_write_colors_decoded_by_rhino3dm(name, level, channels):
    V, F = CASES[name]
    C = random_colors(len(V), channels)
    obj = write_mesh(V, F, C, compress_level=level)
    mesh = rhino3dm.CommonObject.Decode(json.loads(json.dumps(obj)))
    assert isinstance(mesh, rhino3dm.Mesh) and mesh.IsValid
    assert_same(rh_view(mesh), (V, F))
    assert len(mesh.VertexColors) == len(V)
    np.testing.assert_array_equal(rh_colors(mesh), rgba(C))
    # our reader, on our output and on rhino3dm's re-encoding
    for o in (obj, mesh.Encode()):
        got = read_mesh_colors(o)
        assert_same(got[:2], (V, F))
        assert got[2].dtype == np.uint8 and got[2].shape == (len(V), 4)
        np.testing.assert_array_equal(got[2], rgba(C))
        assert_same(read_mesh(o), (V, F))  # read_mesh is unchanged: two arrays, colours skipped


@pytest.mark.parametrize("channels", [3, 4])
@pytest.mark.parametrize("name", COLOR_CASES)
def test_write_colors_match_rhino3dm_bytes(name, channels):
    V, F = CASES[name]
    C = random_colors(len(V), channels)
    mesh = rh_mesh(V, F)
    rh_set_colors(mesh, C)
    assert_same_envelope(write_mesh(V, F, C, compress_level=9), mesh.Encode())
    assert_same_envelope(write_mesh(V, F, colors=C, compress_level=9), mesh.Encode())


@pytest.mark.parametrize("channels", [3, 4])
@pytest.mark.parametrize("name", ["one quad", "mixed 30x30", "soup 200"])
def test_read_colors_of_rhino3dm_meshes(name, channels):
    V, F = CASES[name]
    for double in (True, False):
        C = random_colors(len(V), channels, seed=9)
        mesh = rh_mesh(V, F, double=double)
        rh_set_colors(mesh, C)
        obj = mesh.Encode()
        got = read_mesh_colors(obj)
        assert_same(got[:2], rh_view(mesh))
        np.testing.assert_array_equal(got[2], rgba(C))
        np.testing.assert_array_equal(got[2], rh_colors(rhino3dm.CommonObject.Decode(obj)))


def test_read_colors_absent_is_none():
    V, F = CASES["grid 6x5 (uint8 indices)"]
    for obj in (write_mesh(V, F), rh_mesh(V, F).Encode()):
        got = read_mesh_colors(obj)
        assert len(got) == 3 and got[2] is None
        assert_same(got[:2], (V, F))
    got = read_mesh_colors(rhino3dm.Mesh().Encode())
    assert got[0].shape == (0, 3) and got[1].shape == (0, 4) and got[2] is None


def test_read_colors_writable_and_integer_input():
    V, F = CASES["one quad"]
    C = [[1, 2, 3], [4, 5, 6], [7, 8, 9], [250, 251, 252]]  # python ints are accepted
    assert write_mesh(V, F, C) == write_mesh(V, F, np.array(C, dtype=np.uint8))
    _, _, got = read_mesh_colors(write_mesh(V, F, np.array(C, dtype=np.int64)))
    np.testing.assert_array_equal(got, rgba(np.array(C)))
    got[0, 0] = 99  # a copy, not a view into the archive


def test_write_empty_with_colors_matches_rhino3dm():
    obj = write_mesh(np.zeros((0, 3)), np.zeros((0, 4), dtype=int), np.zeros((0, 3), np.uint8), compress_level=9)
    assert_same_envelope(obj, rhino3dm.Mesh().Encode())


@pytest.mark.parametrize(
    "colors",
    [
        np.zeros((3, 3), np.uint8),  # one row short
        np.zeros((5, 3), np.uint8),  # one row too many
        np.zeros((4, 2), np.uint8),
        np.zeros((4, 5), np.uint8),
        np.zeros(12, np.uint8),
        np.zeros((4, 3)),  # floats are ambiguous (0..1 or 0..255)
        np.zeros((4, 3), bool),
        np.full((4, 3), 256),
        np.full((4, 4), -1),
    ],
)
def test_write_rejects_bad_colors(colors):
    V, F = CASES["one quad"]
    with pytest.raises(ValueError):
        write_mesh(V, F, colors)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(random_meshes(), st.sampled_from([3, 4]), st.integers(0, 2**32 - 1), st.sampled_from([None, 9]))
def test_property_colors_roundtrip(mesh, channels, seed, level):
    V, F = mesh
    C = np.random.default_rng(seed).integers(0, 256, size=(len(V), channels), dtype=np.uint8)
    obj = write_mesh(V, F, C, compress_level=level)
    got = read_mesh_colors(obj)
    assert_same(got[:2], (V, F))
    np.testing.assert_array_equal(got[2], rgba(C))
    rh = rhino3dm.CommonObject.Decode(obj)
    np.testing.assert_array_equal(rh_colors(rh), rgba(C))
    np.testing.assert_array_equal(read_mesh_colors(rh.Encode())[2], rgba(C))


# ----------------------------------------------------------------------------------------------
# garbage, truncation, bit flips


def test_garbage_inputs_return_none():
    good = write_mesh(*CASES["one quad"])
    bad = [
        None, 42, "text", [], {}, {"data": good["data"]},
        {**good, "version": 10001}, {**good, "archive3dm": 50}, {**good, "archive3dm": "60"},
        {**good, "opennurbs": None}, {**good, "opennurbs": 200001010}, {**good, "data": 123}, {**good, "data": "@@@@"},
        {**good, "data": good["data"][:-4]}, {**good, "data": ""},
        {**good, "data": base64.b64encode(b"\x00" * 64).decode()},
        {**good, "data": base64.b64encode(np.random.default_rng(3).bytes(5000)).decode()},
    ]
    for obj in bad:
        assert read_mesh(obj) is None
        assert read_mesh_colors(obj) is None


def test_other_geometry_returns_none():
    for geom in (rhino3dm.Point(rhino3dm.Point3d(1, 2, 3)),
                 rhino3dm.LineCurve(rhino3dm.Point3d(0, 0, 0), rhino3dm.Point3d(1, 1, 1)),
                 rhino3dm.Sphere(rhino3dm.Point3d(0, 0, 0), 2.0).ToBrep()):
        assert read_mesh(geom.Encode()) is None
        assert read_mesh_colors(geom.Encode()) is None


def test_coloured_mesh_with_user_data_falls_back():
    V, F = CASES["one quad"]
    mesh = rh_mesh(V, F)
    rh_set_colors(mesh, random_colors(4, 3))
    mesh.SetUserString("key", "value")
    assert read_mesh_colors(mesh.Encode()) is None


@pytest.mark.parametrize("level", [None, 9])
def test_truncated_coloured_returns_none(level):
    V, F = grid(7, 7)
    obj = write_mesh(V, F, random_colors(len(V), 4), compress_level=level)
    data = payload(obj)
    for k in range(len(data)):
        assert read_mesh_colors(with_payload(obj, data[:k])) is None
    assert read_mesh_colors(with_payload(obj, data + b"\x00")) is None


@pytest.mark.parametrize("level", [None, 9])
def test_bit_flips_coloured_mesh(level):
    """Every flipped bit in the colour buffer (or anywhere) is caught by a CRC or a structure check."""
    V, F = grid(12, 12)
    obj = write_mesh(V, F, random_colors(len(V), 3), compress_level=level)
    data = bytearray(payload(obj))
    rng = np.random.default_rng(13)
    for i in rng.choice(len(data), size=min(1500, len(data)), replace=False).tolist():
        bit = int(rng.integers(8))
        data[i] ^= 1 << bit
        assert read_mesh_colors(with_payload(obj, bytes(data))) is None, (i, bit)
        assert read_mesh(with_payload(obj, bytes(data))) is None, (i, bit)
        data[i] ^= 1 << bit
    assert read_mesh_colors(with_payload(obj, bytes(data))) is not None


@pytest.mark.parametrize("level", [None, 9])
def test_truncated_returns_none(level):
    obj = write_mesh(*grid(7, 7), compress_level=level)
    data = payload(obj)
    for k in range(len(data)):
        assert read_mesh(with_payload(obj, data[:k])) is None
    assert read_mesh(with_payload(obj, data + b"\x00")) is None


def _every_bit_flip_rejected(obj: dict) -> None:
    """Flip every bit of the archive in turn: each is refused; the archive itself still reads."""
    data = bytearray(payload(obj))
    for i in range(len(data)):
        for bit in range(8):
            data[i] ^= 1 << bit
            assert read_mesh(with_payload(obj, bytes(data))) is None, (i, bit)
            data[i] ^= 1 << bit
    assert read_mesh(with_payload(obj, bytes(data))) is not None


def test_every_bit_flip_small_is_rejected():
    _every_bit_flip_rejected(rh_mesh(*CASES["one quad"]).Encode())


@pytest.mark.parametrize("level", [None, 9])
def test_bit_flips_larger_mesh(level):
    V, F = grid(20, 20)
    obj = write_mesh(V, F, compress_level=level)
    data = bytearray(payload(obj))
    rng = np.random.default_rng(11)
    for i in rng.choice(len(data), size=min(1500, len(data)), replace=False).tolist():
        bit = int(rng.integers(8))
        data[i] ^= 1 << bit
        got = read_mesh(with_payload(obj, bytes(data)))
        assert got is None, (i, bit)
        data[i] ^= 1 << bit


def test_inconsistent_double_and_float_vertices_rejected():
    dV = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    _check_double_vertices(dV, dV.astype(np.float32))
    _check_double_vertices(dV + 1e-9, dV.astype(np.float32))  # within openNURBS' 1e-6 tolerance
    with pytest.raises(_Invalid):
        _check_double_vertices(dV + 1e-3, dV.astype(np.float32))


# ----------------------------------------------------------------------------------------------
# real RhinoCommon (Hops) data, archive 70


def test_rhinocommon_mesh_v70():
    obj = json.loads(data_file("hops/rc_mesh_v70.json").read_text())
    assert obj["archive3dm"] == 70
    expected = decode(obj)
    got = read_mesh(obj)
    # RhinoCommon's archive 70 mesh (with normals and double precision vertices) is fully parsed
    assert_same(got, expected)
    assert got[0].shape == (10, 3) and got[1].shape == (6, 4)


def test_hops_post_solve_request_mesh():
    request = json.loads(data_file("hops/post_solve_request.json").read_text())
    item = request["values"][0]["InnerTree"]["{0}"][0]
    assert item["type"] == "Rhino.Geometry.Mesh"
    obj = json.loads(item["data"])
    assert_same(read_mesh(obj), decode(obj))


def test_every_bit_flip_and_cut_of_a_polygon_mesh_is_rejected():
    """The n-gon chunk is checked like the rest (CRC, lengths): a pentagon's archive with any one bit flipped or cut
    short is refused (the caller falls back to rhino3dm), never read as something else, never an exception."""
    from ghserver.convert import _rhino_faces

    V = np.array([[0.0, 0, 0], [1, 0, 0], [1.5, 1, 0], [0.5, 1.5, 0], [-0.5, 1, 0]])
    F4, ngons = _rhino_faces(np.array([[0, 1, 2, 3, 4]]))
    obj = write_mesh(V, F4, ngons=ngons)
    assert read_mesh(obj)[1].tolist() == [[0, 1, 2, 3, 4]]
    _every_bit_flip_rejected(obj)
    data = payload(obj)
    for k in range(len(data)):
        assert read_mesh(with_payload(obj, bytes(data[:k]))) is None

"""Item codecs: what Hops and compute_rhino3d send decodes; outputs use the exact Hops encodings."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from components.core.types import NurbsCurve, Plane
from ghserver import params as P


@pytest.mark.parametrize("data, expected", [("2.5", 2.5), ("1.0", 1.0), (3, 3.0), ("-1e-3", -1e-3), (0.25, 0.25)])
def test_number_decodes_hops_and_raw_values(data, expected):
    assert P.decode_item("Number", {"type": "System.Double", "data": data}) == expected
    assert P.decode_item("Number", {"data": data}) == expected  # compute_rhino3d: no type


@pytest.mark.parametrize("data", ["NaN", "inf", "-Infinity", "abc", "true", "", "[1]"])
def test_number_rejects_non_finite_and_garbage(data):
    with pytest.raises(P.ParamError):
        P.decode_item("Number", {"data": data})


def test_integer_boolean_text():
    assert P.decode_item("Integer", {"data": "5"}) == 5
    assert P.decode_item("Integer", {"data": "5.0"}) == 5
    assert P.decode_item("Integer", {"data": 7}) == 7
    with pytest.raises(P.ParamError, match="integer"):
        P.decode_item("Integer", {"data": "5.5"})
    assert P.decode_item("Boolean", {"data": "true"}) is True
    assert P.decode_item("Boolean", {"data": "False"}) is False
    assert P.decode_item("Boolean", {"data": True}) is True
    with pytest.raises(P.ParamError):
        P.decode_item("Boolean", {"data": "yes"})
    # Hops JSON-quotes text; other clients may send it raw
    assert P.decode_item("Text", {"data": json.dumps('h\u00e9 "q" \\ \n')}) == 'h\u00e9 "q" \\ \n'
    assert P.decode_item("Text", {"data": "plain words"}) == "plain words"


def test_point_vector_plane_line_decode():
    assert np.array_equal(P.decode_item("Point", {"data": '{"X":1.0,"Y":2.0,"Z":3.0}'}), [1, 2, 3])
    assert np.array_equal(P.decode_item("Point", {"data": {"x": 1, "y": 2, "z": 3}}), [1, 2, 3])
    assert np.array_equal(P.decode_item("Vector", {"data": "[0, 0, 1]"}), [0, 0, 1])
    with pytest.raises(P.ParamError, match="NaN"):
        P.decode_item("Point", {"data": '{"X":NaN,"Y":2.0,"Z":3.0}'})
    with pytest.raises(P.ParamError, match="X, Y, Z"):
        P.decode_item("Point", {"data": '{"X":1.0}'})
    # a RhinoCommon Plane carries every public property
    rc_plane = {"Origin": {"X": 1, "Y": 2, "Z": 3}, "OriginX": 1, "OriginY": 2, "OriginZ": 3,
                "XAxis": {"X": 0, "Y": 1, "Z": 0}, "YAxis": {"X": -1, "Y": 0, "Z": 0},
                "ZAxis": {"X": 0, "Y": 0, "Z": 1}, "Normal": {"X": 0, "Y": 0, "Z": 1}, "IsValid": True}
    pl = P.decode_item("Plane", {"data": json.dumps(rc_plane)})
    assert isinstance(pl, Plane) and np.allclose(pl.zaxis, [0, 0, 1]) and np.allclose(pl.origin, [1, 2, 3])
    line = P.decode_item("Line", {"data": '{"From":{"X":0,"Y":0,"Z":0},"To":{"X":1,"Y":1,"Z":1},"Length":1.7}'})
    assert line.shape == (2, 3) and np.array_equal(line[1], [1, 1, 1])


def test_scalar_output_encodings_are_exact():
    assert P.encode_item("Number", 100.0) == {"type": "System.Double", "data": "100.0"}
    assert P.encode_item("Number", np.float32(0.5))["data"] == "0.5"
    assert P.encode_item("Number", 3)["data"] == "3.0"
    assert P.encode_item("Integer", 3)["data"] == "3"
    assert P.encode_item("Integer", np.int64(3))["data"] == "3"
    assert P.encode_item("Integer", 3.0)["data"] == "3"  # never "3.0"
    assert P.encode_item("Boolean", np.bool_(True))["data"] == "true"
    assert P.encode_item("Text", 'h\u00e9 "q"')["data"] == '"h\u00e9 \\"q\\""'  # JSON-quoted, not ASCII-escaped
    for bad in (math.nan, math.inf):
        with pytest.raises(P.OutputError):
            P.encode_item("Number", bad)
    with pytest.raises(P.OutputError):
        P.encode_item("Integer", 2.5)


def test_geometry_output_encodings():
    assert json.loads(P.encode_item("Point", np.array([1.0, 2, 3]))["data"]) == {"X": 1.0, "Y": 2.0, "Z": 3.0}
    assert P.encode_item("Vector", [0, 0, 1])["type"] == "Rhino.Geometry.Vector3d"
    line = json.loads(P.encode_item("Line", np.array([[0, 0, 0], [1, 2, 3.0]]))["data"])
    assert line == {"From": {"X": 0.0, "Y": 0.0, "Z": 0.0}, "To": {"X": 1.0, "Y": 2.0, "Z": 3.0}}
    pl = json.loads(P.encode_item("Plane", Plane(np.zeros(3), np.eye(3)[0], np.eye(3)[1], np.eye(3)[2]))["data"])
    assert set(pl) == {"Origin", "XAxis", "YAxis", "ZAxis"}
    c = P.encode_item("Curve", NurbsCurve(1, np.array([[0, 0, 0], [1, 0, 0.0]]), np.ones(2), np.array([0, 1.0])))
    assert c["type"] == "Rhino.Geometry.Curve" and "archive3dm" in json.loads(c["data"])
    with pytest.raises(P.OutputError, match="NaN"):
        P.encode_item("Mesh", (np.array([[np.nan, 0, 0], [1, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]])))
    with pytest.raises(P.OutputError, match="out of range"):
        P.encode_item("Mesh", (np.zeros((3, 3)), np.array([[0, 1, 5]])))

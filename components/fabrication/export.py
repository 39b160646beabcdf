"""Everything the fabrication stage computes for one mesh at once, the CSV cutting list and the DXF drawing.

:func:`fabrication` runs the steps (flat panels and their sheet layout, panel types, kinks, node axes and beams) and
returns their array-level results; :func:`cutting_list` turns them into one row per panel, :func:`write_csv` and
:func:`write_dxf` write the files. The ``.3dm`` file is written by ``ghserver`` (``ghserver fabricate``), the only
place that uses rhino3dm.
"""
from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np

from components.core.checks import check_choice, check_length, check_number
from components.core.measures import norm
from components.core.mesh import bounding_box_diagonal
from components.fabrication.congruence import PanelTypes, congruence_types, default_tolerance
from components.fabrication.kinks import Dihedrals, dihedral_angles, panel_kinks
from components.fabrication.nodes import AXES, BeamFrames, SupportAxes, beam_frames, support_axes
from components.fabrication.panels import (METHODS, FlatPanels, SheetLayout, checked_panelling, diagonal_pairs,
                                           flat_panels, placed_outlines, sheet_layout, unwelded_warning)

__all__ = ["Fabrication", "fabrication", "cutting_list", "write_csv", "write_dxf", "type_layer", "DXF_UNITS"]

#: model units (Rhino's names, as a .3dm file gives them) → the DXF header's ``$INSUNITS`` code; a model whose units
#: are not known is written unitless (0): a DXF reader then asks or assumes, where a wrong unit would scale every
#: panel by 1000 (a millimetre model read as metres)
DXF_UNITS = {"Inches": 1, "Feet": 2, "Miles": 3, "Millimeters": 4, "Centimeters": 5, "Meters": 6, "Kilometers": 7,
             "Microinches": 8, "Mils": 9, "Yards": 10, "Angstroms": 11, "Nanometers": 12, "Microns": 13,
             "Decimeters": 14, "Dekameters": 15, "Hectometers": 16, "Gigameters": 17, "AstronomicalUnits": 18,
             "LightYears": 19, "Parsecs": 20}


class Fabrication(NamedTuple):
    """Result of :func:`fabrication`."""

    V: np.ndarray  # (n, 3) the mesh
    F: np.ndarray  # (m, k)
    flat: FlatPanels
    layout: SheetLayout
    types: PanelTypes
    dihedrals: Dihedrals
    kink_limit: float  # degrees
    supports: SupportAxes
    frames: BeamFrames
    beam_height: float  # model units
    beam_width: float
    warnings: list


def fabrication(V, F, tolerance: float = 0.0, tolerances=(), mirror: bool = True, sheet_width: float = 0.0,
                sheet_height: float = 0.0, gap: float = 0.0, method: str = "project", axes: str = "auto",
                beam_height: float = 0.0, beam_width: float = 0.0, kink_limit: float = 10.0,
                name: str = "mesh") -> Fabrication:
    """Flat panels on sheets, panel types, kinks, node axes and beams of a panelling, in one call.

    Parameters
    ----------
    V : (n, 3) float64
        Vertex positions.
    F : (m, k) int64
        Padded polygon faces, consistently oriented.
    tolerance : float
        Panel-type tolerance in model units; 0: 1e-3 × the median edge length.
    tolerances : sequence of float
        Tolerances to count the types at; empty: 1, 2, 5 and 10 × the tolerance.
    mirror : bool
        A panel and its mirror image are one type.
    sheet_width, sheet_height, gap : float
        Sheets and spacing of the flat layout (see :func:`components.fabrication.panels.sheet_layout`).
    method : {"project", "unfold"}
        Flattening (see :func:`components.fabrication.panels.flat_panels`).
    axes : {"auto", "offset", "normals"}
        Node axes (see :func:`components.fabrication.nodes.support_axes`).
    beam_height, beam_width : float
        Beam size in model units; 0: 0.2 and 0.05 × the mean edge length.
    kink_limit : float
        Kinks above it (degrees) are reported in ``warnings``.
    name : str
        The mesh's name in error messages.

    Returns
    -------
    Fabrication
        The array-level results of every step.

    Raises
    ------
    MeshError
        Malformed mesh (named ``name``).
    InputError
        A bad option, or a panel larger than the sheet.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> fab = fabrication(*quad_grid(3, 2))
    >>> fab.flat.labels[:2], fab.types.type_counts.tolist(), fab.layout.sheet_count
    (['A01', 'A02'], [1, 1, 1, 1], 1)
    """
    V, F, unwelded = checked_panelling((V, F), name)
    check_choice(method, "method", METHODS)
    check_choice(axes, "axes", AXES)
    tolerance = check_number(tolerance, "tolerance", 0)
    kink_limit = check_number(kink_limit, "kink_limit", 0, 180)
    size = bounding_box_diagonal(V)
    h = check_length(beam_height, "beam_height", size, 0)
    w = check_length(beam_width, "beam_width", size, 0)
    check_length(gap, "gap", size, 0)
    flat = flat_panels(V, F, method=method)
    layout = sheet_layout(flat, sheet_width, sheet_height, gap)
    tol = default_tolerance(flat, tolerance)
    extra = [check_number(t, "tolerances", 0) for t in tolerances] or [tol, 2 * tol, 5 * tol, 10 * tol]
    types = congruence_types(flat.outline, flat.sizes, tol, extra, mirror=bool(mirror))
    dh = dihedral_angles(V, F, flat.orientation)
    sa = support_axes(V, F, axes, flat.orientation)
    fr = beam_frames(V, F, sa.axes)
    L = norm(V[fr.E[:, 1]] - V[fr.E[:, 0]])
    mean_edge = float(L.mean()) if len(L) else 1.0
    warnings = unwelded_warning(unwelded)
    res = float(np.abs(flat.residual).max(initial=0.0))
    if res > 1e-6 * mean_edge:
        warnings.append(f"panels are not planar: corners up to {res:.3g} off their panel's plane")
    over = int(np.sum(dh.angle[dh.interior] > kink_limit))
    if over:
        warnings.append(f"{over} joints kink more than {kink_limit:g}°")
    return Fabrication(V, F, flat, layout, types, dh, kink_limit, sa, fr, h if h > 0 else 0.2 * mean_edge,
                       w if w > 0 else 0.05 * mean_edge, warnings)


def _num(x) -> str:
    return "" if x is None or (isinstance(x, float) and not math.isfinite(x)) else f"{x:.10g}"


def cutting_list(fab: Fabrication) -> tuple[list[str], list[list[str]]]:
    """One row per panel: id, label, type, mirrored, sheet, area, rectangle, residual, edges, angles, diagonals, kinks.

    Returns
    -------
    header : list of str
        ``id, label, type, mirrored, sheet, area, rect_width, rect_height, max_residual``, then ``edge_1``… (edge i
        from corner i to corner i+1, model units), ``angle_1``… (interior corner angles, degrees), ``diagonal_1``…
        (corner pairs 0–2, 1–3, …), ``kink_1``… (the kink at edge i, degrees, positive at a ridge seen from the
        outside, empty on the boundary).
    rows : list of list of str
        Numbers with 10 significant digits; empty cells where a panel has fewer corners or an edge is on the
        boundary.

    Example
    -------
    >>> from components.core.mesh import quad_grid
    >>> header, rows = cutting_list(fabrication(*quad_grid(2, 1)))
    >>> header[:6], rows[0][:6], rows[0][header.index("kink_2")]
    (['id', 'label', 'type', 'mirrored', 'sheet', 'area'], ['0', 'A01', '0', '0', '0', '0.5'], '0')
    """
    flat, types = fab.flat, fab.types
    k = fab.F.shape[1]
    pairs = diagonal_pairs(k)
    kinks = panel_kinks(fab.F, fab.dihedrals, signed=True)
    header = ["id", "label", "type", "mirrored", "sheet", "area", "rect_width", "rect_height", "max_residual"]
    header += [f"edge_{i + 1}" for i in range(k)] + [f"angle_{i + 1}" for i in range(k)]
    header += [f"diagonal_{i + 1}" for i in range(len(pairs))] + [f"kink_{i + 1}" for i in range(k)]
    rows = []
    res = np.abs(flat.residual).max(axis=1)
    for f in range(len(fab.F)):
        row = [str(int(flat.ids[f])), flat.labels[f], str(int(types.types[f])), str(int(types.mirrored[f])),
               str(int(fab.layout.sheet[f])), _num(float(flat.area[f])), _num(float(flat.rect_width[f])),
               _num(float(flat.rect_height[f])), _num(float(res[f]))]
        row += [_num(float(x)) for x in flat.edge_lengths[f]] + [_num(float(x)) for x in flat.corner_angles[f]]
        row += [_num(float(x)) for x in flat.diagonals[f]] + [_num(float(x)) for x in kinks[f]]
        rows.append(row)
    return header, rows


def write_csv(path, fab: Fabrication) -> Path:
    """Write :func:`cutting_list` as CSV (comma-separated, one header row, one row per panel); returns the path.

    Example
    -------
    >>> import tempfile, os
    >>> from components.core.mesh import quad_grid
    >>> p = write_csv(os.path.join(tempfile.mkdtemp(), "cut.csv"), fabrication(*quad_grid(2, 2)))
    >>> len(p.read_text().splitlines())
    5
    """
    header, rows = cutting_list(fab)
    path = Path(path)
    with path.open("w", newline="", encoding="utf-8") as fh:
        wr = csv.writer(fh)
        wr.writerow(header)
        wr.writerows(rows)
    return path


def type_layer(t: int) -> str:
    """The DXF / 3dm layer name of panel type ``t``: ``TYPE_000``, ``TYPE_001``, …

    Example
    -------
    >>> type_layer(7)
    'TYPE_007'
    """
    return f"TYPE_{int(t):03d}"


def write_dxf(path, fab: Fabrication, units: str | None = None) -> Path:
    """Write the flat panels laid out on their sheets as DXF (AutoCAD 2010); returns the path.

    Every panel is one closed LWPOLYLINE on the layer of its type (:func:`type_layer`) with its label as a TEXT
    entity centred on it on the same layer; every sheet is a closed LWPOLYLINE on layer ``SHEETS``. Coordinates are
    the model's units, and the header says which (``$INSUNITS`` from ``units``, a name of :data:`DXF_UNITS`, e.g.
    ``"Millimeters"``; unitless when None or unknown).

    Example
    -------
    >>> import tempfile, os, ezdxf
    >>> from components.core.mesh import quad_grid
    >>> p = write_dxf(os.path.join(tempfile.mkdtemp(), "panels.dxf"), fabrication(*quad_grid(2, 2)))
    >>> msp = ezdxf.readfile(p).modelspace()
    >>> len(msp.query('LWPOLYLINE[layer=="TYPE_000"]')), sorted(t.dxf.text for t in msp.query("TEXT"))
    (4, ['A01', 'A02', 'B01', 'B02'])
    >>> ezdxf.readfile(write_dxf(p, fabrication(*quad_grid(2, 2)), "Millimeters")).units
    4
    """
    import ezdxf  # deferred import: ezdxf costs 0.5 s at import; only the DXF export needs it
    from ezdxf.enums import TextEntityAlignment  # deferred import: with ezdxf above

    flat, lay, types = fab.flat, fab.layout, fab.types
    doc = ezdxf.new("R2010", units=DXF_UNITS.get(units, 0))
    msp = doc.modelspace()
    doc.layers.add("SHEETS", color=8)
    for t in range(len(types.counts)):
        doc.layers.add(type_layer(t), color=1 + t % 254)
    for ox, oy in lay.sheet_origin.tolist():
        W, H = lay.sheet_width, lay.sheet_height
        msp.add_lwpolyline([(ox, oy), (ox + W, oy), (ox + W, oy + H), (ox, oy + H)], close=True,
                           dxfattribs={"layer": "SHEETS"})
    P = placed_outlines(flat, lay)
    c, s = np.cos(lay.angle), np.sin(lay.angle)
    cen = flat.centroid
    lab = np.stack([c * cen[:, 0] - s * cen[:, 1], s * cen[:, 0] + c * cen[:, 1]], axis=1) + lay.offset
    for f in range(len(fab.F)):
        layer = type_layer(types.types[f])
        n = int(flat.sizes[f])
        msp.add_lwpolyline([tuple(p) for p in P[f, :n].tolist()], close=True, dxfattribs={"layer": layer})
        height = 0.15 * float(flat.rect_height[f])
        txt = msp.add_text(flat.labels[f], height=height, dxfattribs={"layer": layer})
        txt.set_placement(tuple(lab[f].tolist()), align=TextEntityAlignment.MIDDLE_CENTER)
    path = Path(path)
    doc.saveas(path)
    return path

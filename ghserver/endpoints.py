"""The menu: one declaration per published component, URI → ``components.<module>.<function>``.

Names, descriptions, inputs (order, kinds, defaults) and outputs are derived from each function
(:func:`ghserver.registry.declare`); a declaration here only adds the URI and Grasshopper nicknames.
Building the list checks every function, so a mismatch fails at import.
"""
from __future__ import annotations

from components.conical import cones as conical, optimize as conical_opt
from components.core import conformal as parametrize_conformal, curvature
from components.fields import extract, field as fields, parametrize, pipeline as pipelines, remesh, streamlines
from components.metrics import health, quality as metrics
from components.network import pipeline as curvature_pipeline, rebuild as quad_rebuild, tracing as curvature_network
from components.planarize import planarizer as planarize
from components.subdivision import (coarse, pipeline as subdivision_pipeline, pull, singularities,
                                    subdivide)
from components.surfaces import generators as surfaces, samples
from ghserver.registry import Registry, declare

M = {"mesh": "M"}

COMPONENTS = [
    # metrics and analysis
    declare(metrics.planarity, "metrics/planarity", nicknames={**M, "planarity": "P"}),
    declare(metrics.warping, "metrics/warping", nicknames=M),
    declare(metrics.diagonal_ratio, "metrics/diagonal_ratio", nicknames=M),
    declare(metrics.face_areas, "metrics/face_areas", nicknames=M),
    declare(metrics.edge_lengths, "metrics/edge_lengths", nicknames=M),
    declare(metrics.corner_angles, "metrics/corner_angles", nicknames=M),
    declare(metrics.verdict_quality, "metrics/verdict_quality", nicknames=M),
    declare(metrics.conical_criterion, "metrics/conical_criterion", nicknames=M),
    declare(metrics.valence, "metrics/valence", nicknames=M),
    declare(metrics.closeness, "metrics/closeness", nicknames={**M, "reference": "R"}),
    declare(metrics.analysis, "metrics/analysis", nicknames={**M, "reference": "R"}),
    declare(metrics.report, "metrics/report", nicknames={**M, "reference": "R"}),
    declare(health.panel_health, "metrics/panel_health", nicknames={**M, "reference": "R"},
            ranges={"tolerance": (0.0, None), "min_edge_ratio": (0.0, None), "min_angle": (0.0, 90.0),
                    "min_area_ratio": (0.0, None), "min_coverage": (0.0, 1.0)}),
    # surfaces
    declare(surfaces.translation, "surfaces/translation", nicknames={"generatrix": "G", "directrix": "D"}),
    declare(surfaces.scale_translation, "surfaces/scale_translation",
            nicknames={"generatrix": "G", "directrix": "D"}),
    declare(surfaces.paraboloid, "surfaces/paraboloid"),
    declare(surfaces.surface_mesh, "surfaces/surface_mesh", nicknames={"surface": "S"}),
    declare(samples.sample, "surfaces/sample"),
    # planarization
    declare(planarize.planarize, "planarize/planarize", nicknames={**M, "reference": "R"},
            ranges={k: (0.0, None) for k in ("closeness_weight", "start_weight", "fairness_weight",
                                             "edge_length_weight", "area_weight", "conical_weight", "tolerance",
                                             "time_budget")}),
    declare(planarize.on_surface, "planarize/on_surface", nicknames={**M, "surface": "S"},
            ranges={k: (0.0, None) for k in ("closeness_weight", "fairness_weight", "tolerance", "time_budget")}),
    # fields
    declare(remesh.remesh, "fields/remesh", nicknames=M),
    declare(curvature.principal_curvature, "fields/principal_curvature", nicknames=M),
    declare(fields.smooth_field, "fields/smooth_field", nicknames=M),
    declare(fields.conjugate_field, "fields/conjugate_field", nicknames=M),
    declare(streamlines.streamlines, "fields/streamlines", nicknames=M),
    declare(parametrize.parametrize, "fields/parametrize", nicknames=M),
    declare(pipelines.extract_quads, "fields/extract_quads", nicknames=M),
    declare(pipelines.pq_from_conjugate_field, "fields/pq_from_conjugate_field", nicknames=M),
    # curvature-network strategy: conformal map, conical meshes, offsets
    declare(curvature_network.curvature_network, "network/curvature_network", nicknames=M),
    declare(parametrize_conformal.conformal_map, "parametrize/conformal_map", nicknames=M),
    declare(quad_rebuild.quad_rebuild, "network/quad_rebuild", nicknames=M),
    declare(conical_opt.optimize, "conical/optimize", nicknames={**M, "reference": "R"}),
    declare(curvature_pipeline.pq_from_curvature_network, "network/pq_from_curvature_network", nicknames=M),
    declare(conical.analysis, "conical/analysis", nicknames=M),
    declare(conical.offset, "conical/offset", nicknames=M),
    # subdivision strategy
    declare(subdivide.catmull_clark, "subdivision/catmull_clark", nicknames=M),
    declare(pull.pull_to_surface, "subdivision/pull_to_surface", nicknames={**M, "surface": "S"}),
    declare(singularities.singularity_analysis, "subdivision/singularity_analysis", nicknames={"surface": "S"}),
    declare(coarse.coarse_mesh, "subdivision/coarse_mesh", nicknames={"surface": "S"}),
    declare(subdivision_pipeline.pq_from_subdivision, "subdivision/pq_from_subdivision",
            nicknames={"surface": "S", "coarse": "C"}),
]


def build_registry() -> Registry:
    """A registry holding every published component."""
    return Registry(COMPONENTS)

"""The menu: one declaration per published component, URI → ``components.<stage>.<module>.<function>``.

Names, descriptions, inputs (order, kinds, defaults) and outputs are derived from each function
(:func:`ghserver.registry.declare`); a declaration here only adds the URI and Grasshopper nicknames.
Building the list checks every function, so a mismatch fails at import.
"""
from __future__ import annotations

import components.conical.cones
import components.conical.optimize
import components.core.conformal
import components.core.curvature
import components.fabrication.congruence
import components.fabrication.kinks
import components.fabrication.nodes
import components.fabrication.panels
import components.fields.candidate
import components.fields.field
import components.fields.parametrize
import components.fields.pipeline
import components.fields.remesh
import components.fields.streamlines
import components.metrics.health
import components.metrics.quality
import components.network.pipeline
import components.network.rebuild
import components.network.tracing
import components.planarize.planarizer
import components.subdivision.coarse
import components.subdivision.pipeline
import components.subdivision.pull
import components.subdivision.singularities
import components.subdivision.subdivide
import components.surfaces.generators
import components.surfaces.samples
from ghserver.registry import RegistrationError, Registry, declare

M = {"mesh": "M"}

COMPONENTS = [
    # metrics and analysis
    declare(components.metrics.quality.planarity, "metrics/planarity", nicknames={**M, "planarity": "P"}),
    declare(components.metrics.quality.warping, "metrics/warping", nicknames=M),
    declare(components.metrics.quality.diagonal_ratio, "metrics/diagonal_ratio", nicknames=M),
    declare(components.metrics.quality.face_areas, "metrics/face_areas", nicknames=M),
    declare(components.metrics.quality.edge_lengths, "metrics/edge_lengths", nicknames=M),
    declare(components.metrics.quality.corner_angles, "metrics/corner_angles", nicknames=M),
    declare(components.metrics.quality.verdict_quality, "metrics/verdict_quality", nicknames=M),
    declare(components.metrics.quality.conical_criterion, "metrics/conical_criterion", nicknames=M),
    declare(components.metrics.quality.valence, "metrics/valence", nicknames=M),
    declare(components.metrics.quality.closeness, "metrics/closeness", nicknames={**M, "reference": "R"}),
    declare(components.metrics.quality.analysis, "metrics/analysis", nicknames={**M, "reference": "R"}),
    declare(components.metrics.quality.report, "metrics/report", nicknames={**M, "reference": "R"}),
    declare(components.metrics.health.panel_health, "metrics/panel_health", nicknames={**M, "reference": "R"},
            ranges={"tolerance": (0.0, None), "min_edge_ratio": (0.0, None), "min_angle": (0.0, 90.0),
                    "min_area_ratio": (0.0, None), "min_coverage": (0.0, 1.0)}),
    # surfaces
    declare(components.surfaces.generators.translation, "surfaces/translation",
            nicknames={"generatrix": "G", "directrix": "D"}),
    declare(components.surfaces.generators.scale_translation, "surfaces/scale_translation",
            nicknames={"generatrix": "G", "directrix": "D"}),
    declare(components.surfaces.generators.paraboloid, "surfaces/paraboloid"),
    declare(components.surfaces.generators.surface_mesh, "surfaces/surface_mesh", nicknames={"surface": "S"}),
    declare(components.surfaces.samples.sample, "surfaces/sample"),
    # planarization
    declare(components.planarize.planarizer.planarize, "planarize/planarize", nicknames={**M, "reference": "R"},
            ranges={k: (0.0, None) for k in ("closeness_weight", "start_weight", "fairness_weight",
                                             "edge_length_weight", "area_weight", "conical_weight", "tolerance",
                                             "time_budget")}),
    declare(components.planarize.planarizer.on_surface, "planarize/on_surface", nicknames={**M, "surface": "S"},
            ranges={k: (0.0, None) for k in ("closeness_weight", "fairness_weight", "tolerance", "time_budget")}),
    # fields
    declare(components.fields.remesh.remesh, "fields/remesh", nicknames=M),
    declare(components.core.curvature.principal_curvature, "fields/principal_curvature", nicknames=M),
    declare(components.fields.field.smooth_field, "fields/smooth_field", nicknames=M),
    declare(components.fields.field.conjugate_field, "fields/conjugate_field", nicknames=M),
    declare(components.fields.streamlines.streamlines, "fields/streamlines", nicknames=M),
    declare(components.fields.parametrize.parametrize, "fields/parametrize", nicknames=M),
    declare(components.fields.candidate.extract_quads, "fields/extract_quads", nicknames=M),
    declare(components.fields.pipeline.pq_from_conjugate_field, "fields/pq_from_conjugate_field", nicknames=M),
    # curvature-network strategy: conformal map, conical meshes, offsets
    declare(components.network.tracing.curvature_network, "network/curvature_network", nicknames=M),
    declare(components.core.conformal.conformal_map, "parametrize/conformal_map", nicknames=M),
    declare(components.network.rebuild.quad_rebuild, "network/quad_rebuild", nicknames=M),
    declare(components.conical.optimize.optimize, "conical/optimize", nicknames={**M, "reference": "R"}),
    declare(components.network.pipeline.pq_from_curvature_network, "network/pq_from_curvature_network", nicknames=M),
    declare(components.conical.cones.analysis, "conical/analysis", nicknames=M),
    declare(components.conical.cones.offset, "conical/offset", nicknames=M),
    # subdivision strategy
    declare(components.subdivision.subdivide.catmull_clark, "subdivision/catmull_clark", nicknames=M),
    declare(components.subdivision.pull.pull_to_surface, "subdivision/pull_to_surface",
            nicknames={**M, "surface": "S"}),
    declare(components.subdivision.singularities.singularity_analysis, "subdivision/singularity_analysis",
            nicknames={"surface": "S"}),
    declare(components.subdivision.coarse.coarse_mesh, "subdivision/coarse_mesh", nicknames={"surface": "S"}),
    declare(components.subdivision.pipeline.pq_from_subdivision, "subdivision/pq_from_subdivision",
            nicknames={"surface": "S", "coarse": "C"}),
    # fabrication
    declare(components.fabrication.panels.panels, "fabrication/panels", nicknames=M,
            ranges={"sheet_width": (0.0, None), "sheet_height": (0.0, None), "gap": (0.0, None)}),
    declare(components.fabrication.congruence.panel_types, "fabrication/panel_types", nicknames=M,
            ranges={"tolerance": (0.0, None)}),
    declare(components.fabrication.kinks.kinks, "fabrication/kinks", nicknames=M, ranges={"limit": (0.0, 180.0)}),
    declare(components.fabrication.nodes.nodes, "fabrication/nodes", nicknames=M,
            ranges={"beam_height": (0.0, None), "beam_width": (0.0, None)}),
]


def _check_names(components) -> None:
    """Every published function is named after its URI's last part (``fields/smooth_field`` → ``smooth_field``)."""
    for c in components:
        if c.function.__name__ != c.uri.rsplit("/", 1)[-1]:
            raise RegistrationError(f"{c.function.__module__}.{c.function.__name__}: a published function is named "
                                    f"after its URI's last part ({c.uri!r})")


_check_names(COMPONENTS)


def build_registry() -> Registry:
    """A registry holding every published component."""
    return Registry(COMPONENTS)

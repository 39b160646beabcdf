"""The menu: one declaration per published component, URI → ``components.<module>.<function>``.

Names, descriptions, inputs (order, kinds, defaults) and outputs are derived from each function
(:func:`ghserver.registry.declare`); a declaration here only adds the URI and Grasshopper nicknames.
Building the list checks every function, so a mismatch fails at import.
"""
from __future__ import annotations

from components import metrics
from ghserver.registry import Registry, declare

COMPONENTS = [
    declare(metrics.planarity, "metrics/planarity", nicknames={"mesh": "M", "planarity": "P"}),
]


def build_registry() -> Registry:
    """A registry holding every published component."""
    return Registry(COMPONENTS)

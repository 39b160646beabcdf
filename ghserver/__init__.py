"""Hops component server for planar-quad meshing."""

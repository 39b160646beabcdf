"""Pure numpy/scipy algorithm steps for planar-quad meshing (no HTTP, no rhino3dm)."""

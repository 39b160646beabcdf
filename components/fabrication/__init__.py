"""The ``fabrication`` stage: from a planar-quad mesh to what the facade engineer builds from.

``panels`` (flat panels laid out on sheets), ``congruence`` (panel types), ``kinks`` (dihedral angles at the
joints), ``nodes`` (node axes, beam planes, torsion, beams) and ``export`` (everything at once, the CSV cutting list
and the DXF drawing).
"""

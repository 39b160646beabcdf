"""The ``subdivision`` stage."""

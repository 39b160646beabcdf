"""The ``core`` stage."""

"""The ``metrics`` stage."""

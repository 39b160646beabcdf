"""The ``fields`` stage."""

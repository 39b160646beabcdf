"""The ``planarize`` stage."""

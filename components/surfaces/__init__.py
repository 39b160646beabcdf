"""The ``surfaces`` stage."""

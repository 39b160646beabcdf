"""The ``network`` stage."""

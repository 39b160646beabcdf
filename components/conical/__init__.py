"""The ``conical`` stage."""

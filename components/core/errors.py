"""The typed input errors every component raises: the message starts with the input's name."""
from __future__ import annotations

__all__ = ["InputError", "MeshError"]


class InputError(ValueError):
    """Invalid input to a component. The message starts with the input's name.

    Parameters
    ----------
    name : str
        Name of the offending input (the component's parameter name).
    message : str
        What is wrong with it, e.g. ``"face 12 is degenerate (zero area)"``.
    """

    def __init__(self, name: str, message: str):
        self.input_name = name
        self.detail = message
        super().__init__(f"{name}: {message}")


class MeshError(InputError):
    """A mesh input is malformed: bad shape, NaN, index out of range, degenerate or non-manifold."""

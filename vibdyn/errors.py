"""Exceptions raised by vibdyn.

Every mistake in a scene or in an input is a :class:`ModelError` (a ``ValueError``) whose message names
the element at fault and what is wrong with it.
"""


class VibdynError(Exception):
    """Base class of every vibdyn exception."""


class ModelError(VibdynError, ValueError):
    """A scene, a scene file or an input that vibdyn cannot accept (the message names the element)."""


class SceneFileError(ModelError):
    """A scene file that cannot be read: TOML syntax or schema error, with its file and key."""

    def __init__(self, message, path=None, key=None):
        where = ", ".join(x for x in (f"file {path}" if path else "", f"key '{key}'" if key else "") if x)
        super().__init__(f"{where}: {message}" if where else message)
        self.path = path
        self.key = key


class ConvergenceError(VibdynError, RuntimeError):
    """An iterative method that did not converge; carries the residual and the best point reached."""

    def __init__(self, message, residual=None, best=None):
        super().__init__(message)
        self.residual = residual
        self.best = best

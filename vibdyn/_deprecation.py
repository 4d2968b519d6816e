"""Former public names (issue 33, item 4): each works for one release and warns once (DeprecationWarning).

:class:`Renamed` is a former attribute name on a class (read on the class or an instance); :class:`RenamedKeyword`
a former keyword of a function. Both record themselves in :data:`RENAMED`, which docs/guide/names.md lists.
"""

import os
import sys
import warnings
from typing import Any

_PACKAGE = os.path.dirname(os.path.abspath(__file__)) + os.sep

#: former name -> its replacement ("Campbell.frequencies" -> "Campbell.omega", "modes(tolerance=)" ->
#: "modes(tol=)"), filled as the modules declaring them are imported
RENAMED: dict[str, str] = {}
_warned: set[str] = set()
#: names kept with a changed meaning (no warning can tell them from a new use): docs/guide/names.md lists them
CHANGED_MEANING = {"Modes.omega_error": "Modes.omega_relative_error",
                   "Modes.eigenvalue_error": "Modes.eigenvalue_relative_error",
                   "TimeResponse.error": "TimeResponse.relative_error"}


def warn_caller(message: str, category: type[Warning] = UserWarning) -> None:
    """Warn ``message`` at the user's line: the first frame of the call stack outside the vibdyn package (and
    Python's import machinery), whatever the number of vibdyn frames between (so Python's default filters, which
    show a DeprecationWarning only when attributed to ``__main__``, show it in a user's script)."""
    frame = sys._getframe(1)
    while frame.f_back is not None and (frame.f_code.co_filename.startswith(_PACKAGE)
                                        or frame.f_code.co_filename.startswith("<frozen importlib")):
        frame = frame.f_back
    globals_ = frame.f_globals
    # (a script run by ``python -c`` or from stdin has a class, BuiltinImporter, as its __loader__: the source
    # lookup through module_globals then raises ImportError, so its globals are not passed)
    source = None if isinstance(globals_.get("__loader__"), type) else globals_
    warnings.warn_explicit(message, category, frame.f_code.co_filename, frame.f_lineno,
                           module=globals_.get("__name__", "<string>"),
                           registry=globals_.setdefault("__warningregistry__", {}), module_globals=source)


def warn_once(former: str, message: str) -> None:
    """A DeprecationWarning for ``former``, the first time only, at the user's line (:func:`warn_caller`)."""
    if former not in _warned:
        _warned.add(former)
        warn_caller(message, DeprecationWarning)


class Renamed:
    """A class attribute: the former name of the attribute ``new`` of the same class (or instance), which it reads
    with a DeprecationWarning the first time."""

    def __init__(self, new: str):
        self.new = new

    def __set_name__(self, owner: type, name: str) -> None:
        self.former = f"{owner.__name__}.{name}"
        RENAMED[self.former] = f"{owner.__name__}.{self.new}"

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        warn_once(self.former, f"{self.former} is {RENAMED[self.former]} now (the former name works until the "
                  "next release)")
        return getattr(owner if obj is None else obj, self.new)


def former_names(**renamed: str):
    """A class decorator: each keyword, a former attribute name, reads the attribute named by its value (as
    :class:`Renamed`)."""

    def declare(cls: type) -> type:
        for former, new in renamed.items():
            alias = Renamed(new)
            setattr(cls, former, alias)
            alias.__set_name__(cls, former)
        return cls

    return declare


class RenamedKeyword:
    """The former keyword ``former`` of ``where`` (a function's public name), now ``new``."""

    def __init__(self, where: str, former: str, new: str):
        self.where, self.former, self.new = where, former, new
        RENAMED[f"{where}({former}=)"] = f"{where}({new}=)"

    def __call__(self, value: Any, former_value: Any, unset: Any = None) -> Any:
        """The keyword's value: ``former_value`` (warned once) when the former keyword was given."""
        if former_value is unset:
            return value
        if value is not unset:
            from .errors import ModelError

            raise ModelError(f"{self.where}: give {self.new}= only ({self.former}= is its former name)")
        warn_once(f"{self.where}({self.former}=)", f"{self.where}({self.former}=...) is {self.where}({self.new}=...) "
                  "now (the former keyword works until the next release)")
        return former_value

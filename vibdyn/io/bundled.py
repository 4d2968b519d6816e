"""The bundled models: scene files shipped as package data of ``vibdyn.models`` (the repository's ``models/``
folder), found by name with :mod:`importlib.resources` from a source checkout and an installed wheel alike."""

from __future__ import annotations

import os
from importlib import resources
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from importlib.resources.abc import Traversable

PACKAGE = "vibdyn.models"
SUFFIX = ".toml"


def bundled_models() -> tuple[str, ...]:
    """The names of the bundled models, sorted (``"four_bar"``, ``"trailer"``, ...): each loads with
    ``vd.load_scene(name)`` and ``vibdyn info NAME``."""
    return tuple(sorted(f.name[:-len(SUFFIX)] for f in resources.files(PACKAGE).iterdir()
                        if f.name.endswith(SUFFIX) and f.is_file()))


def is_model_name(spec: object) -> bool:
    """Whether ``spec`` is a bare name ("four_bar" or "four_bar.toml": a str without a folder), the form
    that may name a bundled model; a Path or a str with a folder in it is always a file path."""
    return (isinstance(spec, str) and bool(spec) and spec not in (".", "..")
            and not any(s and s in spec for s in (os.sep, os.altsep, "/")))


def bundled_model(name: str) -> Traversable | None:
    """The bundled scene file called ``name`` ("four_bar" or "four_bar.toml"), or None if there is none."""
    if not is_model_name(name):
        return None
    stem = name[:-len(SUFFIX)] if name.endswith(SUFFIX) else name
    if stem not in bundled_models():
        return None
    return resources.files(PACKAGE).joinpath(stem + SUFFIX)

"""Shared test helpers."""

import os
from pathlib import Path

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"


def numpy_overflow():
    """The numpy RuntimeWarning (overflow, invalid value, divide by zero) a test's absurd input provokes on
    purpose on its way to a vibdyn error: asserted here, never printed (the suite runs with warnings as errors)."""
    return pytest.warns(RuntimeWarning, match="overflow|invalid value|divide by zero")

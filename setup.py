"""What pyproject.toml cannot say: the packages are vibdyn's, found, plus ``vibdyn.models``, the bundled scene
files of the top-level ``models/`` folder (``package-dir`` in pyproject.toml maps it)."""

from setuptools import find_packages, setup

setup(packages=find_packages(include=["vibdyn", "vibdyn.*"]) + ["vibdyn.models"])

"""Shared fixtures of the Python tests, and the ``slow`` marker.

The tests live in folders that mirror the package (``model/``, ``signals/``, ``campaigns/``,
``fit/``, ``studies/``, ...); the tests of the whole repository (architecture, README,
install) stay here. ``pytest -m "not slow"`` leaves out the tests marked ``slow`` (whole
diagnoses and calibrations, minutes each on 2 cores); ``.ci/test`` runs every test.

This folder is on ``sys.path`` (pytest puts a conftest's folder there), so a test in a
subfolder imports the helpers next to this file (``from _children import ...``).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import vadsim

REPOSITORY = Path(__file__).resolve().parents[2]

TINY_RUN = dict(cycles=20, analyse_cycles=10)
"""The run length of :func:`tiny_run`: enough cycles for contacts, impacts and a window."""


@pytest.fixture(scope="session")
def repository() -> Path:
    """The repository's root (docs, bench, README), wherever a test file sits."""
    return REPOSITORY


@pytest.fixture(scope="session")
def run_cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The result cache the tests that diagnose one campaign the same way share: the test
    run's own (``$VADSIM_CACHE``, which ``.ci/test`` sets for the README, the gallery and the
    tests), else a folder of this test process. A diagnosis is a function of its inputs,
    so the second one reads every run of the first instead of computing it again."""
    folder = os.environ.get("VADSIM_CACHE", "")
    return Path(folder) if folder else tmp_path_factory.mktemp("run-cache")


@pytest.fixture(scope="session")
def tiny_run() -> vadsim.SimulationResult:
    """One short run of the 7in CDE tool at 200 gal/min (regime 1: regular impacts), shared
    by the tests that need a real result but not a particular one."""
    return vadsim.simulate("7in-cde", 200, **TINY_RUN)

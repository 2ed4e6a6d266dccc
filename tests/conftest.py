"""Shared fixtures: the default configuration and its built plant models (built once)."""
import os

import pytest

from plant.model import build_plant
from rt.common.config import load

# `make test` runs two xdist workers, which already fill two cores; the diagnosis's own process
# pool (joblib, default jobs = its cpu count) would oversubscribe them, so each worker fits serially
# (the same result: tests/test_diagnose.py::test_parallel_fits_give_the_serial_result).
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ.setdefault("LOKY_MAX_CPU_COUNT", "1")


@pytest.fixture(scope="session")
def cfg():
    return load()


@pytest.fixture(scope="session")
def reduced(cfg):
    return build_plant(cfg, reduced=True)


@pytest.fixture(scope="session")
def full(cfg):
    return build_plant(cfg, reduced=False)

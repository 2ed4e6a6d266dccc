"""Shared fixtures: the default configuration and its built plant models (built once)."""
import pytest

from plant.model import build_plant
from rt.common.config import load


@pytest.fixture(scope="session")
def cfg():
    return load()


@pytest.fixture(scope="session")
def reduced(cfg):
    return build_plant(cfg, reduced=True)


@pytest.fixture(scope="session")
def full(cfg):
    return build_plant(cfg, reduced=False)

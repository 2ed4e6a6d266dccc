"""Shared fixtures: the default configuration and its built plant models (built once), and a store
for expensive results that both xdist workers of one run share (``shared_results``)."""
import fcntl
import hashlib
import os
import pickle

import pytest

from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import load

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


@pytest.fixture(scope="session")
def shared_results(tmp_path_factory):
    """``memo(key, compute)``: ``compute()``'s value, computed once per test run for ``key`` (any
    picklable value naming every input of ``compute``) and stored in a folder both xdist workers see
    (the parent of their base temporaries; a run without xdist has its own). A worker that asks for
    a value the other one is computing waits for it (one lock per key) rather than computing it
    again. Only for pure computations: the value must follow from the key alone."""
    root = tmp_path_factory.getbasetemp()
    folder = (root.parent if os.environ.get("PYTEST_XDIST_WORKER") else root) / "shared_results"
    folder.mkdir(exist_ok=True)

    def memo(key, compute):
        name = hashlib.sha256(pickle.dumps(key, protocol=5)).hexdigest()
        path = folder / f"{name}.pickle"
        with open(folder / f"{name}.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if path.exists():
                return pickle.loads(path.read_bytes())
            value = compute()
            part = folder / f"{name}.part"
            part.write_bytes(pickle.dumps(value, protocol=5))
            os.replace(part, path)
            return value
    return memo

"""The design's BLAS pin (rt/common/blas.py): OpenBLAS's Haswell kernels and one thread, set before numpy loads.

With them the design (every array the compiled loop reads) is the same bits under numpy's
other SIMD levels and glibc's other libm variants, the two things besides OpenBLAS that pick
code per CPU; a second thread alone changes it, so the pin is what makes two machines agree.
"""
import hashlib
import json
import os
import subprocess
import sys
import warnings

import pytest

import frictionrt.rt.common.blas as blas
from frictionrt.rt.log.design_record import environment_changes

# numpy's SIMD levels above its x86-64-v2 baseline (numpy >= 2.4 names; unknown names are ignored)
# and glibc's libm without its AVX/AVX2/FMA/AVX-512 variants: what an older CPU would run
OTHER_CPU = {"NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR AVX2 AVX512F AVX512_SKX FMA3",
             "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F,-AVX"}



def design_digest() -> str:
    """sha256 over every array the compiled loop reads (Lyapunov law, observer) and its initial state."""
    from frictionrt.rt.common.config import load
    from frictionrt.rt.log.design_record import design_arrays
    from frictionrt.rt.loop.build import build_loop, initial_loop_state
    loop = build_loop(load(), "lyapunov", "observer")
    arrays = design_arrays(loop, initial_loop_state(loop, 1))
    h = hashlib.sha256()
    for k in sorted(arrays):
        h.update(k.encode())
        h.update(arrays[k].tobytes())
    return h.hexdigest()


def digest_in_subprocess(env_extra: dict) -> str:
    code = "from tests.test_blas_pin import design_digest; print(design_digest())"
    p = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, **env_extra), capture_output=True,
                       text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    return p.stdout.strip()


def test_this_process_runs_the_pinned_kernels_on_one_thread(reduced):
    libs = blas.state()   # after a design (the fixture built one)
    assert libs, "no BLAS library found by threadpoolctl"
    assert all(lib["threads"] == 1 for lib in libs), libs
    if os.environ.get("OPENBLAS_CORETYPE") == blas.KERNELS:
        assert {lib["kernels"] for lib in libs if lib["kernels"]} == {blas.KERNELS}, libs


def test_the_design_is_the_same_bits_on_a_cpu_with_other_simd_and_libm_and_not_with_another_thread():
    ours = digest_in_subprocess({})   # a fresh process: frictionrt imported before numpy, as from the CLI
    assert digest_in_subprocess(OTHER_CPU) == ours
    # not vacuous: a second BLAS thread alone moves the design's last bits (measured: 25 of 146 arrays)
    assert digest_in_subprocess({"OPENBLAS_NUM_THREADS": "2"}) != ours


def test_numpy_loaded_first_gets_one_thread_and_a_warning_naming_its_kernels(monkeypatch):
    monkeypatch.setattr(blas, "_asked", {})
    monkeypatch.setattr(blas, "_warned", False)
    monkeypatch.delenv("OPENBLAS_CORETYPE", raising=False)
    monkeypatch.setattr(blas, "_cpu_runs_kernels", lambda: True)
    monkeypatch.setattr(blas, "state", lambda: [{"library": "libopenblas.so", "version": "0.3.31",
                                                 "kernels": "SkylakeX", "threads": 1}])
    with pytest.warns(UserWarning, match=r"SkylakeX kernels, not the Haswell .*OPENBLAS_CORETYPE=Haswell"):
        blas.check()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        blas.check()   # once per process
    monkeypatch.setenv("OPENBLAS_CORETYPE", "SkylakeX")   # the user's own choice: no warning
    monkeypatch.setattr(blas, "_warned", False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        blas.check()


def test_replay_names_another_blas():
    now = blas.state()
    then = [dict(lib, kernels="SkylakeX", threads=2) for lib in now]
    changes = environment_changes({"blas": json.dumps(then)})
    assert any(c.startswith("BLAS SkylakeX x 2 -> ") for c in changes), changes
    assert environment_changes({"blas": json.dumps(now)}) == []
    assert environment_changes({"blas": "{"}) == ["the log's versions, codegen or blas record is unreadable"]


def test_a_run_log_records_the_blas_it_ran_on(cfg):
    from frictionrt.rt.log.writer import run_metadata
    meta = run_metadata(cfg, "passive", "oracle", 1, 200.0, 5.0, 0.1, False)
    assert json.loads(meta["blas"]) == blas.state() != []

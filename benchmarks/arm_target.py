"""The C export on Cortex-M targets, run under qemu-arm user mode: the golden vectors bit for bit,
and the instructions each tick takes.

    python -m benchmarks.arm_target DIR_DOUBLE DIR_FLOAT32 [--ticks N]

An export built with arm-none-eabi-gcc for a Cortex-M4F (``-mcpu=cortex-m4 -mfpu=fpv4-sp-d16
-mfloat-abi=hard``: single-precision FPU, doubles in software) or a Cortex-M7 (``-mcpu=cortex-m7
-mfpu=fpv5-d16``: double-precision FPU) is linked with newlib and benchmarks/arm/linux_shim.c
(newlib's system calls as Linux syscalls) and run by ``qemu-arm -cpu max`` (qemu 7.2's M-profile
CPUs do not start in user mode; the A-profile core executes the same Thumb-2 and VFP
instructions). ``check`` runs the export's ctrl_check on its golden vectors; ``count`` runs
benchmarks/arm/ctrl_count.c over the first N golden ticks with ``-singlestep -d nochain,exec`` (one
log line per executed instruction) and counts, per tick, the instructions from ctrl_step's entry to
its return (the callees included: the soft-float helpers of libgcc, memcpy). An instruction count
is not a cycle count: on a Cortex-M4 most instructions take 1 cycle, VFP divisions 14, loads 2,
taken branches 2-4, so cycles are about 1.2-1.5 times the count (the ARM Cortex-M4 TRM's timings);
it says which build fits a budget by a wide margin, not by a few percent.
"""
from __future__ import annotations

import argparse
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).with_name("arm")
CC = "arm-none-eabi-gcc"
QEMU = "qemu-arm"
CPUS = {"cortex-m4f": ("-mcpu=cortex-m4", "-mfpu=fpv4-sp-d16", "-mfloat-abi=hard", "-mthumb"),
        "cortex-m7": ("-mcpu=cortex-m7", "-mfpu=fpv5-d16", "-mfloat-abi=hard", "-mthumb")}
FLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra")
# a tick is the run of trace lines outside main that starts in ctrl_step
AWK = ('{s=$NF} s=="main"{if(t){print c}; c=0; t=0; next} '
       '{if(!t && c==0 && s=="ctrl_step"){t=1} if(t){c++} else {c=-1}}')


def have_toolchain() -> bool:
    """arm-none-eabi-gcc with newlib, and qemu-arm."""
    return bool(shutil.which(CC) and shutil.which(QEMU) and shutil.which("awk"))


def build(folder, cpu: str, program: str, work) -> Path:
    """Compile the export in ``folder`` with ``program`` ("ctrl_check" from the folder, or
    "ctrl_count" from benchmarks/arm) for ``cpu`` (``CPUS``) into ``work``; the executable's path.
    CalledProcessError with the compiler's message on a failed build."""
    folder, work = Path(folder), Path(work)
    src = folder / "ctrl_check.c" if program == "ctrl_check" else HERE / "ctrl_count.c"
    exe = work / f"{program}_{cpu}"
    cmd = [CC, *FLAGS, *CPUS[cpu], "-I", str(folder), "-nostartfiles", "-o", str(exe), str(folder / "frictionrt_ctrl.c"),
           str(src), str(HERE / "linux_shim.c"), "-lc", "-lgcc"]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    return exe


def check(folder, cpu: str) -> subprocess.CompletedProcess:
    """The export's golden vectors through its ctrl_check built for ``cpu``, under qemu-arm."""
    with tempfile.TemporaryDirectory() as work:
        exe = build(folder, cpu, "ctrl_check", work)
        return subprocess.run([QEMU, "-cpu", "max", str(exe), str(Path(folder) / "golden_in.txt"),
                               str(Path(folder) / "golden_out.txt")], capture_output=True, text=True)


def count(folder, cpu: str, ticks: int) -> np.ndarray:
    """Instructions of each of the first ``ticks`` golden ticks' ctrl_step, built for ``cpu``."""
    with tempfile.TemporaryDirectory() as work:
        exe = build(folder, cpu, "ctrl_count", work)
        cmd = (f"{QEMU} -cpu max -singlestep -d nochain,exec {exe} {Path(folder) / 'golden_in.txt'} {int(ticks)} "
               f"2>&1 >/dev/null | awk '{AWK}'")
        r = subprocess.run(["sh", "-c", cmd], capture_output=True, text=True, check=True)
    n = np.array([int(v) for v in r.stdout.split()], dtype=np.int64)
    if len(n) != ticks:
        raise RuntimeError(f"counted {len(n)} ticks of {ticks} ({cpu}, {folder})")
    return n


def size(folder, cpu: str) -> int:
    """Bytes of code and constants of frictionrt_ctrl.o built for ``cpu`` (text; data and bss are 0)."""
    with tempfile.TemporaryDirectory() as work:
        obj = Path(work) / "c.o"
        subprocess.run([CC, *FLAGS, *CPUS[cpu], "-I", str(folder), "-c", "-o", str(obj),
                        str(Path(folder) / "frictionrt_ctrl.c")], check=True, capture_output=True)
        out = subprocess.run(["arm-none-eabi-size", str(obj)], capture_output=True, text=True, check=True).stdout
    return int(out.splitlines()[1].split()[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("double", help="an export-c folder (double kind)")
    ap.add_argument("float32", help="an export-c --precision float32 folder of the same design")
    ap.add_argument("--ticks", type=int, default=3150, help="golden ticks to count (default: all 3150)")
    ap.add_argument("--budget", type=float, default=168e6 / 21000, help="cycles per tick (168 MHz / 21 kHz)")
    a = ap.parse_args()
    rows = [("double", a.double, "cortex-m4f"), ("double", a.double, "cortex-m7"), ("float32", a.float32, "cortex-m4f"),
            ("float32", a.float32, "cortex-m7")]
    print(f"instructions per tick over the first {a.ticks} golden ticks; budget {a.budget:.0f} cycles")
    print("| kind | core | check | median | p99 | max | text [B] | max / budget |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for kind, folder, cpu in rows:
        ok = check(folder, cpu)
        n = count(folder, cpu, a.ticks)
        print(f"| {kind} | {cpu} | {ok.stdout.strip()[:24] if ok.returncode == 0 else 'FAIL'} | {np.median(n):.0f} | "
              f"{np.percentile(n, 99):.0f} | {n.max()} | {size(folder, cpu)} | {n.max() / a.budget:.2f} |", flush=True)


if __name__ == "__main__":
    main()

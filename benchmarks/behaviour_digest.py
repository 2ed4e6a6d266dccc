"""A digest of what the command line computes, to show that a refactoring changed no behaviour.

    python -m benchmarks.behaviour_digest OUT.json [--quick]
    python -m benchmarks.behaviour_digest --compare BEFORE.json AFTER.json

Runs fixed-seed commands through the installed ``frictionrt`` entry point (so the same script
checks any layout of the code): simulate (three laws, oracle and observer), replay and replay
--plant of one of these logs, rig (an MCAP campaign and an FRF-file campaign), diagnose of
both, modes, impulse, and (without --quick) reproduce --quick. Every MCAP log is decoded with
the ROS 2 decoder (mcap_ros2, not the project's reader) and each field of each topic is hashed
(SHA-256 of its float64/int64 bytes); the JSON outputs are hashed after removing what is
wall-clock by nature (tick_ns, late_ns, stamp, start_utc, timings, command lines, paths). The output
maps every item to its hash; ``--compare`` prints the items that differ and exits 1 if any.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

WALL_CLOCK_FIELDS = {"tick_ns", "late_ns", "stamp"}  # stamp: start_utc + k dt
WALL_CLOCK_KEYS = {"start_utc", "timing_s", "timings", "wall_s", "elapsed_s", "command", "argv",
                   "run_s", "tick_us", "tick_median_us", "tick_p99_us", "tick_max_us", "seconds",
                   "out", "path", "folder", "report", "files", "recording_id", "overruns",
                   "late_max_us", "time_s", "realtime_factor"}


def _frictionrt() -> str:
    exe = shutil.which("frictionrt") or str(Path(sys.executable).with_name("frictionrt"))
    return exe


def _run(args: list[str], cwd: Path) -> str:
    r = subprocess.run([_frictionrt(), *args], cwd=cwd, capture_output=True, text=True)
    if r.returncode not in (0, 1):
        raise SystemExit(f"frictionrt {' '.join(args)} failed ({r.returncode}):\n{r.stderr[-2000:]}")
    return r.stdout


def _scrub(obj):
    """The JSON value without its wall-clock parts (WALL_CLOCK_KEYS, anywhere in the tree)."""
    if isinstance(obj, dict):
        return {k: _scrub(v) for k, v in sorted(obj.items()) if k not in WALL_CLOCK_KEYS}
    if isinstance(obj, list):
        return [_scrub(v) for v in obj]
    return obj


def _hash_json(text: str) -> str:
    start = text.find("{")
    obj = _scrub(json.loads(text[start:]))
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def _hash_mcap(path: Path) -> dict[str, str]:
    """{topic/field: hash} of a log, decoded by the ROS 2 decoder."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    columns: dict[str, list] = {}
    with open(path, "rb") as fh:
        reader = make_reader(fh, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(log_time_order=False):
            for field in msg.__slots__:
                if field in WALL_CLOCK_FIELDS:
                    continue
                value = getattr(msg, field)
                if hasattr(value, "sec"):  # builtin_interfaces/Time: stamps are tick-derived
                    value = value.sec * 1_000_000_000 + value.nanosec
                columns.setdefault(f"{channel.topic}/{field}", []).append(value)
    return {k: hashlib.sha256(np.asarray(v).tobytes()).hexdigest()[:16] for k, v in sorted(columns.items())}


def digest(work: Path, quick: bool) -> dict[str, str]:
    out: dict[str, str] = {}
    for law, est, freq in (("passive", "oracle", 205), ("hysteresis", "observer", 380), ("lyapunov", "oracle", 205)):
        name = f"sim_{law}_{est}"
        _run(["simulate", "--law", law, "--estimator", est, "--freq", str(freq), "--amp", "5",
              "--duration", "0.15", "--out", name], work)
        out.update({f"{name}:{k}": v for k, v in _hash_mcap(work / f"{name}.mcap").items()})
    log = "sim_lyapunov_oracle.mcap"
    out["replay"] = _hash_json(_run(["replay", log, "--json"], work))
    out["replay_plant"] = _hash_json(_run(["replay", "--plant", log, "--json"], work))
    out["modes"] = _hash_json(_run(["modes", "--json"], work))
    out["impulse"] = _hash_json(_run(["impulse", "--fn1", "100", "--json"], work))
    _run(["rig", "--effect", "moving_mass", "--seed", "3", "-o", "campaign"], work)
    for f in sorted((work / "campaign").glob("*.mcap")):
        out.update({f"rig/{f.stem}:{k}": v for k, v in _hash_mcap(f).items()})
    out["diagnose"] = _hash_json(_run(["diagnose", "campaign", "--json", "--jobs", "2"], work))
    _run(["rig", "--effect", "clamp_compliance", "--seed", "1", "--frf-files", "-o", "frf"], work)
    for f in sorted((work / "frf").glob("*.csv")):
        out[f"rig_frf/{f.name}"] = hashlib.sha256(f.read_bytes()).hexdigest()[:16]
    out["diagnose_frf"] = _hash_json(_run(["diagnose", "frf", "--json"], work))
    if not quick:
        out["reproduce_quick"] = _hash_json(_run(["reproduce", "--quick", "--json", "--out", "rq"], work))
    return out


def _without_wall_clock(d: dict[str, str]) -> dict[str, str]:
    """A digest without the fields that are wall-clock by nature (a digest written before a
    field joined ``WALL_CLOCK_FIELDS`` compares too)."""
    return {k: v for k, v in d.items() if k.rsplit("/", 1)[-1] not in WALL_CLOCK_FIELDS}


def compare(before: Path, after: Path) -> int:
    a, b = (_without_wall_clock(json.loads(p.read_text())) for p in (before, after))
    differ = sorted(k for k in a.keys() | b.keys() if a.get(k) != b.get(k))
    for k in differ:
        print(f"differs: {k}: {a.get(k)} -> {b.get(k)}")
    print(f"{len(a.keys() | b.keys()) - len(differ)} items identical, {len(differ)} differ")
    return 1 if differ else 0


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", nargs="?", type=Path, help="write the digest here (JSON)")
    p.add_argument("--quick", action="store_true", help="leave out reproduce --quick")
    p.add_argument("--compare", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    a = p.parse_args()
    if a.compare:
        return compare(*a.compare)
    if a.out is None:
        p.error("give OUT.json or --compare BEFORE AFTER")
    with tempfile.TemporaryDirectory() as tmp:
        d = digest(Path(tmp), a.quick)
    a.out.write_text(json.dumps(d, indent=1, sort_keys=True) + "\n")
    print(f"{len(d)} items -> {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Soak: a paced run with logging (MCAP and rrd) for minutes, watched from outside.

    python -m benchmarks.soak [--minutes 10] [--law lyapunov] [--out logs/soak] [--no-rrd]
                              [--rt-priority N --cpu K] [--null-s 60] [--json]

Starts ``frictionrt simulate --paced --duration 60*MINUTES --out OUT`` as a child process and
samples its resident memory (VmRSS, /proc) every second. Afterwards it reports, from the run's
JSON summary and from the files themselves:

* memory: RSS at the start of the loop (first sample after the log file appears), at the end, and
  its maximum [MB]; flat means the end is within a few MB of the start;
* timing: overruns (missed periods) and their rate, the lateness of each tick's start against its
  deadline (the logged /rt.late_ns) as p50 / p99 / p99.9 / max [us], read chunk by chunk; and,
  next to them, the null loop's (the same pacing and real-time set-up with an empty tick, for
  --null-s seconds after the soak, rt/loop/floor.py): the machine's floor;
* logging: dropped log blocks, unwritten ticks, file sizes;
* readability: the MCAP's summary and every chunk decoded (rt.log.mcap_log's chunk walker, one chunk
  in memory at a time: a 10-minute log is ~8 GB), ticks strictly increasing and every value finite.

Run it on a quiet machine: the paced loop shares two cores with the log writer.
"""
import argparse
import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np


def _rss_mb(pid: int) -> float | None:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def _scan_mcap(path: Path) -> dict:
    """Chunk-by-chunk check of a (large) run log: ticks increasing, values finite, late_ns stats."""
    from mcap.reader import make_reader

    from frictionrt.rt.log.mcap_log import chunk_messages, file_topics, payload_rows
    late, n_msgs, last_k, bad_ticks, nonfinite = [], 0, {}, 0, 0
    with open(path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        summary = reader.get_summary()
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
        _, signals, _, _, topics = file_topics(meta, {})
        late_col = next(i for i, (n, _, _) in enumerate(signals) if n == "late_ns")
        for (_, channel), (payloads, times, seqs) in chunk_messages(f, summary):
            tp = topics[channel.topic]
            k, _, vals = tp.decode(payload_rows(path, tp, [payloads]))
            n_msgs += len(vals)
            nonfinite += int(np.count_nonzero(~np.isfinite(vals)))
            prev = last_k.get(tp.name, -1)
            bad_ticks += int(np.count_nonzero(np.diff(np.concatenate([[prev], k])) <= 0))
            last_k[tp.name] = int(k[-1])
            if late_col in tp.columns:
                late.append(vals[:, list(tp.columns).index(late_col)])
    late = np.concatenate(late) / 1e3 if late else np.zeros(1)
    return {"chunks": len(summary.chunk_indexes), "messages": n_msgs, "non_increasing_ticks": bad_ticks,
            "non_finite_values": nonfinite, "last_tick": max(last_k.values()) if last_k else None,
            "late_us": {q: float(np.percentile(late, p)) for q, p in
                        (("p50", 50), ("p99", 99), ("p99.9", 99.9))} | {"max": float(late.max())}}


def soak(minutes: float, law: str, out: Path, rrd: bool, rt_sets: list[str], null_s: float) -> dict:
    duration = 60.0 * minutes
    sets = [a for s in rt_sets for a in ("--set", s)]
    cmd = [sys.executable, "-m", "frictionrt.rt.cli", *sets, "simulate", "--paced", "--law", law, "--freq", "223.6", "--amp", "5",
           "--duration", str(duration), "--out", str(out), "--json"] + ([] if rrd else ["--no-rrd"])
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    samples: list[tuple[float, float]] = []
    part = out.with_name(out.name + ".mcap.part")

    def watch():
        t0 = None
        while proc.poll() is None:
            if t0 is None and part.exists():
                t0 = time.monotonic()
            rss = _rss_mb(proc.pid)
            if t0 is not None and rss is not None:
                samples.append((time.monotonic() - t0, rss))
            time.sleep(1.0)

    watcher = threading.Thread(target=watch)
    watcher.start()
    stdout, stderr = proc.communicate()
    watcher.join()
    if proc.returncode != 0:
        raise SystemExit(f"simulate failed ({proc.returncode}): {stderr.strip()[-500:]}")
    run = json.loads(stdout)
    rss = np.array([s[1] for s in samples])
    t0 = time.perf_counter()
    scan = _scan_mcap(Path(run["mcap"]))
    from frictionrt.rt.common.config import load
    from frictionrt.rt.loop.floor import null_loop
    cfg = load(sets=rt_sets)
    null = null_loop(cfg.rt, cfg.dt_s, null_s) if null_s > 0 else None
    res = {"minutes": minutes, "law": law, "ticks": run["ticks"], "overruns": run["overruns"],
           "overrun_rate": run["overruns"] / (run["ticks"] + run["overruns"]), "realtime": run.get("realtime"),
           "null": null,
           "dropped_blocks": run["dropped_blocks"], "unwritten_ticks": run.get("unwritten_ticks", 0),
           "rss_mb": {"start": float(rss[min(5, len(rss) - 1)]), "end": float(rss[-1]), "max": float(rss.max()),
                      "samples": len(rss)},
           "files_mb": {k: Path(run[k]).stat().st_size / 1e6 for k in ("mcap", "rrd") if run.get(k)},
           "scan": scan, "scan_s": time.perf_counter() - t0}
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--minutes", type=float, default=10.0, help="paced run length [min] (default 10)")
    ap.add_argument("--law", default="lyapunov", help="control law (default lyapunov: the busiest)")
    ap.add_argument("--out", default="logs/soak", help="log base name (default logs/soak)")
    ap.add_argument("--no-rrd", action="store_true", help="MCAP only")
    ap.add_argument("--rt-priority", type=int, default=0, metavar="N", help="SCHED_FIFO priority of the loop thread "
                    "(rt.priority; 0: off)")
    ap.add_argument("--cpu", type=int, default=-1, metavar="K", help="the loop thread's core (rt.cpu; -1: not pinned)")
    ap.add_argument("--null-s", type=float, default=60.0, metavar="S", help="null loop after the soak [s] (0: none)")
    ap.add_argument("--json", action="store_true", help="one JSON object")
    args = ap.parse_args()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    res = soak(args.minutes, args.law, out, not args.no_rrd, [f"rt.priority={args.rt_priority}", f"rt.cpu={args.cpu}"],
               args.null_s)
    if args.json:
        print(json.dumps(res))
        return
    r, s = res["rss_mb"], res["scan"]
    print(f"soak {res['minutes']:g} min paced, {res['law']}: {res['ticks']} ticks, overruns {res['overruns']} "
          f"({100 * res['overrun_rate']:.4f} %), dropped blocks {res['dropped_blocks']}, unwritten ticks "
          f"{res['unwritten_ticks']}")
    if res["null"] is not None:
        n = res["null"]
        print(f"  null loop ({n['ticks']} ticks, same set-up): overruns {n['overruns']} ({100 * n['overrun_rate']:.4f} %), "
              f"lateness [us] p99 {n['late']['p99_us']:.1f}, p99.9 {n['late']['p999_us']:.1f}, "
              f"max {n['late']['max_us']:.1f}")
    print(f"  RSS [MB]: start {r['start']:.0f}, end {r['end']:.0f}, max {r['max']:.0f} ({r['samples']} samples)")
    print("  lateness [us]: " + ", ".join(f"{k} {v:.1f}" for k, v in s["late_us"].items()))
    print(f"  files [MB]: {', '.join(f'{k} {v:.0f}' for k, v in res['files_mb'].items())}")
    print(f"  MCAP scan: {s['chunks']} chunks, {s['messages']} messages, last tick {s['last_tick']}, "
          f"non-increasing ticks {s['non_increasing_ticks']}, non-finite values {s['non_finite_values']} "
          f"({res['scan_s']:.0f} s)")


if __name__ == "__main__":
    main()

"""``frictionrt replay RUN.mcap --plant``: the open-loop plant replay (rt/loop/replay_plant.py)."""
from __future__ import annotations

import json

from rt.cli.common import fail


def cmd_replay_plant(cfg, args) -> int:
    """Replay the log's V_cmd and F_exc into actuator and plant and compare their outputs; exit 0
    when bit-exact (or nothing to compare), 1 when they differ, 2 for a bad file."""
    from rt.log.design_record import describe
    from rt.loop.replay_plant import replay_plant
    if args.paced:
        return fail("--plant with --paced: the plant replay runs offline only; drop --paced")
    try:
        res = replay_plant(args.log, fallback_cfg=cfg, sets=args.sets)
    except ValueError as exc:
        return fail(str(exc))
    code = 1 if res["bit_exact"] is False else 0
    if args.json:
        print(json.dumps(res))
        return code
    sets = f" with {' '.join(res['sets'])}" if res["sets"] else ""
    print(f"replay --plant {res['file']}{sets}: {res['ticks']} ticks of V_cmd, F_exc into actuator and plant "
          f"({res['wall_s']:.2f} s), failed contact solves {res['failed_solves']}")
    if res["missing_ticks"]:
        print(f"  the log misses {res['missing_ticks']} ticks: replayed up to the first gap only")
    print(describe(res["design"]))
    if res["bit_exact"] is None:
        print("  no recorded /actuator or /plant signals: nothing to compare; replayed (min / mean / max):")
        for name, o in res["outputs"].items():
            print(f"  {name:>10} {o['min']:>12.5g} {o['mean']:>12.5g} {o['max']:>12.5g}")
        return code
    print(f"  {'bit-exact' if res['bit_exact'] else 'DIFFERS'}: max |diff| {res['max_abs_diff']:.3g} over "
          f"{len(res['signals_compared'])} /actuator and /plant signals")
    if not res["bit_exact"]:
        worst = sorted(((v, k) for k, v in res["max_abs_diff_by_signal"].items() if v), reverse=True)[:8]
        print(f"  first mismatch at tick {res['first_mismatch_tick']}; largest |diff| (SI units): "
              + ", ".join(f"{k} {v:.3g}" for v, k in worst))
    return code

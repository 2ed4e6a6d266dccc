# %% [markdown]
# # Tune a gain in a script
#
# A grid of the Lyapunov law's boundary layer eps, each candidate scored by step-sine sweeps
# around mode 3: the mean peak change against passive [dB] (negative = lower) and the actuator
# power [W]. The same as
# `frictionrt tune --law lyapunov --grid tracking.eps_m_s=0.003,0.01,0.03 --modes 3 --amps 5`
# (docs/recipes/tune-a-gain.md). About 40 s on 2 cores; `FRICTIONRT_EXAMPLES_QUICK=1` runs two
# values on 5 points (the test suite's version).

# %%
import os
from pathlib import Path

import frictionrt as fr

SMALL = os.environ.get("FRICTIONRT_EXAMPLES_QUICK") == "1"
OUT = Path(os.environ.get("FRICTIONRT_EXAMPLES_OUT", "logs/examples"))
OUT.mkdir(parents=True, exist_ok=True)

cfg = fr.load_config()
eps = [0.01, 0.03] if SMALL else [0.003, 0.01, 0.03]
res = fr.tune(cfg, law="lyapunov", grid={"tracking.eps_m_s": eps}, modes=(3,), amps_n=(5.0,),
              points=5 if SMALL else 9, jobs=1 if SMALL else None, out=OUT / "tune", force=True,
              progress=not SMALL)

# %% [markdown]
# One row per candidate; the best has the lowest peak change (within `max_power_w` if given).
# `res.warnings` says where the grid does not resolve the passive peak, and how many points would.

# %%
for row in res.rows():
    print(f"eps {row['tracking.eps_m_s']:<6g} peak change {row['peak_change_db']:+6.2f} dB, "
          f"power {row['power_w']:.3g} W{'  <- best' if row['best'] else ''}")
for w in res.warnings:
    print("warning:", w)

# %% [markdown]
# The best configuration runs everywhere a configuration does, e.g. as the start of a finer grid:

# %%
best = res.best_config
print("best eps:", best.tracking.eps_m_s)
res.plot().savefig(OUT / "tune_pareto.png")

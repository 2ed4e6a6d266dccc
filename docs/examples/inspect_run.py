# %% [markdown]
# # Inspect a run in Foxglove and rerun
#
# A closed-loop run with every signal logged while it runs: `run.mcap` (ROS 2 messages, open it
# in Foxglove with the layout `run.foxglove.json`) and `run.rrd` (open it with `rerun run.rrd`,
# or in a notebook). The same as
# `frictionrt simulate --law lyapunov --freq 205 --amp 5 --duration 1 --out logs/examples/run`
# (docs/recipes/inspect-a-run.md). About 5 s; `FRICTIONRT_EXAMPLES_QUICK=1` runs 0.2 s.

# %%
import os
from pathlib import Path

import frictionrt as fr

SMALL = os.environ.get("FRICTIONRT_EXAMPLES_QUICK") == "1"
OUT = Path(os.environ.get("FRICTIONRT_EXAMPLES_OUT", "logs/examples"))
OUT.mkdir(parents=True, exist_ok=True)

res = fr.simulate(law="lyapunov", freq_hz=205.0, amp_n=5.0, duration_s=0.2 if SMALL else 1.0,
                  out=OUT / "run", force=True)
print(f"acceleration at 0.45 m: {res['acc045_amplitude']:.3f} m/s^2, mean F_N1 {res['fn1_mean_n']:.1f} N")
print(f"log: {res['mcap']} (Foxglove layout {res['foxglove_layout']}), {res['rrd']} (rerun)")

# %% [markdown]
# The run's signals are numpy arrays too (the same ticks the log holds):

# %%
F_N1 = res.run.signal("F_N1")
print(f"F_N1 over the run: {F_N1.min():.1f} .. {F_N1.max():.1f} N, {len(F_N1)} ticks")
res.plot().savefig(OUT / "run.png")

# %% [markdown]
# A replay of the log through the controller gives the same bits (the hardware-in-the-loop check):

# %%
print("replay bit-exact:", fr.replay(res["mcap"])["bit_exact"])

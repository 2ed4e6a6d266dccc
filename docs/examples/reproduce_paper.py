# %% [markdown]
# # Reproduce the paper
#
# Becker & Gaul's experiments and claims C1..C6 on the simulated rig: the impulse test, the
# step-sine FRFs of passive, hysteresis-optimal and Lyapunov control around the resonances, and
# the best constant clamping force. The same as
# `frictionrt reproduce --quick --out logs/examples/reproduce` (docs/recipes/reproduce-the-paper.md).
#
# Run it with `python docs/examples/reproduce_paper.py` (the quick plan: about 30 s on 2 cores),
# or open it in Jupyter with jupytext. `FRICTIONRT_EXAMPLES_QUICK=1` runs a smaller version
# (mode 3, the observer only), which the test suite runs.

# %%
import os
from pathlib import Path

import frictionrt as fr

SMALL = os.environ.get("FRICTIONRT_EXAMPLES_QUICK") == "1"
OUT = Path(os.environ.get("FRICTIONRT_EXAMPLES_OUT", "logs/examples"))
OUT.mkdir(parents=True, exist_ok=True)

cfg = fr.load_config()                      # the spec's defaults; fr.load_config("my.toml", sets=[...])
# error_estimate: how far the plant's discretisation moves each claim's margin ("auto": the stored
# margins of the default's quick plan; the small version's one-mode plan has none, so it skips it)
res = fr.reproduce(cfg, quick=True, modes=(3,) if SMALL else None,
                   estimators=("observer",) if SMALL else fr.ESTIMATORS, out=OUT / "reproduce", force=True,
                   progress=not SMALL, error_estimate="none" if SMALL else "auto")

# %% [markdown]
# Which claims hold, on the paper's observer and on the oracle (the plant's own u_rel, v_rel):

# %%
for estimator, verdicts in res.verdicts().items():
    print(f"{estimator:>8}: " + ", ".join(f"{c} {'yes' if ok else 'NO'}" for c, ok in verdicts.items()))

# %% [markdown]
# The change of each resonance peak against passive [dB], negative = lower (law -> mode -> amplitude):

# %%
print(res["by_estimator"]["observer"]["peak_change_db"])

# %% [markdown]
# The Lyapunov law against passive (the paper's Fig. 8); `res.plot("hysteresis")` is Fig. 7.

# %%
fig = res.plot("lyapunov")
fig.savefig(OUT / "reproduce_fig8.png")
print(f"report: {OUT / 'reproduce' / 'report.md'}")

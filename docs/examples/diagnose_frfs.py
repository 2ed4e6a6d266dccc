# %% [markdown]
# # Diagnose your own measured FRFs
#
# FRFs as an analyser exports them (here: a stand-in written from the virtual rig, whose true
# structure carries an extra mass at the tip accelerometer: `;` separators, decimal commas,
# magnitude in g/N and phase in degrees) are imported with what the file does not say, then
# diagnosed: the model is calibrated, the candidate effects are ranked and the missing one is
# named. The same as `frictionrt import-frf ...` and `frictionrt diagnose ...`
# (docs/recipes/diagnose-your-frfs.md). A few minutes on 2 cores; `FRICTIONRT_EXAMPLES_QUICK=1`
# imports one test only (the test suite's version).

# %%
import os
from pathlib import Path

import numpy as np

import frictionrt as fr

SMALL = os.environ.get("FRICTIONRT_EXAMPLES_QUICK") == "1"
OUT = Path(os.environ.get("FRICTIONRT_EXAMPLES_OUT", "logs/examples"))
OUT.mkdir(parents=True, exist_ok=True)

# the "lab": FRF files of the virtual rig with a hidden effect, re-written as an analyser's export
truth = fr.rig(effect="accelerometer_mass", out=OUT / "truth_frf", frf_files=True, seed=3, force=True)
from frictionrt.rt.log.frf_files import read_frf  # noqa: E402  (the rig's own reader, for the stand-in)

exports = []
for f in truth["files"][:1] if SMALL else truth["files"]:
    t = read_frf(f)
    head = ['"Frequency [Hz]"'] + [f'"{s} Magnitude [g/N]";"{s} Phase [deg]"' for s in t.H]
    rows = [";".join(head)]
    for j, fj in enumerate(t.freq_hz):
        cols = [fj] + [x for h in t.H.values() for x in (abs(h[j]) / 9.80665, np.degrees(np.angle(h[j])))]
        rows.append(";".join(f"{x:.9e}".replace(".", ",") for x in cols))
    path = OUT / "lab" / f"{t.name}.txt"
    path.parent.mkdir(exist_ok=True)
    path.write_text("\n".join(rows) + "\n")
    exports.append((path, t))

# %% [markdown]
# The import asks for what the file does not say: the sensors' positions along the beam [m],
# where the force acts [m], the bolt force held in each test [N].

# %%
first = exports[0][1]
imported = fr.import_frf([p for p, _ in exports], OUT / "lab_frf", force=True,
                         sensor_positions=first.meta["sensor_positions_m"],
                         excitation_x=first.meta["excitation_x_m"], fn1=[t.F_N1 for _, t in exports])
print(imported.to_dict()["folder"], [t["file"] for t in imported.to_dict()["tests"]])

# %% [markdown]
# The diagnosis: what calibration explains, which effect is named, what remains.

# %%
diag = fr.diagnose(OUT / "lab_frf", out=OUT / "lab_diagnosis", force=True)
print(diag)
diag.plot().savefig(OUT / "lab_diagnosis.png")

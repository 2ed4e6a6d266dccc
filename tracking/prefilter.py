"""Force setpoint prefilter: F* through a 2nd-order Butterworth before feedforward and PID.

The static feedforward (F* - F0)/c_v passes the law's setpoint changes straight to the piezo
stack, whose resonance (moving mass on k_stack + k_screw, zeta 0.05, ~7 kHz) the force-tracking
loop amplifies: the designed closed loop F/F* peaks at +18 dB (strain gauge) / +20 dB (force
cell) near 7 kHz (docs/tracking.md). The Lyapunov law switches between F_min and F_max within
a vibration cycle; unfiltered, F_N1 then rang between ~80 and ~690 N at 7 kHz and hammered the
structure (v_rel 1.4 m/s RMS against a 1 mm/s first harmonic). The prefilter at
``tracking.setpoint_filter_hz`` removes that content (1 kHz: -34 dB at 7 kHz) and delays a
230 Hz setpoint by ~0.3 ms.

Kernel: ``frictionrt.tracking.lowpass._biquad_step`` with one channel, input F* [N], output the filtered F* [N].
"""
from __future__ import annotations

from frictionrt.tracking.lowpass import BiquadParams, build_butter2
from frictionrt.rt.common.config import Config

PREFILTER_SLOTS = ("s1", "s2")
PREFILTER_OUTPUTS = (("F_set_filtered", "N"),)


def build_prefilter(cfg: Config) -> BiquadParams:
    return build_butter2(cfg.tracking.setpoint_filter_hz, cfg.dt_s, "tracking.setpoint_filter_hz")

"""The oracle estimator: the plant's true u_rel, v_rel at the adaptive screw, band-limited.

The plant's relative motion at the screw carries, besides the structural response, the
near-Nyquist ringing of modes the 21 kHz step does not resolve (the tangential contact mode,
k_t on the damper's mass, ~14 kHz; docs/plant.md section 2.6). At the mode-3 resonance with
F_N1 near F_max it dominates v_rel: RMS 0.2 m/s against a 0.75 mm/s first harmonic, |v_rel|
above eps = 10 mm/s in 96 % of the ticks, so a Lyapunov law on the raw signal clamps at F_max.
Any real measurement or estimator is band-limited; the oracle passes both signals through a
2nd-order Butterworth at ``observer.oracle_bandwidth_hz`` (``frictionrt.tracking.lowpass``). It remains the upper
bound of what an estimator can give in that band.

Kernel: ``frictionrt.tracking.lowpass._biquad_step`` with two channels, inputs u = (u_rel [m], v_rel [m/s]) of
the plant at t_k, outputs y = (u_rel_hat [m], v_rel_hat [m/s]); state slots ``ORACLE_SLOTS``.
"""
from __future__ import annotations

from frictionrt.tracking.lowpass import BiquadParams, build_butter2
from frictionrt.rt.common.config import Config

ORACLE_SLOTS = ("u_s1", "u_s2", "v_s1", "v_s2")
ORACLE_OUTPUTS = (("u_rel_hat", "m"), ("v_rel_hat", "m/s"))


def build_oracle(cfg: Config) -> BiquadParams:
    """The oracle's low-pass at cfg.observer.oracle_bandwidth_hz for the step cfg.dt_s."""
    return build_butter2(cfg.observer.oracle_bandwidth_hz, cfg.dt_s, "observer.oracle_bandwidth_hz")

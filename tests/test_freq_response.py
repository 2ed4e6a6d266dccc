"""The force-tracking design's stacked frequency response (tracking.force_tracking._freq) against
python-control's own evaluation, point by point: the same bits, so the design's gains and figures
do not move with the faster evaluation."""
import numpy as np
import pytest

from frictionrt.rt.common.config import Config
from frictionrt.tracking import force_tracking as ft


@pytest.mark.parametrize("sensor", ft.SENSORS)
def test_stacked_response_is_python_controls_bit_for_bit(sensor):
    cfg = Config()
    dt = cfg.dt_s
    G = ft.discrete_actuator_model(cfg, sensor)
    w = ft._grid(dt, n=400)  # from 0.1 Hz to just below Nyquist, across the stack resonance
    for out in range(G.noutputs):
        ours = ft._freq(G, w, dt, out)
        theirs = G(np.exp(1j * w * dt), squeeze=False)[out, 0]
        assert ours.tobytes() == theirs.tobytes()
    # a single frequency goes through python-control itself
    assert ft._freq(G, w[:1], dt).tobytes() == G(np.exp(1j * w[:1] * dt), squeeze=False)[0, 0].tobytes()

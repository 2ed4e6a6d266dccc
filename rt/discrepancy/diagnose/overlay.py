"""The diagnosis' overlay figure: measured |H| and the models' over frequency, and below each the
models' residuals in dB, so that models lying on top of each other in |H| are told apart."""
from __future__ import annotations

import numpy as np

MODELS = {"before": ("nominal model (before)", "C1--"), "after": ("updated model (after)", "C0-")}
"""The diagnosis' two models, {key: (label, line style)}: nominal (before) and updated (after)."""

def residual_db(H_model: np.ndarray, H_meas: np.ndarray) -> np.ndarray:
    """The log-magnitude residual of a model [dB]: 20 log10(|H_meas| / |H_model|), measured - model
    (as diagnosis.rrd's /frf_gap: positive where the model is below the measurement)."""
    return 20.0 * np.log10(np.abs(H_meas) / np.abs(H_model))


def overlay_figure(title: str, panels: list, models: dict, loglog: bool = False):
    """A matplotlib figure, per panel (ylabel, f [Hz], H_meas, {model key: H}) two axes over f: |H|
    measured and of each model of ``models`` {key: (label, style)}, and below it each model's
    residual_db, measured - model (0 dB: the model is the measurement), so that curves lying
    on top of each other above are told apart below."""
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(2 * len(panels), 1, figsize=(8, 1.2 + 4.2 * len(panels)), sharex=True, squeeze=False,
                             gridspec_kw={"height_ratios": [3, 1.4] * len(panels)})
    for j, (ylabel, f, H, Hm) in enumerate(panels):
        ax, axr = axes[2 * j, 0], axes[2 * j + 1, 0]
        draw = ax.loglog if loglog else ax.semilogy
        draw(f, np.abs(H), "k-", lw=0.8, label="measured")
        for k, (lab, st) in models.items():
            draw(f, np.abs(Hm[k]), st, lw=0.8, label=lab)
            axr.plot(f, residual_db(Hm[k], H), st, lw=0.8, label=lab)
        axr.axhline(0.0, color="k", lw=0.5)
        if loglog:
            axr.set_xscale("log")
        ax.set_ylabel(ylabel)
        axr.set_ylabel("measured - model\n[dB]")
        ax.grid(True, which="both", lw=0.3)
        axr.grid(True, which="both", lw=0.3)
    axes[0, 0].set_title(title)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("frequency [Hz]")
    fig.tight_layout()
    return fig

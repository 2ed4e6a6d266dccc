"""Running the diagnosis' fits where a user sees them (docs/discrepancy.md "Progress and
Ctrl-C"): progress bars, the candidates' fits in parallel, and Ctrl-C that keeps what is done.

Progress: a fit counts its model evaluations on a tqdm bar on stderr with the best cost so far
(``watch``); fits run in parallel are counted as they end (``fit_in_parallel``). These are tqdm bars
on stderr as the sweeps' (rt.experiments.branches.run_branches), shown with ``--json`` too, since
stdout keeps the JSON alone.

Ctrl-C: a fit stopped inside raises FitInterrupted with its best point evaluated so far (``watch``);
the workflow records every fit once done into a dict and, in ``keeping``, turns the KeyboardInterrupt
into Interrupted with what it had (``partial_result``), which the CLI prints and writes to the report
folder (``write_partial_report``: filled beside it and renamed, never half-written), exit status 130.
"""
from __future__ import annotations

import math
from contextlib import contextmanager
from pathlib import Path

import joblib
import numpy as np
from threadpoolctl import threadpool_limits
from tqdm import tqdm


class FitInterrupted(KeyboardInterrupt):
    """A fit stopped by the user (Ctrl-C): ``label`` names it, ``best`` = {"fitted", "cfg", "evaluations"}
    its best point evaluated so far."""

    def __init__(self, label: str, best: dict):
        super().__init__(label)
        self.label, self.best = label, best


class Interrupted(KeyboardInterrupt):
    """The diagnosis stopped by the user (Ctrl-C); ``partial``: what it had (``partial_result``)."""

    def __init__(self, partial: dict):
        super().__init__("interrupted")
        self.partial = partial


def rounded(theta: dict) -> dict:
    """Fitted parameters as the report gives them: 5 significant digits."""
    return {k: float(f"{v:.5g}") for k, v in theta.items()}


PEOPLE_DIGITS = 4
"""Significant digits of a fitted value in the text for people, of its parameter's scale: the
calibration scales' 1 (x nominal), an effect's default strength; the JSON keeps its own."""


def fitted_text(theta: dict) -> str:
    """Fitted parameters for people: ``E 1.002, k_t 1.032, moving_mass 0.05``, each rounded to
    PEOPLE_DIGITS significant digits of its scale (an effect's default strength, else 1 for the
    calibration's scale factors; a value's own magnitude for any other), so that a strength pressed
    to a bound of 0 (e.g. 4.5e-31 of a default 3e-5) reads 0."""
    from frictionrt.rt.discrepancy.effects import EFFECTS
    out = []
    for k, v in theta.items():
        v = float(v)
        scale = abs(EFFECTS[k].parameter.default) if k in EFFECTS else 1.0 if k in ("E", "k_t", "modal_damping", "mu") \
            else abs(v)
        if not math.isfinite(v) or scale == 0.0:
            out.append(f"{k} {v:g}")
            continue
        r = round(v, PEOPLE_DIGITS - 1 - math.floor(math.log10(scale)))
        out.append(f"{k} {0.0 if r == 0 else r:.{PEOPLE_DIGITS}g}")
    return ", ".join(out)


def done_fit(theta: dict, cfg, **more) -> dict:
    """A fit as the workflow keeps it once done: {"fitted": ``rounded(theta)``, "cfg": its configuration,
    ``more``} (what an interruption writes)."""
    return {"fitted": rounded(theta), "cfg": cfg} | more


class Evaluations:
    """A fit's model evaluations so far: their number ``n``, the best cost (sum of squared weighted
    residuals, dimensionless) and its point ``x``, on the tqdm ``bar``."""

    def __init__(self, bar):
        self.bar, self.n, self.cost, self.x = bar, 0, math.inf, None

    def seen(self, x, r: np.ndarray) -> None:
        """One evaluation at the optimiser's point ``x`` with the weighted residuals ``r``."""
        cost = float(r @ r)
        if cost < self.cost:
            self.cost, self.x = cost, np.array(x, float)
        self.n += 1
        self.bar.set_postfix(cost=f"{self.cost:.6g}", refresh=False)
        self.bar.update()


@contextmanager
def watch(label: str, bars: bool, point):
    """Yields the Evaluations of the fit ``label`` (the fit calls its ``seen`` after each model), counted on
    a tqdm bar on stderr when ``bars``. Ctrl-C inside raises FitInterrupted with its best point,
    ``point(x) -> (theta, cfg)`` (a plain KeyboardInterrupt before the first evaluation ended)."""
    with tqdm(desc=label, unit="model", disable=not bars) as bar:
        ev = Evaluations(bar)
        try:
            yield ev
        except FitInterrupted:      # a fit inside this one (a start of it) was stopped: it names the point
            raise
        except KeyboardInterrupt:
            if ev.x is None:
                raise
            raise FitInterrupted(label, done_fit(*point(ev.x), evaluations=ev.n)) from None


def partial_result(done: dict, stopped: KeyboardInterrupt, **keys) -> dict:
    """What an interrupted diagnosis had: ``keys`` (its "input", ...), "interrupted": True and "fits"
    {name: {"fitted", ...}} of the fits ``done`` (``done_fit``) and, if ``stopped`` is a FitInterrupted,
    the interrupted one's best point; the configuration of the last under "_config"."""
    fits = dict(done)
    if isinstance(stopped, FitInterrupted):
        fits[f"{stopped.label} (interrupted: its best point so far)"] = stopped.best
    out = keys | {"interrupted": True, "fits": {k: {n: v for n, v in f.items() if n != "cfg"} for k, f in fits.items()}}
    return out | ({"_config": list(fits.values())[-1]["cfg"]} if fits else {})


@contextmanager
def keeping(done: dict, **keys):
    """Runs the block that fills ``done`` with the fits as they end; Ctrl-C raises Interrupted with
    ``partial_result(done, ..., **keys)``."""
    try:
        yield done
    except KeyboardInterrupt as exc:
        raise Interrupted(partial_result(done, exc, **keys)) from None


def partial_summary(partial: dict) -> str:
    """The text the CLI prints for an interrupted diagnosis (``partial_result``)."""
    return "\n".join(["interrupted; the fits done so far:"]
                     + [f"  {name}: {fitted_text(f['fitted'])}" for name, f in partial["fits"].items()])


def write_result(folder: Path, res: dict) -> None:
    """diagnose.json (``res`` without its "_" keys) and, if ``res`` has one, model.toml ("_config") in ``folder``."""
    import json

    from frictionrt.rt.common.config import dumps
    (folder / "diagnose.json").write_text(json.dumps({k: v for k, v in res.items() if not k.startswith("_")},
                                                     indent=1) + "\n")
    if "_config" in res:
        (folder / "model.toml").write_text(dumps(res["_config"]))


def write_partial_report(partial: dict, out: str | Path) -> Path:
    """The report folder of an interrupted diagnosis, filled beside ``out`` and renamed to it (rt.discrepancy.
    rig.campaign.new_folder: never half-written): ``write_result`` of ``partial`` (model.toml: the last fit's
    configuration) and report.md."""
    from frictionrt.rt.discrepancy.rig.campaign import new_folder
    with new_folder(out) as tmp:
        write_result(tmp, partial)
        (tmp / "report.md").write_text("\n".join(
            [f"# Diagnosis ({partial['input']}): interrupted", "",
             "The diagnosis was stopped before its end; the fits done so far (model.toml: the last of them):", "",
             "| fit | fitted |", "| --- | --- |",
             *[f"| {name} | `{f['fitted']}` |" for name, f in partial["fits"].items()], ""]))
    return Path(out)


def fit_in_parallel(calls: list, jobs: int | None, dask_address: str | None = None, bars: bool = False,
                    each=None) -> list:
    """[f(*args, **kwargs) for (f, args, kwargs) in calls], in joblib (loky) worker processes when
    jobs (default joblib.cpu_count()) > 1, or on the dask cluster at dask_address (jobs ignored;
    ``frictionrt.rt.experiments.connect``): the candidates' fits are independent given the calibration, and
    each is a pure function of its inputs, so the results are the same as in sequence (tested);
    the workers keep their compiled kernels between calls. The results arrive in the calls' order, counted
    on a tqdm bar on stderr when ``bars``; ``each(i, result)`` is told of each as it arrives (what Ctrl-C keeps)."""
    out = []
    with tqdm(total=len(calls), desc="candidates' fits", unit="fit", disable=not bars) as bar:
        for i, result in enumerate(_results(calls, jobs, dask_address)):
            out.append(result)
            bar.update()
            if each is not None:
                each(i, result)
    return out


def _results(calls: list, jobs: int | None, dask_address: str | None):
    """The results of ``calls`` (``fit_in_parallel``) one by one, in order, as they end."""
    if dask_address is not None:
        from frictionrt.rt.experiments import connect
        with connect(dask_address) as client:
            for future in [client.submit(_one_blas_thread, f, a, k, pure=False) for f, a, k in calls]:
                yield future.result()
        return
    jobs = min(jobs or joblib.cpu_count(), len(calls))
    if jobs <= 1:
        for f, a, k in calls:
            yield f(*a, **k)
        return
    yield from joblib.Parallel(n_jobs=jobs, backend="loky", return_as="generator")(
        joblib.delayed(f)(*a, **k) for f, a, k in calls)


def _one_blas_thread(f, args: tuple, kwargs: dict):
    """f(*args, **kwargs) with BLAS single-threaded, as in this process and in a loky worker (a
    dask worker's own setting may differ)."""
    with threadpool_limits(1):
        return f(*args, **kwargs)

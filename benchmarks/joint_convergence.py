"""Convergence of the joint's figures in its discretisation: contact pitch, element length and
plant step (docs/plant.md 6, "Convergence"; SPEC 2).

    python -m benchmarks.joint_convergence [--grid P:E:S[:R] ...] [--fn1 40 100] [--set KEY=VALUE ...]

Each grid entry P:E:S[:R] is a contact pitch P [mm], a largest element E [mm], S plant substeps per
controller step and the pitch's refinement R near the interface's ends (plant.interface.end_refinement;
1, the default of an entry, is P everywhere: the default plant is 10:5:1:2); the contact is per unit
area, so every entry is the same physical model. Per entry
and hammer level F_N1 the script runs the simulated hammer test (plant.impulse.impulse_test, the
configured hammer, 1 s) and prints modes 2-5's identified f [Hz] and zeta [%], their offsets from
the last (finest) entry, the hammer FRF's distance from the last entry (RMS of 20 log10 |H / H_ref|
over 50-1200 Hz [dB]) and the plant step's median wall time [us] in that run. Where the grid holds
three entries of one pitch and element with substeps S, 2S, 4S, it also gives the observed order
of the step p = log2(|H_S - H_2S| / |H_2S - H_4S|) and each entry's distance from the Richardson
limit H_4S + (H_4S - H_2S) / (2^p - 1).

Tolerances (issue 31, item 5): f within 0.3 %, zeta within 10 %, hammer FRF within 0.3 dB rms of
the limit.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from benchmarks.entry import run_main
from frictionrt.plant import measures
from frictionrt.plant.impulse import impulse_test
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import Config, load, with_sets

BAND_HZ = (50.0, 1200.0)
DEFAULT_GRID = ("20:10:1", "10:5:1", "5:2.5:1", "2.5:2.5:1")


def setting(text: str) -> tuple[float, float, int, int]:
    """(pitch [mm], element [mm], substeps, end refinement) of a grid entry 'P:E:S[:R]'."""
    try:
        fields = text.split(":")
        if len(fields) not in (3, 4):
            raise ValueError
        out = (float(fields[0]), float(fields[1]), int(fields[2]), int(fields[3]) if len(fields) == 4 else 1)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected PITCH_MM:ELEMENT_MM:SUBSTEPS[:END_REFINEMENT], "
                                         "e.g. 10:5:4 or 10:5:1:2") from None
    if min(out) <= 0:
        raise argparse.ArgumentTypeError(f"{text!r}: pitch, element, substeps and refinement must be positive")
    return out


def label(entry: tuple[float, float, int, int]) -> str:
    """'P:E:S', or 'P:E:S:R' where the entry refines the ends."""
    p, e, s, r = entry
    return f"{p:g}:{e:g}:{s}" + (f":{r}" if r > 1 else "")


def configured(base: Config, entry: tuple[float, float, int, int]) -> Config:
    """``base`` at the entry's pitch, element length, substeps and end refinement."""
    p, e, s, r = entry
    return with_sets(base, [f"plant.interface.pitch_m={p * 1e-3!r}", f"plant.element_length_m={e * 1e-3!r}",
                            f"plant.substeps={s}", f"plant.interface.end_refinement={r}"])


def hammer(cfg: Config, F_N1: float) -> dict:
    """The hammer test at F_N1 [N]: modal f [Hz], zeta [-] of modes 2-5, the FRF in ``BAND_HZ``
    (lines ``freq`` [Hz]), the exponential window's tau_w [s], wall [s]."""
    t0 = time.perf_counter()
    r = impulse_test(build_plant(cfg), F_N1)
    band = (r.freq > BAND_HZ[0]) & (r.freq < BAND_HZ[1])
    return {"f": r.freq_hz, "zeta": r.damping_ratio, "H": r.frf[band], "freq": r.freq[band],
            "tau_w": cfg.impulse.record_s / 4.0, "wall_s": time.perf_counter() - t0}


rms_db = measures.rms_db


def lab_measures(rows: list[dict]) -> list[dict]:
    """Per entry, against the last (finest) one, in the bands of the last entry's modes 2-5
    (plant.measures): per mode the peak's frequency offset [%] and height offset [dB], the
    half-power zeta offset [%] and the magnitude-weighted FRF error [dB]; over 50-1200 Hz the
    weighted error and the rms of dB."""
    ref = rows[-1]
    bands = measures.mode_bands(ref["f"])
    m_ref = measures.mode_measures(ref["freq"], ref["H"], bands, ref["tau_w"])
    out = []
    for r in rows:
        m = measures.mode_measures(r["freq"], r["H"], bands, r["tau_w"])
        out.append({"df_pct": [100 * (a.f_peak_hz / b.f_peak_hz - 1) for a, b in zip(m, m_ref)],
                    "dpeak_db": [20 * np.log10(a.peak_abs / b.peak_abs) for a, b in zip(m, m_ref)],
                    "dzeta_pct": [100 * (a.zeta_half_power / b.zeta_half_power - 1) for a, b in zip(m, m_ref)],
                    "zeta_hp_pct": [100 * a.zeta_half_power for a in m],
                    "band_db": measures.band_errors_db(r["freq"], r["H"], ref["H"], bands),
                    "weighted_db": measures.weighted_error_db(r["H"], ref["H"]), "rms_db": rms_db(r["H"], ref["H"])})
    return out


def print_lab_measures(entries: list[str], rows: list[dict]) -> None:
    """The table of ``lab_measures`` and, for entries of one pitch at substeps S, 2S, 4S..., the
    observed order of each error e_S (weighted, dB) against the finest: p = (e_S - e_2S) / 6.02."""
    lab = lab_measures(rows)
    print("\nLab measures against the last entry (plant.measures; modes 2-5): peak f [%], peak height [dB], "
          "half-power zeta [%, offset], weighted FRF error per mode band [dB]; whole band: weighted [dB] / "
          "rms of dB\n")
    print("| entry | peak f | peak height | zeta (half power) | band error | weighted / rms |")
    print("| --- | --- | --- | --- | --- | --- |")
    for e, m in zip(entries, lab):
        fmt = lambda xs, f: ", ".join(f.format(x) for x in xs)  # noqa: E731
        print(f"| {e} | {fmt(m['df_pct'], '{:+.3f}')} | {fmt(m['dpeak_db'], '{:+.2f}')} | "
              + ", ".join(f"{z:.3f} ({d:+.0f} %)" for z, d in zip(m["zeta_hp_pct"], m["dzeta_pct"]))
              + f" | {fmt(m['band_db'], '{:.1f}')} | {m['weighted_db']:.1f} / {m['rms_db']:.2f} |")
    for k in range(len(lab) - 2):
        p = (lab[k]["weighted_db"] - lab[k + 1]["weighted_db"]) / (20 * np.log10(2))
        pb = [(a - b) / (20 * np.log10(2)) for a, b in zip(lab[k]["band_db"], lab[k + 1]["band_db"])]
        print(f"observed order {entries[k]} -> {entries[k + 1]} (halving assumed): weighted {p:.2f}; per mode band "
              + ", ".join(f"{x:.2f}" for x in pb))


def richardson(H1: np.ndarray, H2: np.ndarray, H4: np.ndarray) -> tuple[float, np.ndarray]:
    """(observed order p, limit) of three results at steps h, h/2, h/4 (module docstring)."""
    p = float(np.log2(np.linalg.norm(H1 - H2) / np.linalg.norm(H2 - H4)))
    return p, H4 + (H4 - H2) / (2.0 ** max(p, 0.1) - 1.0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--grid", type=setting, nargs="+", default=[setting(g) for g in DEFAULT_GRID],
                    metavar="P:E:S[:R]", help="pitch [mm]:element [mm]:substeps[:end refinement, 1 = uniform] "
                                              "per entry, the finest last "
                                          f"(default {' '.join(DEFAULT_GRID)})")
    ap.add_argument("--fn1", type=float, nargs="+", default=[100.0], help="F_N1 levels [N] (default 100)")
    ap.add_argument("--save", metavar="FILE.npz", help="also write every entry's f, zeta and FRF (numpy .npz)")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    base = load(None, args.sets)
    saved = {}
    for F_N1 in args.fn1:
        rows = []
        for entry in args.grid:
            rows.append(hammer(configured(base, entry), F_N1))
            print(f"F_N1 {F_N1:g} N, {label(entry)} done ({rows[-1]['wall_s']:.0f} s)", flush=True)
        for entry, r in zip(args.grid, rows):
            key = f"{F_N1:g}N_" + label(entry).replace(":", "_")
            saved |= {f"{key}_f": r["f"], f"{key}_zeta": r["zeta"], f"{key}_H": r["H"], f"{key}_wall": r["wall_s"]}
        ref = rows[-1]
        print(f"\nHammer test at F_N1 = {F_N1:g} N: modes 2-5, f [Hz] and zeta [%] (offsets from the last entry), "
              f"FRF distance [dB rms, {BAND_HZ[0]:g}-{BAND_HZ[1]:g} Hz]\n")
        print("| P:E:S[:R] | " + " | ".join(f"mode {m} f" for m in (2, 3, 4, 5)) + " | "
              + " | ".join(f"mode {m} zeta" for m in (2, 3, 4, 5)) + " | FRF [dB] | wall [s] |")
        print("| --- " * 11 + "|")
        for entry, r in zip(args.grid, rows):
            fs = " | ".join(f"{f:.2f} ({100 * (f / f0 - 1):+.2f} %)" for f, f0 in zip(r["f"], ref["f"]))
            zs = " | ".join(f"{100 * z:.3f} ({100 * (z / z0 - 1):+.0f} %)" for z, z0 in zip(r["zeta"], ref["zeta"]))
            print(f"| {label(entry)} | {fs} | {zs} | {rms_db(r['H'], ref['H']):.2f} | "
                  f"{r['wall_s']:.0f} |")
        by_space: dict[tuple[float, float, int], dict[int, np.ndarray]] = {}
        for entry, r in zip(args.grid, rows):
            by_space.setdefault((entry[0], entry[1], entry[3]), {})[entry[2]] = r["H"]
        for (p, e, r), Hs in by_space.items():
            for s in sorted(Hs):
                if 2 * s in Hs and 4 * s in Hs:
                    order, limit = richardson(Hs[s], Hs[2 * s], Hs[4 * s])
                    ends = f" (ends {p / r:g} mm)" if r > 1 else ""
                    print(f"\n{p:g} mm{ends} / {e:g} mm, substeps {s}, {2 * s}, {4 * s}: observed order {order:.2f}; distance "
                          "from the Richardson limit [dB rms]: "
                          + ", ".join(f"{k} substeps {rms_db(Hs[k], limit):.2f}" for k in (s, 2 * s, 4 * s)))
        print_lab_measures([label(e) for e in args.grid], rows)
    if args.save:
        np.savez(args.save, **saved)
    return 0


if __name__ == "__main__":
    run_main(main)

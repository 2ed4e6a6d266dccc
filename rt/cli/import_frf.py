"""``frictionrt import-frf``: FRFs as analysers export them (CSV/TXT, UFF 58, MATLAB .mat) into a
folder of FRF files with sidecars that ``diagnose`` and ``validate`` read (rt.log.frf_import)."""
from __future__ import annotations

import argparse
import json

import shtab

from frictionrt.rt.cli.common import add_force, add_out, fail, parse_list

DESCRIPTION = """Reads exported FRFs, one test per file, and writes them as a folder of FRF files with
JSON sidecars (docs/data-format.md, "FRF files") that diagnose and validate read. Text files with ; tab ,
or blank separators, decimal points or commas, quoted headers, real and imaginary or magnitude and
phase columns; universal files (data sets 58); MATLAB .mat (v7.3 needs h5py). What a file does not say
is given by the options below; a missing one is named with its option. Details: docs/discrepancy.md,
"Your own measured FRFs"."""

EXAMPLES = """examples:
  frictionrt import-frf lab/fn100.csv --unit "g/N" --sensor-positions acc1=0.45,acc2=0.765 \\
      --excitation-x 0.325 --fn1 100 -o logs/lab_frf
  frictionrt import-frf lab/run1.uff lab/run2.uff --fn1 40,300 --sensor-positions a1=0.45 \\
      --excitation-x 0.325 -o logs/lab_uff
  frictionrt validate logs/lab_frf && frictionrt diagnose logs/lab_frf"""


def _positions(text: str) -> dict:
    out = {}
    for item in (t for t in text.split(",") if t.strip()):
        name, eq, x = item.partition("=")
        try:
            out[name.strip()] = float(x)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{item.strip()!r}: give NAME=X [m], e.g. a1=0.45,a2=0.765") from None
        if not eq:
            raise argparse.ArgumentTypeError(f"{item.strip()!r}: give NAME=X [m], e.g. a1=0.45,a2=0.765")
    return out


def add_parser(subparsers, parents=None) -> argparse.ArgumentParser:
    """Register ``import-frf`` on an argparse subparsers object."""
    from frictionrt.rt.log.frf_import import FREQUENCY_UNITS, PHASE_UNITS
    from frictionrt.rt.log.frf_files import QUANTITIES
    p = subparsers.add_parser("import-frf", parents=parents or [], help="import exported FRFs (CSV/TXT, UFF, .mat) "
                              "as a folder of FRF files", description=DESCRIPTION, epilog=EXAMPLES)
    p.add_argument("sources", nargs="+", metavar="FILE", help="exported FRF files, one test each").complete = shtab.FILE
    add_out(p, "DIR", "a folder it creates with one FRF file and sidecar per source", required=True)
    add_force(p, "an existing folder as a whole")
    g = p.add_argument_group("what a file does not say")
    g.add_argument("--unit", help="the FRFs' unit, e.g. '(m/s^2)/N', 'g/N', '(mm/s)/N', 'm/V' (default: the file's)")
    g.add_argument("--quantity", choices=list(QUANTITIES), help="the quantity in SI units per newton, instead of "
                   "--unit (default: the file's)")
    g.add_argument("--frequency-unit", choices=list(FREQUENCY_UNITS), help="(default: the file's)")
    g.add_argument("--phase-unit", choices=list(PHASE_UNITS), help="(default: the file's)")
    g.add_argument("--sensor-names", metavar="A,B", type=lambda t: [s.strip() for s in t.split(",") if s.strip()],
                   help="rename the sensors in the file's order (default: the file's names in snake_case)")
    g.add_argument("--sensor-positions", metavar="NAME=X,...", type=_positions,
                   help="each sensor's position along the beam [m]")
    g.add_argument("--excitation-x", type=float, metavar="X", help="where the force acts [m]")
    g.add_argument("--fn1", metavar="F[,F...]", help="bolt force held during each test [N], one or one per "
                   "source (0 without an adaptive screw)")
    g.add_argument("--force-scale", type=float, metavar="N_PER_V", help="an FRF per volt: the shaker's force per "
                   "drive volt; the FRF is stored per newton")
    g.add_argument("--drive-voltage", type=float, metavar="V", help="an FRF per volt: the drive's amplitude; "
                   "the FRF stays per volt")
    g.add_argument("--amplitude", type=float, metavar="N", help="the force's amplitude [N] (default: not recorded)")
    p.add_argument("--description", help="the sidecars' description (default: imported from FILE)")
    p.add_argument("--json", action="store_true", help='one JSON object: {"folder", "tests": [{"source", "file", '
                   '"sensors", "lines", "f_min_hz", "f_max_hz", "quantity", "excitation", "unit", "dropped_dc_line"}]}')
    return p


def cmd_import_frf(cfg, args) -> int:
    from frictionrt.rt.log.frf_import import import_frf
    fn1 = None
    if args.fn1 is not None:
        try:
            fn1 = parse_list(args.fn1, float, "import-frf --fn1", "100 or 40,100,300")
        except ValueError as exc:
            return fail(str(exc))
    try:
        res = import_frf(args.sources, args.out, unit=args.unit, quantity=args.quantity,
                         frequency_unit=args.frequency_unit, phase_unit=args.phase_unit,
                         sensor_names=args.sensor_names, sensor_positions=args.sensor_positions,
                         excitation_x=args.excitation_x, fn1=fn1, force_scale=args.force_scale,
                         drive_voltage=args.drive_voltage, amplitude=args.amplitude,
                         description=args.description, force=args.force)
    except ValueError as exc:
        return fail(f"import-frf: {exc}")
    print(json.dumps(res.to_dict()) if args.json else str(res))
    return 0

"""``frictionrt config``: the resolved configuration (defaults <- --config <- --set) as TOML or JSON."""
from __future__ import annotations

import argparse
import json

from frictionrt.rt.common.config import dumps, to_dict


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``config`` (parents: frictionrt's --config/--set parser)."""
    c = sub.add_parser("config", parents=parents, help="print the resolved configuration",
                       description="Print the resolved configuration (defaults <- --config <- --set) as TOML "
                                   "with units, or as JSON. The TOML output is a valid --config file.")
    c.add_argument("--show", action="store_true", help="print it (the default action)")
    c.add_argument("--json", action="store_true", help="JSON instead of TOML")
    return c


def cmd_config(cfg, args) -> int:
    print(json.dumps(to_dict(cfg), indent=2) if args.json else dumps(cfg), end="" if not args.json else "\n")
    return 0


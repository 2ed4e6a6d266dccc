"""How a benchmark script ends: its exit code, or one line naming a bad ``--set`` / configuration (exit 2);
and how it writes its --json record (whole or not at all).

    write_json(a.json, out)
    if __name__ == "__main__":
        run_main(main)
"""
from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn

from frictionrt.rt.common.config import ConfigError


def run_main(main: Callable[[], int]) -> NoReturn:
    """SystemExit with main()'s code; a ConfigError (a bad --set or configuration file) is printed
    as one stderr line naming the value and exits with 2, without a traceback."""
    try:
        code = main()
    except ConfigError as exc:
        print(f"benchmarks.{Path(sys.argv[0]).stem}: error: {exc}", file=sys.stderr)
        code = 2
    raise SystemExit(code)


def write_json(path, doc) -> None:
    """Write doc as indented JSON to path (nothing when path is None or empty), through a temporary
    file beside it and a rename: a reader or a crash never sees half a file."""
    if not path:
        return
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    try:
        with open(tmp, "w") as fh:
            json.dump(doc, fh, indent=1)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)

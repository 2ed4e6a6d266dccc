"""How a benchmark script ends: its exit code, or one line naming a bad ``--set`` / configuration (exit 2).

    if __name__ == "__main__":
        run_main(main)
"""
from __future__ import annotations

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

"""``python -m frictionrt.rt.cli ARGS``: the same as ``frictionrt ARGS``."""
import sys

from frictionrt.rt.cli import main

sys.exit(main())

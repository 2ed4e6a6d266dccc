"""``python -m rt.cli ARGS``: the same as ``frictionrt ARGS``."""
import sys

from rt.cli import main

sys.exit(main())

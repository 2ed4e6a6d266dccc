"""``python -m frictionrt ARGS``: the same as ``frictionrt ARGS``."""
from frictionrt.rt.cli import main

raise SystemExit(main())

"""The ``frictionrt`` command: ``main`` (the console script) and ``build_parser``.

One module per verb (``frictionrt.rt.cli.simulate``, ``frictionrt.rt.cli.rig``, ...), each owning its parser and its
command; ``frictionrt.rt.cli.common`` below them holds what they share; ``frictionrt.rt.cli.app`` only assembles them.
"""
from frictionrt.rt.cli.app import build_parser, main

__all__ = ["build_parser", "main"]

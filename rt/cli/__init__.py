"""The ``frictionrt`` command: ``main`` (the console script) and ``build_parser``.

One module per verb (``rt.cli.simulate``, ``rt.cli.rig``, ...), each owning its parser and its
command; ``rt.cli.common`` below them holds what they share; ``rt.cli.app`` only assembles them.
"""
from rt.cli.app import build_parser, main

__all__ = ["build_parser", "main"]

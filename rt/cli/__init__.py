"""The ``frictionrt`` command: ``main`` (the console script) and ``build_parser``."""
from rt.cli.app import build_parser, main

__all__ = ["build_parser", "main"]

"""A package's face: the names it offers other packages, imported on first use (PEP 562).

A face that imported its modules eagerly would make ``import rt.loop`` compile or load every
kernel of the loop (about 2 s) even for a command that only reads a log; a lazy face costs
nothing until a name is used. ``lazy_face`` returns the package's ``__getattr__`` and
``__dir__``; the package lists the same names in ``__all__``.
"""
from __future__ import annotations

import importlib
import sys
from collections.abc import Callable


def lazy_face(package: str, exports: dict[str, str]) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """(``__getattr__``, ``__dir__``) for the package named ``package`` whose public names are
    ``exports``: name -> the module that defines it. A name is imported at its first use and
    then kept in the package's namespace."""
    def __getattr__(name: str) -> object:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return __getattr__, __dir__

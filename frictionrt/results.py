"""What the jobs of ``frictionrt`` return: a ``Result`` with ``.to_dict()`` (what the command
line's ``--json`` prints), item access to the same fields, and ``.plot()`` (a matplotlib Figure)
where people would rather look than read.

A Figure is built without pyplot (``matplotlib.figure.Figure``): it shows in a notebook as the
value of a cell, and ``fig.savefig("x.png")`` writes it anywhere, with no display.
"""
from __future__ import annotations

import copy
import json
from collections.abc import Callable, Mapping
from typing import Any


class Result(Mapping):
    """A job's result: ``to_dict()`` is the JSON object the command line's ``--json`` prints (full
    precision), ``result["key"]`` reads a field of it, ``plot()`` draws it (where the job has a
    picture; ``TypeError`` otherwise), ``str(result)`` is the text the command line prints.

    ``kind``: the job ("simulate", "reproduce", ...); ``data``: the JSON object; ``plotter``:
    a function of no argument that returns a matplotlib Figure; ``text``: the people's summary;
    ``extra``: Python objects a script may want beyond the JSON (e.g. the run's signals), by name.
    """

    def __init__(self, kind: str, data: dict, plotter: Callable[[], Any] | None = None, text: str | None = None,
                 **extra: Any):
        self.kind = kind
        self._data = data
        self._plotter = plotter
        self._text = text
        self.extra = extra

    def to_dict(self) -> dict:
        """The JSON object (a deep copy: editing it leaves the result as it is)."""
        return copy.deepcopy(self._data)

    def to_json(self) -> str:
        """``to_dict()`` as one line of JSON, as ``--json`` prints it."""
        return json.dumps(self._data)

    def plot(self):
        """A matplotlib Figure of the result (``fig.savefig(path)`` writes it)."""
        if self._plotter is None:
            raise TypeError(f"the {self.kind} result has no plot; read .to_dict()")
        return self._plotter()

    def __getitem__(self, key: str) -> Any:
        return self._data[key]

    def __iter__(self):
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __getattr__(self, name: str) -> Any:
        extra = self.__dict__.get("extra", {})
        if name in extra:
            return extra[name]
        raise AttributeError(f"{type(self).__name__} of {self.__dict__.get('kind', '?')!r} has no attribute {name!r}; "
                             f"its fields: {', '.join(self.__dict__.get('_data', {}))}")

    def __str__(self) -> str:
        return self._text if self._text is not None else json.dumps(self._data, indent=1)

    def __repr__(self) -> str:
        keys = ", ".join(list(self._data)[:8]) + (", ..." if len(self._data) > 8 else "")
        return f"<frictionrt {self.kind} result: {keys}>"

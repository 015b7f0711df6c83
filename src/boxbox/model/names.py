"""A mistyped field name on a model object fails with the nearest real names.

Used as `__getattr__`, which Python calls only when normal lookup fails: correct names cost
nothing extra. The suggestions are worked out only when the message is read, so code that probes
for an attribute (`getattr(obj, name, default)`, `hasattr`) stays cheap.
"""

from __future__ import annotations

import difflib
from typing import NoReturn


class NoSuchField(AttributeError):
    """AttributeError whose message names the closest fields and properties of the object's class."""

    def __init__(self, cls: type, name: str) -> None:
        super().__init__(name)
        self.cls, self.field = cls, name

    def __str__(self) -> str:
        known = sorted({n for n in dir(self.cls) if not n.startswith("_")}
                       | set(getattr(self.cls, "_fields", ())) | set(getattr(self.cls, "__dataclass_fields__", {})))
        near = difflib.get_close_matches(self.field, known, n=3, cutoff=0.5)
        words = [w for w in self.field.split("_") if w]
        near += [n for n in known if n not in near and any(w in n.split("_") for w in words)][:3]
        hint = f"; did you mean {', '.join(near[:4])}?" if near else ""
        return f"{self.cls.__name__} has no field {self.field!r}{hint} (docs/robots.md lists every field)"


def no_such_field(obj: object, name: str) -> NoReturn:
    """Raise the AttributeError for `name` (plain for dunder probes such as copy's and pickle's)."""
    if name.startswith("__"):
        raise AttributeError(name)
    raise NoSuchField(type(obj), name)

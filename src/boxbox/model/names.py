"""A mistyped field name on a model object fails with the nearest real names.

Used as `__getattr__`, which Python calls only when normal lookup fails: correct names cost
nothing extra.
"""

from __future__ import annotations

import difflib
from typing import NoReturn


def no_such_field(obj: object, name: str) -> NoReturn:
    """Raise AttributeError for `name`, suggesting the closest fields and properties of `obj`."""
    if name.startswith("__"):  # copy, pickle and friends probe for these: the plain error
        raise AttributeError(name)
    cls = type(obj)
    known = [n for n in dir(cls) if not n.startswith("_")]
    known += list(getattr(cls, "_fields", ())) + list(getattr(cls, "__dataclass_fields__", {}))
    near = difflib.get_close_matches(name, sorted(set(known)), n=3, cutoff=0.5)
    words = name.split("_")
    near += [n for n in sorted(set(known)) if n not in near and any(w and w in n.split("_") for w in words)][:3]
    hint = f"; did you mean {', '.join(near[:4])}?" if near else ""
    raise AttributeError(f"{cls.__name__} has no field {name!r}{hint} (docs/robots.md lists every field)")

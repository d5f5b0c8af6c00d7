"""Results kept by what they were made from: a bounded store, least recently used first out.

A result that is a pure function of its inputs (a clip generated for a rig, a clip read
and analysed from its keys) is made once while those inputs are unchanged and given again
after: a re-plan, a re-bake, each job of a batch. What is kept is made read only
(``freeze``), so a caller that writes into a kept array fails at once instead of changing
what the next caller is given. Nothing here knows what it keeps.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections import OrderedDict

import numpy as np


class Memo:
    """At most ``kept`` results, and at most ``max_bytes`` of their arrays (``freeze``'s
    count), the latest kept."""

    def __init__(self, kept: int, max_bytes: int | None = None):
        self.kept, self.max_bytes = int(kept), max_bytes
        self._items: OrderedDict = OrderedDict()  # key -> (value, bytes)
        self.bytes = 0

    def __len__(self) -> int:
        return len(self._items)

    def __contains__(self, key) -> bool:
        return key in self._items

    def get(self, key, default=None):
        """The result kept for ``key`` (now the most recent), else ``default``."""
        hit = self._items.get(key)
        if hit is None:
            return default
        self._items.move_to_end(key)
        return hit[0]

    def put(self, key, value):
        """Keep ``value`` (made read only) for ``key``; the oldest go past the bounds.
        Returns ``value``."""
        size = freeze(value)
        old = self._items.pop(key, None)
        if old is not None:
            self.bytes -= old[1]
        self._items[key] = (value, size)
        self.bytes += size
        while len(self._items) > self.kept or (self.max_bytes is not None and self.bytes > self.max_bytes
                                               and len(self._items) > 1):
            _, (_, gone) = self._items.popitem(last=False)
            self.bytes -= gone
        return value

    def clear(self) -> None:
        self._items.clear()
        self.bytes = 0


def freeze(value, _seen=None) -> int:
    """Make every numpy array in ``value`` read only (in dataclasses, lists, tuples and
    dicts, nested) and return their bytes, each array counted once."""
    seen = set() if _seen is None else _seen
    if id(value) in seen:
        return 0
    if isinstance(value, np.ndarray):
        seen.add(id(value))
        value.setflags(write=False)
        return int(value.nbytes)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        seen.add(id(value))
        return sum(freeze(getattr(value, f.name), seen) for f in dataclasses.fields(value))
    if isinstance(value, (list, tuple)):
        seen.add(id(value))
        return sum(freeze(v, seen) for v in value)
    if isinstance(value, dict):
        seen.add(id(value))
        return sum(freeze(v, seen) for v in value.values())
    return 0


def digest(*values) -> str:
    """A digest of ``values`` by what they hold: numpy arrays by their shape, type and
    bytes, dataclasses by their fields, lists, tuples and dicts by their items, anything
    else by its ``repr``; two values with one digest are made of the same numbers."""
    h = hashlib.sha1()
    _feed(h, values)
    return h.hexdigest()


def _feed(h, value) -> None:
    if isinstance(value, np.ndarray):
        h.update(repr(("array", value.shape, value.dtype.str)).encode())
        h.update(np.ascontiguousarray(value).tobytes())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(repr(("dataclass", type(value).__qualname__)).encode())
        for f in dataclasses.fields(value):
            h.update(f.name.encode())
            _feed(h, getattr(value, f.name))
    elif isinstance(value, (list, tuple)):
        h.update(repr(("seq", len(value))).encode())
        for v in value:
            _feed(h, v)
    elif isinstance(value, dict):
        h.update(repr(("dict", len(value))).encode())
        for k, v in value.items():
            _feed(h, k)
            _feed(h, v)
    else:
        h.update(repr((type(value).__qualname__, value)).encode())


__all__ = ["Memo", "digest", "freeze"]

"""A named registry: what the package lets a user add by name without editing a list.

Planners (`planners.registry`), observation kinds (`navigation.observations`) and plants
(`diagrams.plants`) are each a `Registry`: a read-only mapping name → entry, in
registration order, that only `add` and `remove` change.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Generic, TypeVar

T = TypeVar("T")


class Registry(Mapping[str, T], Generic[T]):
    """Entries by name, in registration order.

    Args:
        what: what an entry is, for messages ("planner", "plant", …).
    """

    def __init__(self, what: str) -> None:
        self.what = what
        self._entries: dict[str, T] = {}

    def add(self, name: str, entry: T, replace: bool = False) -> T:
        """Register `entry` as `name` (`ValueError` if taken and not `replace`)."""
        if name in self._entries and not replace:
            raise ValueError(f"a {self.what} called {name!r} is registered already")
        self._entries[name] = entry
        return entry

    def remove(self, name: str) -> None:
        """Forget `name` (nothing if it is not registered)."""
        self._entries.pop(name, None)

    def names(self) -> tuple[str, ...]:
        """Every name, in registration order."""
        return tuple(self._entries)

    def __getitem__(self, name: str) -> T:
        return self._entries[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

"""Named presets, one registry per kind (lighting, viewing, scenario).

Error messages, ``--help`` texts and the docs list the same names because they
all read them from here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ..errors import ParameterError


@dataclass(frozen=True)
class Entry:
    name: str
    summary: str
    factory: Callable[..., Any]


class Registry:
    """Presets of one kind, by name, in the order they were registered."""

    def __init__(self, kind: str, alternatives: str = "") -> None:
        self.kind = kind
        self.alternatives = alternatives  # what else the kind accepts, e.g. "or a JSON file"
        self._entries: dict[str, Entry] = {}

    def register(self, name: str, summary: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
        def decorate(factory: Callable[..., Any]) -> Callable[..., Any]:
            if name in self._entries:
                raise RuntimeError(f"{self.kind} preset {name!r} registered twice")
            self._entries[name] = Entry(name, summary, factory)
            return factory

        return decorate

    def names(self) -> tuple[str, ...]:
        return tuple(self._entries)

    def entries(self) -> tuple[Entry, ...]:
        return tuple(self._entries.values())

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and name.strip().lower() in self._entries

    def choices(self) -> str:
        """``"a, b, c"`` plus the alternatives: the text of help strings and errors."""
        text = ", ".join(self._entries)
        return f"{text}{', ' + self.alternatives if self.alternatives else ''}"

    def get(self, name: str) -> Entry:
        key = str(name).strip().lower()
        if key not in self._entries:
            raise ParameterError(f"unknown {self.kind} {name!r}; choose one of {self.choices()}")
        return self._entries[key]

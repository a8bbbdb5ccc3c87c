"""Strategies by name: one small registry per family (parameterizations, formulations, pruners, LP backends).

In the manner of cvxpy's solver registry: each family has an abstract base class saying what a
strategy implements, and a :class:`Registry` of its subclasses by their ``name``. Everything that
accepts a strategy by name reads the registry: the checks of :func:`spherekin.compile`, the command
line's ``choices`` and every "expected one of" error. A new strategy is a subclass decorated with
``@REGISTRY.register``; it is then accepted everywhere.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

__all__ = ["Registry"]


class Registry(Mapping):
    """The strategies of one ``family`` (e.g. "pruner"), name -> class, in registration order.

    A read-only mapping (``name in registry``, ``list(registry)``: the names); :meth:`lookup` is
    the one place an unknown name becomes a ValueError listing the valid ones.
    """

    def __init__(self, family: str):
        self.family = family
        self._classes: dict[str, type] = {}

    def register(self, cls: type, *, first: bool = False) -> type:
        """Class decorator: add ``cls`` under ``cls.name`` (a non-empty string not yet taken), last in
        the order (``first``: before every other, where the order is a preference, as the systems')."""
        name = getattr(cls, "name", None)
        if not isinstance(name, str) or not name:
            raise ValueError(f"{self.family}: expected a class with a non-empty string attribute 'name', got {cls!r}")
        if name in self._classes:
            raise ValueError(f"{self.family}: {name!r} is already registered ({self._classes[name].__name__})")
        self._classes = {name: cls, **self._classes} if first else {**self._classes, name: cls}
        return cls

    def unregister(self, name: str) -> type:
        """Remove and return the class registered as ``name`` (for tests and plug-ins)."""
        return self._classes.pop(self.lookup(name).name)

    def lookup(self, name) -> type:
        """The class registered as ``name``; ValueError "family: expected one of [...], got ..." otherwise."""
        try:
            return self._classes[name]
        except (KeyError, TypeError):
            raise ValueError(f"{self.family}: expected one of {list(self._classes)}, got {name!r}") from None

    def __getitem__(self, name: str) -> type:
        return self._classes[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._classes)

    def __len__(self) -> int:
        return len(self._classes)

    def __repr__(self) -> str:
        return f"Registry({self.family!r}: {list(self._classes)})"

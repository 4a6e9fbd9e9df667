"""Registries of pluggable classes, keyed by their ``name``, filled on first use.

A registry knows the packages whose modules hold its classes; the first lookup imports them
all (each class registers itself with :meth:`Registry.register`), so ``import vfrs`` does not
depend on import side effects, and a new class is one new module in one of those packages.
Choices in scene validation, error messages and the CLI come from the registry.

>>> from vfrs.enforcement import METHODS
>>> sorted(METHODS)[:2]
['augmented_lagrange', 'detect_only']
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import MutableMapping

__all__ = ["Registry"]


class Registry(MutableMapping):
    """``kind``: what it holds (for messages); ``packages``: dotted names of packages whose
    modules are imported on first use; ``modules``: further single modules."""

    def __init__(self, kind: str, packages=(), modules=()):
        self.kind = kind
        self.packages = tuple(packages)
        self.modules = tuple(modules)
        self._items: dict = {}
        self._loaded = False
        self._loading = False

    def register(self, cls):
        """Class decorator: registers ``cls`` under ``cls.name``."""
        name = getattr(cls, "name", "")
        if not name:
            raise TypeError(f"{cls.__name__} needs a class attribute `name` to be registered as a {self.kind}")
        self._items[name] = cls
        return cls

    def unregister(self, name: str) -> None:
        self._items.pop(name, None)

    def _load(self) -> None:
        if self._loaded or self._loading:
            return
        self._loading = True
        try:
            for pkg in self.packages:
                mod = importlib.import_module(pkg)
                for info in pkgutil.iter_modules(mod.__path__):
                    importlib.import_module(f"{pkg}.{info.name}")
            for m in self.modules:
                importlib.import_module(m)
            self._loaded = True
        finally:
            self._loading = False

    def __getitem__(self, name):
        self._load()
        return self._items[name]

    def __iter__(self):
        self._load()
        return iter(self._items)

    def __len__(self):
        self._load()
        return len(self._items)

    def __setitem__(self, name, cls):
        self._load()
        self._items[name] = cls

    def __delitem__(self, name):
        self._load()
        del self._items[name]

    def __contains__(self, name):
        self._load()
        return name in self._items

    def choices(self) -> list:
        return sorted(self)

    def __repr__(self):
        return f"Registry({self.kind!r}, {sorted(self._items)})"

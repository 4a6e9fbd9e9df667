"""The package's files as its registries know them, for the architecture tests: which files
hold the effects and the role plug-ins, so that no test types a list of files by hand (a
new effect's or plug-in's files are covered the moment it is registered)."""

from __future__ import annotations

import sys
from pathlib import Path

import vfrs
from vfrs.dynamics.integrators import INTEGRATORS
from vfrs.effects import EFFECTS
from vfrs.enforcement import DETECTORS, METHODS, SOLVERS
from vfrs.enforcement.scheme import SCHEMES

PKG = Path(vfrs.__file__).parent
#: The registries of the contact and time-stepping roles (their plug-ins are chosen by name).
ROLES = (METHODS, DETECTORS, SOLVERS, SCHEMES, INTEGRATORS)


def _files_of(module: str) -> list[Path]:
    """The files of a module of vfrs, or of every module under it for a package."""
    path = PKG.joinpath(*module.split(".")[1:])
    if path.is_dir():
        return sorted(path.rglob("*.py"))
    return [path.with_suffix(".py")]


def effect_packages() -> list[str]:
    """The top-level modules of vfrs that hold the registered effects (``vfrs.flow``,
    ``vfrs.enforcement``, ...): those EFFECTS loads, and those its classes live in."""
    names = set(EFFECTS.modules) | {cls.__module__ for cls in EFFECTS.values()}
    return sorted({".".join(n.split(".")[:2]) for n in names if n.startswith("vfrs.")})


def effect_files() -> list[Path]:
    """Every file of the effects' top-level modules."""
    return sorted({p for m in effect_packages() for p in _files_of(m)})


def plugin_names() -> dict[Path, set[str]]:
    """Each role plug-in's file -> the names (registered names and class names) it defines."""
    out: dict[Path, set[str]] = {}
    for reg in ROLES:
        for name in reg:
            cls = reg[name]
            out.setdefault(Path(sys.modules[cls.__module__].__file__).resolve(), set()).update({name, cls.__name__})
    return out


def role_names() -> tuple[set[str], set[str]]:
    """(every registered role name, every registered role class name)."""
    names = {n for reg in ROLES for n in reg}
    return names, {reg[n].__name__ for reg in ROLES for n in reg}

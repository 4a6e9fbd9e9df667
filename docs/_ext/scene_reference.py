"""The scene file reference, generated from the code: every section and key that a registered
class reads, with its type, default, unit, range or choices and description.

Everything here is read at build time from the registries (``vfrs.roles.INTEGRATORS``,
``vfrs.effects.EFFECTS``, ``vfrs.enforcement`` ``METHODS`` / ``DETECTORS`` / ``SOLVERS`` /
``SCHEMES``, ``vfrs.meshes.PARAMS``, ``vfrs.materials.MATERIALS``) and their ``Params``
dataclasses, whose fields carry :func:`vfrs.params.param`'s metadata; the keys that the scene
reads by hand come from :mod:`vfrs.scene` itself: ``[output]`` from its ``Output`` dataclass,
``[[bodies]]``' own keys and ``[[obstacles]]`` recorded from its readers while they read an
example (:func:`read_keys`). A class registered (or a default
changed) in the code changes this page at the next build: nothing here is copied by hand.

``python docs/_ext/scene_reference.py`` prints the Markdown.
"""

from __future__ import annotations

import dataclasses
import inspect
import re
import typing
from dataclasses import MISSING

__all__ = ["scene_reference", "registries"]


def registries() -> dict:
    """The registries the reference walks, by what they hold (imported here, read at call time)."""
    from vfrs.effects import EFFECTS
    from vfrs.enforcement.base import METHODS
    from vfrs.enforcement.detector import DETECTORS
    from vfrs.enforcement.scheme import SCHEMES
    from vfrs.enforcement.solver import SOLVERS
    from vfrs.flow.model import FLOW_MODELS
    from vfrs.materials import MATERIALS
    from vfrs.meshes import PARAMS
    from vfrs.roles import INTEGRATORS

    return {"integrators": INTEGRATORS, "effects": EFFECTS, "methods": METHODS, "detectors": DETECTORS,
            "solvers": SOLVERS, "schemes": SCHEMES, "generators": PARAMS, "materials": MATERIALS,
            "flow_models": FLOW_MODELS}


# ---- one field -------------------------------------------------------------------------------
def _type_text(tp) -> str:
    if isinstance(tp, str):
        text = tp
    else:
        args = typing.get_args(tp)
        origin = typing.get_origin(tp)
        if origin is tuple and args and Ellipsis not in args:
            kind = "integers" if all(a is int for a in args) else "numbers"
            return f"array of {len(args)} {kind}"
        if args and type(None) in args:
            inner = [a for a in args if a is not type(None)]
            return " or ".join(_type_text(a) for a in inner) + " (optional)"
        if origin is list:
            return "array"
        text = getattr(tp, "__name__", str(tp))
    return {"float": "number", "int": "integer", "bool": "boolean", "str": "string", "object": "any",
            "list": "array", "dict": "table"}.get(text, text)


def _default(f) -> object:
    if f.default is not MISSING:
        return f.default
    if f.default_factory is not MISSING:
        return f.default_factory()
    return MISSING


def _value_text(v) -> str:
    if v is MISSING:
        return "**required**"
    if v is None:
        return "unset"
    if isinstance(v, bool):
        return f"`{str(v).lower()}`"
    if isinstance(v, str):
        return f'`"{v}"`'
    if isinstance(v, tuple):
        v = list(v)
    if isinstance(v, float):
        return f"`{v:g}`"
    return f"`{v!r}`"


def _num(x) -> str:
    return f"{x:g}" if isinstance(x, float) else str(x)


def _range_text(m) -> str:
    parts = []
    if m.get("positive"):
        parts.append("> 0")
    if m.get("nonnegative"):
        parts.append(">= 0")
    low, high = m.get("low"), m.get("high")
    if low is not None and high is not None:
        parts.append(f"[{_num(low)}, {_num(high)}]")
    elif low is not None:
        parts.append(f">= {_num(low)}")
    elif high is not None:
        parts.append(f"<= {_num(high)}")
    if m.get("minimum") is not None:
        parts.append(f">= {m['minimum']}")
    choices = m.get("choices")
    if choices is not None:
        values = choices() if callable(choices) else choices
        parts.append("one of " + ", ".join(f"`{c}`" for c in sorted(values)))
    return "; ".join(parts)


def _line(text: str) -> str:
    """One line of Markdown (a definition list's term or definition holds no line break)."""
    return " ".join(str(text).split())


def _first_paragraph(doc: str | None) -> str:
    if not doc:
        return ""
    text = inspect.cleandoc(doc).split("\n\n")[0]
    # reST roles and literals become Markdown code
    text = re.sub(r":(?:class|func|mod|meth|attr|data):`~?([^`]+)`", r"`\1`", text)
    text = text.replace("``", "`")
    return " ".join(text.split())


def _field_rows(cls, prefix: str = "") -> list:
    """One row per scene key of the dataclass ``cls`` (a nested Params dataclass: its keys as
    ``prefix.key``)."""
    try:
        types = typing.get_type_hints(cls)
    except Exception:
        types = {}
    rows = []
    for f in dataclasses.fields(cls):
        if f.name.startswith("_"):
            continue
        tp = types.get(f.name, f.type)
        default = _default(f)
        if dataclasses.is_dataclass(tp) and isinstance(tp, type):
            rows.extend(_field_rows(tp, f"{prefix}{f.name}."))
            continue
        m = dict(f.metadata)
        rows.append((f"`{prefix}{f.name}`", _type_text(tp), _value_text(default), m.get("unit", ""),
                     _range_text(m), m.get("doc", "")))
    return rows


#: A body and an obstacle with every optional table the reader knows (constraints, both kinds of
#: load), read by :func:`read_keys` to list the keys ``vfrs.scene`` reads by hand.
_EXAMPLE_BODY = {"name": "b", "mesh": {"builtin": "box"}, "material": {"model": "isotropic", "E": 1e3, "nu": 0.3},
                 "damping": {"a0": 0.0, "a1": 0.0}, "mass": "consistent", "velocity": [0.0, 0.0, 0.0],
                 "fixed": [{"surface": "zmin"}],
                 "loads": [{"type": "pressure", "surface": "zmax", "value": 1.0},
                           {"type": "traction", "surface": "zmax", "value": [0.0, 0.0, 1.0]}]}
_EXAMPLE_OBSTACLE = {"type": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}
_READERS = ("number", "integer", "boolean", "string", "vector", "array", "table")


def read_keys() -> dict:
    """The keys ``vfrs.scene`` reads by hand, recorded while its own readers (``read_body``,
    ``read_obstacle``) read an example: ``{"bodies": rows, "obstacles": rows}``, each row
    (key, type, default, unit, range, doc) like :func:`_field_rows`' (the mesh and material
    tables' own keys are the generators' and materials' sections). Read from the code, so a key
    added to or changed in the reader shows here."""
    from vfrs.scene import parse as scene  # the readers of [[bodies]] and [[obstacles]]
    from vfrs.params.table import REQUIRED, Table

    seen: list = []
    originals = {k: getattr(Table, k) for k in _READERS}

    def recorder(kind):
        def read(self, key, default=REQUIRED, **kw):
            seen.append((self.where, key, kind, default, kw))
            return originals[kind](self, key, default, **kw)
        return read

    for k in _READERS:
        setattr(Table, k, recorder(k))
    try:
        scene.read_body(Table(_EXAMPLE_BODY, "bodies[0]", "<reference>"), ".")
        scene.read_obstacle(Table(_EXAMPLE_OBSTACLE, "obstacles[0]", "<reference>"), 0)
    finally:
        for k, f in originals.items():
            setattr(Table, k, f)
    out: dict = {"bodies": [], "obstacles": []}
    done = set()
    for where, key, kind, default, kw in seen:
        path = re.sub(r"\[\d+\]", "[]", f"{where}.{key}")
        top, _, rest = path.partition("].")
        section = top.removesuffix("[")
        if rest.startswith(("mesh.", "material.")) or (section, rest, kind) in done:
            continue
        done.add((section, rest, kind))
        what = str(kw.get("what", "")).strip().strip("()")
        rng = []
        for flag, text in (("positive", "> 0"), ("nonnegative", ">= 0")):
            if kw.get(flag):
                rng.append(text)
        if kw.get("minimum") is not None:
            rng.append(f">= {kw['minimum']}")
        if kw.get("choices") is not None:
            rng.append("one of " + ", ".join(f"`{c}`" for c in kw["choices"]))
        out[section].append((f"`{rest}`", kind, _value_text(MISSING if default is REQUIRED else default), "",
                             "; ".join(rng), what))
    return out


def _field_comments(cls) -> dict:
    """Field name -> the ``# comment`` that ends its line in the class's source."""
    out = {}
    try:
        source = inspect.getsource(cls)
    except (OSError, TypeError):
        return out
    for m in re.finditer(r"^\s+(\w+)\s*:[^#\n]*#\s*(.+)$", source, re.M):
        out.setdefault(m.group(1), m.group(2).strip())
    return out


def _schema_comment(schema: str, key: str) -> str:
    """The comment on ``[key = ...]`` (or ``key = ...``) in vfrs.scene's schema, with the
    comment lines that continue it."""
    lines = schema.splitlines()
    for i, line in enumerate(lines):
        if re.match(rf"^\s*\[?{re.escape(key)} = ", line) and "#" in line:
            parts = [line.split("#", 1)[1].strip()]
            for nxt in lines[i + 1:]:
                if nxt.strip().startswith("#") and nxt.index("#") > 20:
                    parts.append(nxt.strip()[1:].strip())
                else:
                    break
            return " ".join(parts)
    return ""


def key_entry(row) -> list:
    """One key as a definition-list entry (MyST ``deflist``): the key is the term; the definition
    is its type (and unit), default, range or choices, then its description::

        `step`
        : number (s) · **required** · > 0 — time step

    A list, not a six-column table: the keys and choices are code that does not wrap, and six
    columns of it left the description one word wide at 1280 px (tests/test_docs_site.py)."""
    key, kind, default, unit, rng, doc = (_line(c) for c in row)
    meta = [f"{kind} ({unit})" if unit else kind, default if default == "**required**" else f"default {default}"]
    meta += [rng] if rng else []
    text = " · ".join(meta) + (f" — {doc}" if doc else "")
    return [key, f": {text}", ""]


def _table(rows) -> list:
    """The keys ``rows`` (see :func:`_field_rows`) as a definition list, one entry per key."""
    if not rows:
        return ["No keys of its own.", ""]
    return [line for row in rows for line in key_entry(row)]


def _class_block(title: str, cls, params, level: str = "###") -> list:
    lines = [f"{level} {title}", ""]
    summary = _first_paragraph(cls.__doc__)
    if summary:
        lines += [summary, ""]
    lines.append(f"Read by `{cls.__module__}.{cls.__qualname__}`.")
    lines.append("")
    return lines + _table(_field_rows(params) if params is not None else [])


def _output_rows(scene_mod, output, schema_text: str) -> list:
    """``[output]``'s keys from the ``Output`` dataclass, described by their fields' comments
    or, failing one, by the key's comment in the schema."""
    choices = {"compression": scene_mod.COMPRESSIONS, "until": scene_mod.UNTIL, "fields": list(scene_mod.FIELDS)}
    rows = []
    comments = _field_comments(output)
    for f in dataclasses.fields(output):
        kind = f.type.replace(" | None", "") if isinstance(f.type, str) else f.type
        doc = comments.get(f.name) or _schema_comment(schema_text, f.name)
        rng = ("one of " if f.name != "fields" else "any of ") + ", ".join(f"`{c}`" for c in choices[f.name]) \
            if f.name in choices else ""
        rows.append((f"`{f.name}`", _type_text(kind), _value_text(_default(f)), "", rng, doc))
    return rows


# ---- the page --------------------------------------------------------------------------------
def scene_reference() -> str:
    """The reference as Markdown (headings from ``##`` down), read from the registries now."""
    import vfrs.scene as scene_mod
    from vfrs.enforcement.effect import ContactEffect, ContactParams
    from vfrs.roles import mode_of
    from vfrs.scene import Output
    from vfrs.scene.plausibility import ChecksParams

    reg = registries()
    out: list = []
    w = out.extend

    w(["## The whole file at a glance", "",
       "The schema as `vfrs.scene` states it (keys in `[]` are optional, with their defaults); the "
       "sections below list every key a registered class reads.", "", "```text"])
    schema = (scene_mod.__doc__ or "").split("Schema (keys in ``[]`` are optional, with their defaults)::", 1)
    w(inspect.cleandoc(schema[-1]).splitlines() if len(schema) == 2 else ["# (the schema is not in vfrs.scene's docstring)"])
    w(["```", ""])

    # [time]
    w(["## `[time]`", "",
       "`mode` chooses the integrator among those registered for that mode; the bodies' kinematics "
       "choose between them (a finite-strain material: the Newton integrator). The other keys are the "
       "chosen integrator's `Params`.", ""])
    modes = sorted({mode_of(c) for c in reg["integrators"].values()})
    w(_table([("`mode`", "string", '`"dynamic"`', "", "one of " + ", ".join(f"`{m}`" for m in modes),
                "the kind of run; with the bodies' kinematics it chooses an integrator below")]))
    for name, cls in sorted(reg["integrators"].items(), key=lambda kv: (mode_of(kv[1]), kv[1].kinematics != "linear")):
        w(_class_block(f'`mode = "{mode_of(cls)}"`, {cls.kinematics} strain (`{name}`)', cls, cls.Params))

    # [output]
    w(["## `[output]`", "",
       "Read by `vfrs.scene` into its `Output` dataclass (no registry: the keys are fixed). The "
       "descriptions are the comments on the dataclass's fields or, failing one, on the key in the "
       "schema above; `vfrs.scene.COMPRESSIONS`, `UNTIL` and `FIELDS` give the choices.", ""])
    w(_table(_output_rows(scene_mod, Output, schema[-1] if len(schema) == 2 else "")))

    # [checks]
    w(["## `[checks]`", ""])
    w(_table(_field_rows(ChecksParams)))

    # [[bodies]]
    keys = read_keys()
    w(["## `[[bodies]]`", "",
       "A body's own keys, as `vfrs.scene` reads them (recorded from its reader at build time; `[]`: each "
       "entry of the array); its `mesh` and `material` tables are read by the registered generators and "
       "materials below.", ""])
    w(_table(keys["bodies"]))
    w(["### `mesh`: built-in generators", "",
       "`mesh = { builtin = \"<name>\", ... }`, plus vfrs's own `refine = n` (every tetrahedron split into "
       "eight, n times); or `mesh = { path = \"file.msh\", length_unit = \"m\" }` for a mesh file "
       "(`merge_nodes`, `refine`).", ""])
    for name, cls in sorted(reg["generators"].items()):
        w(_class_block(f'`builtin = "{name}"`', cls, cls, "####"))
    w(["### `material`: models", "",
       "`material = { model = \"<name>\", ... }`, or one such table per mesh region "
       "(`material = { cover = { ... }, body = { ... } }`).", ""])
    for name, cls in sorted(reg["materials"].items()):
        kin = getattr(cls, "kinematics", "")
        w(_class_block(f'`model = "{name}"`' + (f" ({kin} strain)" if kin else ""), cls, cls, "####"))

    w(["## `[[obstacles]]`", "", "Rigid obstacles a body can touch (recorded from the reader like the bodies' keys).", ""])
    w(_table(keys["obstacles"]))

    # effects
    w(["## Effects", "",
       "A section named after a registered effect adds it to the run; a scene without the section runs "
       "none of its code. Registered effects: " + ", ".join(f"`[{n}]`" for n in sorted(reg["effects"])) + ".", ""])
    for name, cls in sorted(reg["effects"].items()):
        if cls is ContactEffect or name == "contact":
            w(_contact_section(cls, ContactParams, reg))
            continue
        w(_class_block(f"`[{name}]`", cls, getattr(cls, "Params", None)))
        if name == "flow":
            w(["The keys every flow model shares are above; the chosen `model` adds its own (a key of "
               "another model is refused by name).", "", "#### Flow models (`model`)", ""])
            for model, c in sorted(reg["flow_models"].items()):
                w(_class_block(f'`model = "{model}"`', c, getattr(c, "Params", None), "#####"))
    return "\n".join(out).rstrip() + "\n"


def _contact_section(cls, common, reg) -> list:
    lines = _class_block("`[contact]`", cls, common)
    lines += ["The keys every method shares are above; the chosen `method`, `detection` and `solver` add "
              "their own (a key of another one is refused by name).", ""]
    for title, key, registry in (("Methods", "method", reg["methods"]), ("Detectors", "detection", reg["detectors"]),
                                 ("Contact solvers", "solver", reg["solvers"])):
        lines += [f"#### {title} (`{key}`)", ""]
        for name, c in sorted(registry.items()):
            lines += _class_block(f'`{key} = "{name}"`', c, getattr(c, "Params", None), "#####")
    lines += ["#### Schemes (`scheme`)", "",
              "How contact enters the time loop of a dynamic run; no keys of their own.", ""]
    for name, c in sorted(reg["schemes"].items()):
        lines += [f"`{name}`", f": {_line(_first_paragraph(c.__doc__) or '(no docstring)')} "
                               f"(`{c.__module__}.{c.__qualname__}`)", ""]
    return lines


if __name__ == "__main__":
    print(scene_reference(), end="")

"""The checks of ``[contact] surface`` and ``pairs`` against the bodies and their meshes' named
surfaces: scene validation (the scene runs them before any mesh is built, and again with the
meshes), used by :class:`vfrs.enforcement.surfaces.ContactSurfaces` too."""

from __future__ import annotations


#: The contact surface a body uses when ``[contact] surface`` does not name one for it (its
#: whole boundary if its mesh has no such surface).
DEFAULT_SURFACE = "medial"


def contact_surface_errors(surface, pairs, surfaces_of: dict) -> list:
    """What is wrong with ``[contact] surface`` / ``pairs`` for bodies whose meshes have the
    surfaces ``surfaces_of`` (body name -> surface names): a list of (key, message), empty if
    nothing. Nothing falls back silently: an empty ``pairs``, a body that does not exist, a
    surface name that no body in contact has (a typo; the default ``"medial"`` may be absent:
    the whole boundary is used then), a body's named surface its mesh lacks."""
    import difflib

    errors = []
    names = list(surfaces_of)

    def near(word, choices):
        m = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
        return f"; did you mean {m[0]!r}?" if m else ""

    if pairs is not None:
        if len(pairs) == 0:
            errors.append(("pairs", "an empty list would turn contact off; remove the [contact] section instead, "
                                    "or list the pairs of bodies that may touch (omit pairs: every pair)"))
        for i, pair in enumerate(pairs):
            for b in pair:
                if b not in surfaces_of:
                    errors.append((f"pairs[{i}]", f"no body named {b!r}{near(b, names)}; bodies are {names}"))
            if len(pair) == 2 and pair[0] == pair[1]:
                errors.append((f"pairs[{i}]", f"[{pair[0]!r}, {pair[1]!r}]: a body with itself (self-contact) is "
                                              "not supported; pair two different bodies"))
    in_contact = sorted({b for q in (pairs or []) for b in q if b in surfaces_of}) if pairs else names
    if isinstance(surface, str):
        if surface != DEFAULT_SURFACE and in_contact and not any(surface in surfaces_of[b] for b in in_contact):
            have = sorted({n for b in in_contact for n in surfaces_of[b]})
            errors.append(("surface", f"no body in contact has a surface {surface!r}{near(surface, have)}; their "
                                      f"surfaces: {have} (or give a table body -> surface)"))
    elif isinstance(surface, dict):
        for b, name in surface.items():
            if b not in surfaces_of:
                errors.append((f"surface.{b}", f"no body named {b!r}{near(b, names)}; bodies are {names}"))
            elif name not in surfaces_of[b]:
                errors.append((f"surface.{b}", f"the mesh of body {b!r} has no surface {name!r}"
                                               f"{near(name, surfaces_of[b])}; it has {sorted(surfaces_of[b])}"))
    return errors

"""How big a scene is before anything is allocated: nodes, DOFs, and the memory of the
matrices and of the Cholesky factors, checked against the memory the machine has.

The estimate is an order of magnitude, from counts measured on the built-in meshes (Kuhn
tetrahedra, faer's supernodal factor with nested dissection):

- each node couples to about 15 nodes (itself included): 9 x 15 = 135 stored entries per node
  in each 3n x 3n matrix (K, M, their free-free blocks, K_eff: six are kept), 12 bytes each;
- the factor of a body's free block stores about 4.3 n^1.45 entries (n its DOFs; measured
  nnz(L) 1.1e5 at 882 DOFs, 9.9e6 at 19,494, 1.9e7 at 37,044), 8 bytes each;
- generating a mesh holds about 200 bytes per tetrahedron at its peak;
- a quadratic (ten-node) body has about 8 times its linear mesh's nodes (one per edge: 6.7-7.3
  measured on the box and the M5 fold) and each node couples to about twice as many (245 stored
  entries per node measured, against 120 for linear ones); its factor is counted as twice a
  linear factor of as many DOFs (not measured: an estimate).

The limit is the memory available now (``MemAvailable`` of ``/proc/meminfo``, else the free
physical pages), or ``VFRS_MEMORY_LIMIT`` (bytes, or with a suffix: ``16G``, ``500M``; ``0``
or ``none``: no check).
"""

from __future__ import annotations

import os

#: The largest mesh a scene may ask for at all (nodes), whatever the machine: index arrays
#: are 64-bit, but no machine holds the matrices of more.
MAX_NODES = 2**31 - 1
ENTRIES_PER_NODE = 135
#: A quadratic body's: its nodes per node of the linear mesh, stored entries per node, and factor scale.
QUADRATIC_NODES, QUADRATIC_ENTRIES_PER_NODE, QUADRATIC_FACTOR = 8, 260, 2.0
MATRICES_KEPT = 6
MESH_BYTES_PER_TET = 200


def factor_entries(n_dofs: int) -> float:
    """The estimated stored entries of a Cholesky factor of an n_dofs x n_dofs FE matrix."""
    return 4.3 * float(n_dofs) ** 1.45 if n_dofs > 0 else 0.0


def estimate(bodies) -> dict:
    """Totals over ``bodies``, a list of (nodes, tetrahedra) or (nodes, tetrahedra, order) per
    body (``None``: unknown; order 2: ``nodes`` are the quadratic body's own)."""
    known = [(b[0], b[1], b[2] if len(b) > 2 else 1) for b in bodies if b is not None]
    nodes = sum(n for n, _, _ in known)
    tets = sum(t for _, t, _ in known)
    per_node = {1: ENTRIES_PER_NODE, 2: QUADRATIC_ENTRIES_PER_NODE}
    matrices = MATRICES_KEPT * 12.0 * sum(per_node[o] * n for n, _, o in known)
    factor = 8.0 * sum(factor_entries(3 * n) * (QUADRATIC_FACTOR if o == 2 else 1.0) for n, _, o in known)
    mesh = float(MESH_BYTES_PER_TET * tets)
    return {"nodes": nodes, "tetrahedra": tets, "dofs": 3 * nodes, "matrix_bytes": matrices,
            "factor_bytes": factor, "mesh_bytes": mesh, "bytes": matrices + factor + mesh,
            "unknown": len(bodies) - len(known)}


_SUFFIX = {"": 1, "b": 1, "k": 2**10, "m": 2**20, "g": 2**30, "t": 2**40}


def memory_limit() -> tuple[float | None, str]:
    """(bytes, where the number comes from); ``None`` bytes: no check."""
    env = os.environ.get("VFRS_MEMORY_LIMIT")
    if env is not None:
        text = env.strip().lower().rstrip("ib")
        if text in ("0", "none", "off", ""):
            return None, "VFRS_MEMORY_LIMIT"
        unit = text[-1] if text[-1] in _SUFFIX else ""
        try:
            value = float(text[: len(text) - len(unit)] if unit else text) * _SUFFIX[unit]
        except ValueError:
            from ..errors import SceneError

            raise SceneError(f"VFRS_MEMORY_LIMIT = {env!r}: expected bytes, e.g. 16G, 500M or 0 (no check)") from None
        return value, "VFRS_MEMORY_LIMIT"
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0, "MemAvailable in /proc/meminfo"
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")), "free physical memory"
    except (ValueError, OSError, AttributeError):
        return None, "unknown"


def gb(x: float) -> str:
    return f"{x / 2**30:.3g} GB"


def check_memory(source: str, bodies, where) -> dict:
    """Raises :class:`~vfrs.errors.SceneError` if the scene's estimate exceeds the memory
    limit; ``bodies`` as for :func:`estimate`, ``where`` their key paths. Returns the estimate."""
    from ..errors import SceneError

    est = estimate(bodies)
    limit, origin = memory_limit()
    if limit is None or est["bytes"] <= limit:
        return est
    sizes = [b[0] if b is not None else 0 for b in bodies]
    big = where[max(range(len(sizes)), key=sizes.__getitem__)] if sizes else ""
    raise SceneError(
        f"{source}: {big}: the scene needs about {gb(est['bytes'])} ({est['nodes']:,} nodes, {est['dofs']:,} DOFs: "
        f"matrices {gb(est['matrix_bytes'])}, Cholesky factors {gb(est['factor_bytes'])}, mesh {gb(est['mesh_bytes'])}) "
        f"but {gb(limit)} are available ({origin}); coarsen the mesh (fewer cells), or set VFRS_MEMORY_LIMIT "
        "(e.g. 64G, or 0 for no check) if the estimate is wrong for this machine"
    )

"""Mass redistribution (the default dynamic contact scheme): the contact-surface nodes carry no
mass, so contact never has to stop a node's own inertia within one step.

Why. In the semi-discrete problem with the usual mass matrix, a contact node that closes
carries mass and velocity, and a scheme that enforces the gap at t_{n+1} stops that mass
within one step: the recorded force holds an impulse of about m_i v / h, which grows without
limit as h shrinks (the peak contact pressure doubled each time the step halved). With no mass
on the contact nodes their position is set by the elastic balance with their neighbours at
every instant: the semi-discrete problem is a Lipschitz ODE in the other nodes (Khenous,
Laborde & Renard, Eur. J. Mech. A/Solids 27, 2008; Doyen, Ern & Piperno, SIAM J. Sci. Comput.
33, 2011, "modified mass method"), the contact force is a continuous function of time, and its
time-discrete history converges as h -> 0.

How. Each (free) contact-surface node c gives its mass to its non-contact neighbours j (the
nodes it shares a tetrahedron with), with weights w_cj proportional to the shared volume (the
consistent mass coupling), sum_j w_cj = 1; T is that map (identity on the other nodes, w on
the contact nodes). With P the projection onto the other nodes' DOFs,

    M' = P M P + diag(T^T m~),    m~_c = (row sum of M at c) + (its column sum over the other DOFs)

the other nodes keep their own consistent (or lumped) mass and couplings, and each contact
node's share of the mass (what its rows and columns held) is lumped onto its neighbours. M'
has zero rows and columns on the contact nodes and the sparsity of M on the others, so K_eff
keeps the pattern of K and its factor does not grow (the Galerkin alternative T^T M T couples
the neighbours' neighbours: the medium M5 factor grew from 6.07 to 8.13 million entries). For a
lumped mass this is the contact nodes' masses moved onto their neighbours. The total mass and
the momentum of every uniform velocity are M's exactly (each contact node's weights sum to one). The
centre of mass and the rotational inertia are not kept exactly: the contact nodes' mass moves
inward by a fraction of an element (:class:`Redistribution` reports both; the M5 folds'
numbers are in docs/contact.md). Weights that also reproduce linear fields (which keep the
centre of mass) must extrapolate, with both signs, and in a 1-D impact their force history
was worse (peak 1.6 F0 and an L1 error of 0.11-0.18 against 1.33 F0 and 0.031). A contact
node with no non-contact neighbour takes the mean of its resolved contact neighbours (rings
outward).

Nodes whose three DOFs are all fixed are neither massless nor targets (their rows are
eliminated). Gravity and the mass-proportional damping follow the new mass (a body falls
at g, undeformed). A body whose contact nodes cannot reach a node that can carry their mass
(its contact surface is the whole mesh) is refused with a SceneError naming it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ...errors import SceneError
from ...linalg import combine_columns, dot
from ...mesh import rigid_modes
from ..scheme import ContactScheme, register_scheme


@dataclass
class Redistribution:
    """What the redistribution did, per body: ``massless`` nodes, the ``moved`` mass (kg,
    the contact nodes' lumped mass), ``mass`` (total, kg, unchanged), ``centroid_shift``
    (m) and ``inertia_change`` (relative change of the trace of the second moment about
    the centre of mass)."""

    body: str
    massless: int
    nodes: int
    mass: float
    moved: float
    centroid_shift: float
    inertia_change: float

    def describe(self) -> str:
        return (f"{self.body}: {self.massless} of {self.nodes} nodes massless ({self.moved / self.mass:.1%} of "
                f"{self.mass:.4g} kg moved onto their neighbours); centre of mass moved {self.centroid_shift:.3g} m, "
                f"rotational inertia {self.inertia_change:+.2%}")


def _adjacency(tets, n, volumes) -> sp.csr_matrix:
    """A_ij = total volume of the tetrahedra sharing nodes i != j (the pattern and, up to
    rho / 20, the values of the consistent mass coupling)."""
    rows, cols, vals = [], [], []
    k = tets.shape[1]  # four nodes, or ten (a quadratic element: its mid-edge nodes are nodes like the others)
    for a in range(k):
        for b in range(k):
            if a != b:
                rows.append(tets[:, a])
                cols.append(tets[:, b])
                vals.append(volumes)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def interpolation(problem, contact_nodes) -> tuple:
    """(T, massless): T (n_points x n_points, csr) maps node velocities to node velocities,
    identity except on the ``massless`` nodes (the free contact-surface nodes, global
    numbers), whose rows are convex weights on nodes that carry mass and whose columns are
    zero. SceneError for a body whose massless nodes reach no such node."""
    n = problem.n_points
    fixed_dofs = np.zeros(problem.n_dofs, dtype=bool)
    fixed_dofs[problem.fixed] = True
    fully_fixed = fixed_dofs.reshape(-1, 3).all(axis=1)
    is_contact = np.zeros(n, dtype=bool)
    is_contact[np.asarray(contact_nodes, dtype=np.int64)] = True
    massless = is_contact & ~fully_fixed
    blocks = []
    for part in problem.bodies:
        m = part.mesh
        vol = np.abs(m.signed_volumes())
        blocks.append(_adjacency(m.tets, m.n_points, vol))
    A = sp.block_diag(blocks, format="csr") if len(blocks) > 1 else blocks[0]
    # Sources: rows of T known so far. Targets (non-contact, not fully fixed) are their own.
    source = ~massless & ~fully_fixed
    rows_of: dict = {}  # massless node -> (columns, weights)
    pending = np.flatnonzero(massless)
    S = sp.diags(source.astype(float), format="csr")  # the known rows of T, as a matrix
    while pending.size:
        W = A[pending][:, np.flatnonzero(source)]
        reach = np.asarray(W.sum(axis=1)).ravel()
        ok = reach > 0
        if not ok.any():
            break
        sub = A[pending[ok]].multiply(source[None, :]).tocsr()
        sub = sp.diags(1.0 / reach[ok]) @ sub
        new_rows = (sub @ S).tocsr()
        for k, node in enumerate(pending[ok].tolist()):
            lo, hi = new_rows.indptr[k], new_rows.indptr[k + 1]
            rows_of[node] = (new_rows.indices[lo:hi].copy(), new_rows.data[lo:hi].copy())
        place = sp.csr_matrix((np.ones(int(ok.sum())), (pending[ok], np.arange(int(ok.sum())))), shape=(n, int(ok.sum())))
        S = (S + place @ new_rows).tocsr()
        source[pending[ok]] = True
        pending = pending[~ok]
    if pending.size:
        bad = sorted({problem.body_of_node(int(k)).name for k in pending})
        raise SceneError(
            f"[contact] scheme = \"mass_redistribution\": the contact surface of body {', '.join(map(repr, bad))} "
            f"leaves no node to carry the mass of its contact nodes ({pending.size} nodes reach none: every node "
            "of the body is on its contact surface or fixed). Name a smaller contact surface ([contact] surface), "
            "mesh the body with interior nodes, or choose scheme = \"stabilized\"")
    # T: identity on every node that is not massless, the weights on the massless ones.
    keep = ~massless
    r_idx = [np.flatnonzero(keep)]
    c_idx = [np.flatnonzero(keep)]
    vals = [np.ones(int(keep.sum()))]
    for node, (cols, w) in rows_of.items():
        r_idx.append(np.full(len(cols), node))
        c_idx.append(cols)
        vals.append(w)
    T = sp.csr_matrix((np.concatenate(vals), (np.concatenate(r_idx), np.concatenate(c_idx))), shape=(n, n))
    return T, np.flatnonzero(massless)


def _dof_map(T) -> sp.csr_matrix:
    """T on nodes -> T on node-major DOFs (each component alike)."""
    return sp.kron(T, sp.identity(3, format="csr"), format="csr")


def redistributed_mass(problem, contact_nodes) -> tuple:
    """(M', massless nodes, [Redistribution per body]) for the problem's mass M (all DOFs):
    M' = P M P + diag(T^T m~), see the module docstring."""
    T, massless = interpolation(problem, contact_nodes)
    Td = _dof_map(T)
    M = problem.M.tocsr()
    keep = np.ones(problem.n_dofs)
    keep[(3 * massless[:, None] + np.arange(3)).ravel()] = 0.0
    P = sp.diags(keep, format="csr")
    # each massless DOF's share: its row of M and its column over the kept DOFs
    share = (1.0 - keep) * (M @ np.ones(problem.n_dofs) + M.T @ keep)
    M_new = (P @ M @ P + sp.diags(Td.T @ share)).tocsr()
    M_new.eliminate_zeros()
    M_new.sort_indices()
    return M_new, massless, [_report(part, M, M_new, massless) for part in problem.bodies]


def _second_moments(M, X) -> tuple:
    """(mass, centroid, trace of the second moment about it) of the x-components of M."""
    Mx = M[0::3, 0::3]
    one = np.ones(Mx.shape[0])
    m = Mx @ one
    mass = dot(one, m)
    c = np.array([dot(X[:, k], m) for k in range(3)]) / mass
    Y = X - c
    trace = sum(dot(Y[:, k], Mx @ Y[:, k]) for k in range(3))
    return mass, c, trace


def _report(part, M, M_new, massless) -> Redistribution:
    s = part.dofs
    X = part.mesh.points
    m0, c0, j0 = _second_moments(M[s, s], X)
    m1, c1, j1 = _second_moments(M_new[s, s], X)
    mine = massless[(massless >= part.node_offset) & (massless < part.node_offset + part.n_points)] - part.node_offset
    Mx = M[s, s][0::3, 0::3]
    moved = float(np.asarray(Mx[mine].sum(axis=1)).sum()) if mine.size else 0.0
    return Redistribution(part.name, int(mine.size), part.n_points, m1, moved, float(np.sqrt(np.sum((c1 - c0) ** 2))),
                          (j1 - j0) / j0 if j0 else 0.0)


def _null_space(A, tol=1e-9) -> np.ndarray:
    """A basis (columns) of the null space of the dense (m, k) ``A``, k small, by Gauss-Jordan
    elimination with partial pivoting on its columns scaled to unit maximum: elementwise numpy
    operations in a fixed order, so the same bits on every CPU (LAPACK's SVD would pick its
    kernels by CPU, see :func:`vfrs.linalg.dot`). Pivots below ``tol`` of the largest entry
    count as zero."""
    A = np.array(A, dtype=float)
    k = A.shape[1]
    colmax = np.abs(A).max(axis=0) if A.size else np.zeros(k)
    scale = np.where(colmax > 0, colmax, 1.0)
    A = A / scale
    top = np.abs(A).max() if A.size else 0.0
    pivots: list = []
    r = 0
    for c in range(k):
        if r == A.shape[0]:
            break
        i = r + int(np.argmax(np.abs(A[r:, c])))
        if not abs(A[i, c]) > tol * top:
            continue
        A[[r, i]] = A[[i, r]]
        A[r] = A[r] / A[r, c]
        for j in range(A.shape[0]):
            if j != r and A[j, c] != 0.0:
                A[j] = A[j] - A[j, c] * A[r]
        pivots.append(c)
        r += 1
    free = [c for c in range(k) if c not in pivots]
    N = np.zeros((k, len(free)))
    for n, c in enumerate(free):
        N[c, n] = 1.0
        for row, pc in enumerate(pivots):
            N[pc, n] = -A[row, c]
    return N / scale[:, None]


def _solve_small(A, b) -> np.ndarray:
    """``A^-1 b`` for a small symmetric positive definite ``A`` (a Gram matrix of rigid
    motions) by Gaussian elimination with partial pivoting in plain Python floats: the same
    bits on every CPU."""
    n = len(b)
    a = [[float(A[i][j]) for j in range(n)] + [float(b[i])] for i in range(n)]
    for c in range(n):
        p = max(range(c, n), key=lambda i: abs(a[i][c]))
        a[c], a[p] = a[p], a[c]
        for i in range(c + 1, n):
            f = a[i][c] / a[c][c]
            if f != 0.0:
                a[i] = [x - f * y for x, y in zip(a[i], a[c])]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        x[i] = (a[i][n] - sum(a[i][j] * x[j] for j in range(i + 1, n))) / a[i][i]
    return np.array(x)


class _TakeBack:
    """What is left of a step's energy gain to take back, and the velocity and the contact
    impulse (free DOFs; the supports' share apart) the stages have made of it so far."""

    def __init__(self, v0, gain, tolerance):
        self.v = v0.copy()
        self.impulse = np.zeros(len(self.v))
        self.impulse_fixed = None
        self.left = gain
        self.tiny = tolerance * gain

    def more(self) -> bool:
        """Whether there is still energy to take back."""
        return self.left > self.tiny

    def scale_down(self, M, w, record) -> None:
        """Takes what is left, up to all of w's kinetic energy, by v -> v - c w."""
        Mw = M @ w
        q = dot(w, Mw)  # twice the kinetic energy of w; w . M v = w . M w
        if not q > 0:
            return
        take = min(self.left, 0.5 * q)
        c = 1.0 - np.sqrt(max(1.0 - 2.0 * take / q, 0.0))
        self.v = self.v - c * w
        if record:
            self.impulse = self.impulse - c * Mw
        self.left -= take


@register_scheme
class MassRedistributionScheme(ContactScheme):
    """The contact-surface nodes' mass moved onto their neighbours (:func:`redistributed_mass`);
    contact forces at t_{n+1} in the HHT-alpha recursion, as in the plain scheme; and a step
    whose contact made energy is corrected (:meth:`after_correct`)."""

    name = "mass_redistribution"
    #: A step's contact energy gain below this share of its contact work is round-off.
    GAIN_TOLERANCE = 1e-9

    def __init__(self, params=None):
        super().__init__(params)
        self.report: list = []
        self.impulse = None
        self._jump_energy = 0.0  # what this step's correction changed the kinetic energy by (J)
        self.corrections = 0  # steps corrected so far
        self.corrected = 0.0  # energy the corrections took back so far (J)
        self.uncorrected = 0.0  # energy gains no correction could take back (J)
        self._warned = False

    def prepare(self, problem, surfaces) -> list:
        M_new, massless, self.report = redistributed_mass(problem, surfaces.nodes)
        problem.set_mass(M_new)
        return [f"mass redistribution: {r.describe()}" for r in self.report]

    def setup(self, effect, ctx) -> None:
        c = ctx.constants
        self.h, self.beta, self.gamma = c.h, c.beta, c.gamma
        self._mass = ctx.mass  # M^-1, factored on first use (a step that needs a correction)
        p = self.problem = effect.problem
        self.M = p.M_free.tocsr()
        self.T = _dof_map(interpolation(p, effect.surfaces.nodes)[0])
        # Each body's rigid motions that its fixed DOFs allow (a free body: all six; a body on
        # rollers: those along them; a clamped one: none), and the free bodies' together, on
        # the free DOFs, with their Gram matrices in M: the correction's stages keep each
        # body's momentum along them, or record what they change.
        fixed = np.zeros(p.n_dofs, dtype=bool)
        fixed[p.fixed] = True
        pos = np.full(p.n_dofs, -1)
        pos[p.free] = np.arange(len(p.free))
        self.rigid_each = [r for r in (self._rigid([b], pos, fixed) for b in p.bodies) if r is not None]
        free_bodies = [b for b in p.bodies if not fixed[b.dofs].any()]
        self.rigid_free = [self._rigid([b], pos, fixed) for b in free_bodies]
        self.rigid_all = self._rigid(free_bodies, pos, fixed) if len(free_bodies) > 1 else None

    def _rigid(self, bodies, pos, fixed):
        """(rows, R, M R, (R^T M R)^-1) of the rigid motions of ``bodies`` that leave their
        fixed DOFs at rest (R on the free DOFs), or None if there is none."""
        dofs = np.concatenate([np.arange(b.dofs.start, b.dofs.stop) for b in bodies])
        R = rigid_modes(np.concatenate([b.mesh.points for b in bodies]))
        held = fixed[dofs]
        if held.any():  # the combinations that vanish on the fixed DOFs
            N = _null_space(R[held])
            if N.shape[1] == 0:
                return None
            R = np.column_stack([combine_columns(R, N[:, j]) for j in range(N.shape[1])])
        rows = pos[dofs[~held]]
        R = R[~held]
        Mb = self.M[rows][:, rows]
        MR = np.column_stack([Mb @ R[:, j] for j in range(R.shape[1])])
        gram = np.array([[dot(R[:, i], MR[:, j]) for j in range(R.shape[1])] for i in range(R.shape[1])])
        return rows, R, MR, gram

    @staticmethod
    def _rigid_part(v, rigid) -> np.ndarray:
        """The M-orthogonal projection of ``v`` onto the rigid motions ``rigid``."""
        rows, R, MR, gram = rigid
        out = np.zeros_like(v)
        rhs = [dot(MR[:, j], v[rows]) for j in range(R.shape[1])]
        out[rows] = combine_columns(R, _solve_small(gram, rhs))
        return out

    def after_correct(self, effect, step, x_start, x_end, found, lam, G) -> None:
        """The energy check. With contact forces at t_{n+1} in the recursion, the trapezoidal
        rule (HHT alpha = 0) changes the energy in a step by the contact work
        (x1 - x0) . (f0 + f1) / 2 exactly. With the change of what the pair forces store in
        their overlap (a penalty's springs), that is <= 0 at an impact and zero in persistent
        contact on a flat face, but it is > 0 when a pair releases within the step (its last
        force still acts over the step: O(h^2) per release, more when the step is large for
        the impact speed), and node-to-surface pairs on curved faceted surfaces are not
        conservative (a slave's frozen geometry turns as it slides from facet to facet: two
        graded Gmsh balls gained 1.2e-3 to 2.8e-3 E0 per impact, not less with a smaller
        step). A step whose contact made energy gives it back at its end, by an impulse that
        removes exactly the gain, taken in this order from

        1. the deformation: the velocity less each body's rigid motion (M-orthogonally; of a
           body with fixed DOFs, the rigid motion they allow: along rollers, say), scaled
           down: no body's momentum along a free direction changes, so it is no contact force;
        2. the normal relative motion of the contact zone: b = T^T G^T gdot over the pairs
           loaded at either end of the step (gdot their normal velocity from the interpolated
           contact-node velocities T v), the velocity change -mu M^-1 b: a contact impulse,
           equal and opposite between the bodies, recorded in the contact force (when the
           bodies separate it slows them: a pull in the record);
        3. the free bodies' rigid motions relative to their common one, scaled down: total
           momentum and angular momentum kept, recorded as contact impulse;
        4. only in a step far too large for the impact speed (a body pushed through elements
           in one step, then released: the contact's last force acts over the whole rebound):
           the bodies' rigid motion itself, recorded as contact impulse on them (its reaction
           is taken by the fixed bodies' supports or the obstacle, and a VfrsWarning says the
           step is too large).

        Each stage takes what is left, up to all of its component's kinetic energy. The
        impulses are zero on the massless contact nodes (pressure and area do not see them);
        the energy is part of ``contact_work``; history ``contact_energy_corrected`` (J) adds
        it up. What no stage can take (a step far too large for the impact) stays, with a
        warning."""
        self._jump_energy = 0.0
        self.impulse = None
        step.set_velocity_jump(None)
        if step.u_tilde is None:  # statics
            return
        f_prev, loaded_prev, _ = effect.step_start
        gain = self._energy_gain(effect, x_start, x_end)
        if gain is None:
            return
        # the step's velocity (free DOFs), from the Newmark relations at the corrected u
        v0 = step.v_tilde + (self.gamma / (self.beta * self.h)) * (step.u - step.u_tilde)
        back = _TakeBack(v0, gain, self.GAIN_TOLERANCE)
        self._take_deformation(back)
        self._take_contact_zone(back, step, lam, G, loaded_prev)
        stage4 = self._take_rigid(back)
        removed = gain - back.left
        if back.more():
            self.uncorrected += back.left
        self._warn(back, stage4, step, gain, removed, x_end, f_prev, effect.balance_force)
        if removed <= 0:
            return
        v = back.v
        step.set_velocity_jump(v - v0)
        M_dv = self.M @ (v - v0)
        self._jump_energy = dot(v0, M_dv) + 0.5 * dot(v - v0, M_dv)
        if back.impulse.any():
            self.impulse = step.dofmap.expand(back.impulse, back.impulse_fixed)
        self.corrected += -self._jump_energy
        self.corrections += 1

    def _energy_gain(self, effect, x_start, x_end) -> float | None:
        """The energy the step's contact made (J): the trapezoidal contact work plus the change
        of what the pair forces store in their overlap, or None if it is round-off or a loss."""
        f_prev, _, stored_prev = effect.step_start
        dx = x_end.ravel() - x_start.ravel()
        w0, w1 = 0.5 * dot(dx, f_prev), 0.5 * dot(dx, effect.balance_force)
        gain = w0 + w1 + effect.stored_energy - stored_prev
        scale = abs(w0) + abs(w1) + effect.stored_energy + stored_prev
        if not gain > self.GAIN_TOLERANCE * scale:
            return None
        return gain

    def _take_deformation(self, back) -> None:
        """Stage 1: the deformation (a body with fixed DOFs: all its motion), scaled down: no
        free body's momentum changes."""
        v = back.v
        rigid = sum((self._rigid_part(v, r) for r in self.rigid_each), np.zeros_like(v))
        back.scale_down(self.M, v - rigid, record=False)

    def _take_contact_zone(self, back, step, lam, G, loaded_prev) -> None:
        """Stage 2: the contact zone's normal relative motion, over the pairs loaded at either
        end of the step: a contact impulse, equal and opposite between the bodies."""
        p = self.problem
        rows = []
        if back.more() and G is not None and len(lam) and (lam > 0).any():
            rows.append(G[np.flatnonzero(lam > 0)].tocsr())
        if back.more() and loaded_prev is not None and len(loaded_prev):
            rows.append(loaded_prev.constraint(p.n_points).tocsr())
        if not rows:
            return
        v = back.v
        Gu = sp.vstack(rows).tocsr()
        gdot = Gu @ (self.T @ step.dofmap.expand(v, p.fixed_values(step.t, 1)))
        b_all = self.T.T @ (Gu.T @ gdot)  # all DOFs: equal and opposite between the bodies
        b = b_all[p.free]
        Mb = self._mass.solve(b)
        A, B = dot(b, Mb), dot(v, b)
        if A > 0 and B > 0:
            take = min(back.left, 0.5 * B * B / A)
            mu = (B - np.sqrt(max(B * B - 2.0 * A * take, 0.0))) / A
            back.v = v - mu * Mb
            back.impulse_fixed = -mu * b_all[p.fixed]  # what the supports take, recorded as well
            back.impulse = back.impulse - mu * b
            back.left -= take

    def _take_rigid(self, back) -> bool:
        """Stage 3: the free bodies' rigid motions relative to their common one; stage 4: the
        bodies' rigid motions themselves. Both recorded as contact impulse. True if stage 4 ran."""
        if back.more() and self.rigid_all is not None:
            v = back.v
            rigid = sum((self._rigid_part(v, r) for r in self.rigid_free), np.zeros_like(v))
            back.scale_down(self.M, rigid - self._rigid_part(v, self.rigid_all), record=True)
        if back.more() and self.rigid_each:
            v = back.v
            back.scale_down(self.M, sum((self._rigid_part(v, r) for r in self.rigid_each), np.zeros_like(v)),
                            record=True)
            return True
        return False

    def _warn(self, back, stage4, step, gain, removed, x_end, f_prev, f_end) -> None:
        """Warns (once a run) that the step is too large for the impact speed, when the gain
        could not all be taken back or stage 4 slowed the bodies' rigid motion."""
        # A gain below the work the contact forces do over the positions' last bits (eps times
        # the largest coordinate) is round-off: corrected as far as it goes, but no warning (a
        # block settled on a plane gains 1e-23 J now and then, where eps L F is 1e-20 J).
        if (back.more() or stage4) and not self._warned and gain > 4.0 * np.finfo(float).eps * float(
                np.abs(x_end).max(initial=0.0)) * (float(np.abs(f_prev).sum()) + float(np.abs(f_end).sum())):
            import warnings

            from ...errors import VfrsWarning

            self._warned = True
            what = (f"only {removed:.3g} J could be taken back (the bodies' motion holds no more)" if back.more() else
                    "taking it back slowed the free bodies' rigid motion, a momentum change the fixed bodies' "
                    "supports or the obstacle take")
            warnings.warn(f"t = {step.t:.6g}: contact made {gain:.3g} J of energy in one step, and {what}: the step "
                          "is too large for this impact speed (a pair pushed through elements in one step, then "
                          "released). Use a smaller time step.", VfrsWarning, stacklevel=3)

    def work(self, state, stepped: bool) -> float:
        out, self._jump_energy = self._jump_energy, 0.0
        return out

    def record(self, history: dict) -> None:
        history.setdefault("contact_energy_corrected", []).append(self.corrected)

    def state(self) -> dict:
        return {"corrections": self.corrections, "corrected": self.corrected, "uncorrected": self.uncorrected,
                "warned": self._warned}

    def restore(self, state: dict) -> None:
        self.corrections = state.get("corrections", 0)
        self.corrected = state.get("corrected", 0.0)
        self.uncorrected = state.get("uncorrected", 0.0)
        self._warned = state.get("warned", False)

"""The ``[contact]`` effect: detection, the reduced contact solve, forces into the step.

Per step (in the ``correct`` hook, after the contact-free solve u0):

1. detect pairs at the current positions (interface mesh or BVH, both directions between
   each pair of bodies; rigid planes too);
2. with the pairs' geometry frozen (xi, zeta, n), the gaps respond linearly to pair forces:
   g = g0 + W lam, g0 the gaps of u0, W = s G K_eff^-1 G^T from the precomputed compliance;
3. the method decides lam (penalty, Lagrange LCP, Uzawa augmentations, or nothing);
4. the force G^T lam is applied with one solve; detection is repeated at the new positions
   until the loaded pairs stop changing (at most ``max_detections`` times).

``solver = "refactor"`` replaces 2-3 for the penalty methods by the plain reference:
refactor K_eff + s G^T diag(k) G and solve, on the same active-set iteration.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import scipy.sparse as sp

from ..contact import BvhDetector, ContactPairs, InterfaceMesh, contact_area, node_to_plane, tributary_areas
from ..effects import Effect, register_effect
from ..errors import ConvergenceError, VfrsError, VfrsWarning
from .base import METHODS
from .compliance import Compliance

DETECTION = ("bvh", "interface_mesh")


@register_effect
class ContactEffect(Effect):
    """``[contact]``: ``method`` (penalty, penalty_volume, lagrange, augmented_lagrange,
    detect_only), ``[detection = "bvh"]`` (or ``"interface_mesh"``, the paper's),
    ``[pairs]`` (body-name pairs; default every pair of bodies), ``[surface = "medial"]`` (or a
    table body -> surface; default: the named surface if the mesh has it, else the whole
    boundary), ``[kappa]`` (penalty, Pa/m; volume form N/m^3; Uzawa start, default 1),
    ``[growth = 10]``, ``[reduction = 0.75]``, ``[max_augmentations = 4]``,
    ``[gap_tol = 1e-7]`` (m), ``[kappa_max = 1e16]``, ``[search_distance]`` (m, BVH; default
    half the mean surface edge), ``[max_iterations = 100]`` (active set), ``[max_detections = 8]``,
    ``[solver = "compliance"]`` (or ``"refactor"``), ``[strict = true]`` (raise
    :class:`vfrs.ConvergenceError` when an active set cycles or does not settle),
    ``[stabilized = true]`` (dynamic runs: contact-stabilized predictor; false is the
    paper's plain scheme, which gains energy at impacts).
    """

    name = "contact"

    @classmethod
    def resolve(cls, table) -> dict:
        method = table.string("method", choices=METHODS)
        cfg = {
            "method": method,
            "detection": table.string("detection", "bvh", choices=DETECTION),
            "pairs": table.raw("pairs", None),
            "surface": table.raw("surface", "medial"),
            "kappa": table.number("kappa", None if method in ("penalty", "penalty_volume") else 1.0, positive=True),
            "growth": table.number("growth", 10.0, low=1.0, high=1e6),
            "reduction": table.number("reduction", 0.75, low=0.0, high=1.0),
            "max_augmentations": table.integer("max_augmentations", 4, minimum=1),
            "gap_tol": table.number("gap_tol", 1e-7, positive=True, what=" (m)"),
            "kappa_max": table.number("kappa_max", 1e16, positive=True),
            "search_distance": table.number("search_distance", None, positive=True, what=" (m)"),
            "max_iterations": table.integer("max_iterations", 100, minimum=1),
            "max_detections": table.integer("max_detections", 8, minimum=1),
            "solver": table.string("solver", "compliance", choices=["compliance", "refactor"]),
            "strict": table.boolean("strict", True),
            "stabilized": table.boolean("stabilized", True),
        }
        if cfg.get("pairs") is not None:
            p = cfg["pairs"]
            if not isinstance(p, list) or not all(isinstance(q, list) and len(q) == 2 and all(isinstance(b, str) for b in q) for q in p):
                raise table.error(f"expected a list of [body, body] pairs, got {p!r}", "pairs")
        s = cfg["surface"]
        if not (isinstance(s, str) or (isinstance(s, dict) and all(isinstance(v, str) for v in s.values()))):
            raise table.error(f"expected a surface name or a table body -> surface, got {s!r}", "surface")
        if cfg["method"] == "penalty_volume" and cfg["detection"] != "interface_mesh":
            raise table.error("penalty_volume needs detection = \"interface_mesh\" (it penalises inverted interface volumes)", "method")
        if cfg["solver"] == "refactor" and cfg["method"] not in ("penalty", "penalty_volume"):
            raise table.error("the refactoring reference path exists for the penalty methods only", "solver")
        table.done()
        # TOML has no null: unset options are left out of the resolved scene.
        return {k: v for k, v in cfg.items() if v is not None}

    # -- setup ---------------------------------------------------------------------------
    def setup(self, problem) -> None:
        cfg = self.config
        self.problem = problem
        self.method = METHODS[cfg["method"]](cfg)
        parts = {p.name: p for p in problem.bodies}
        X = problem.points
        self.surface_of = {}
        for p in problem.bodies:
            name = cfg["surface"] if isinstance(cfg["surface"], str) else cfg["surface"].get(p.name, "medial")
            tri = p.mesh.surfaces.get(name)
            if tri is None:
                if isinstance(cfg["surface"], dict) and p.name in cfg["surface"]:
                    raise VfrsError(f"[contact] surface: body {p.name!r} has no surface {name!r}; it has {sorted(p.mesh.surfaces)}")
                tri = p.mesh.boundary_faces()
            self.surface_of[p.name] = tri + p.node_offset
        if cfg.get("pairs") is None:
            names = [p.name for p in problem.bodies]
            pairs = [[a, b] for i, a in enumerate(names) for b in names[i + 1 :]]
        else:
            pairs = cfg["pairs"]
            for a, b in pairs:
                for n in (a, b):
                    if n not in parts:
                        raise VfrsError(f"[contact] pairs: no body named {n!r}; bodies are {sorted(parts)}")
        self.pairs = pairs
        all_tri = np.concatenate(list(self.surface_of.values()))
        self.areas = tributary_areas(X, all_tri)  # per global node (0 off the surfaces)
        edges = np.linalg.norm(X[all_tri] - X[np.roll(all_tri, 1, axis=1)], axis=2)
        self.h_surface = float(edges.mean())
        self.search = cfg.get("search_distance") or 0.5 * self.h_surface
        self.detectors = []
        for a, b in self.pairs:
            if cfg["detection"] == "interface_mesh":
                # Rebuilt (when the slip demands it) once per step, at the start-of-step
                # configuration, which contact has kept free of overlap; never mid-step.
                self.detectors.append(InterfaceMesh(X, self.surface_of[a], self.surface_of[b], auto_rebuild=False))
            else:
                for s, m in ((a, b), (b, a)):
                    nodes = np.unique(self.surface_of[s])
                    self.detectors.append(BvhDetector(self.surface_of[m], slave_nodes=nodes, slave_areas=self.areas[nodes]))
        # Boundary edges and nodes of the (open) contact surfaces, for the BVH's pairs.
        edges = np.sort(all_tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        uniq, counts = np.unique(edges, axis=0, return_counts=True)
        rim = uniq[counts == 1]
        self.boundary_edges = set(map(tuple, rim.tolist()))
        self.boundary_nodes = set(rim.ravel().tolist())
        self.planes = problem.obstacles
        self.plane_nodes = np.unique(all_tri)
        # Two detection directions between bodies share each contact patch: halve each.
        self.pair_weight = 0.5 if self.pairs else 1.0
        t0 = time.perf_counter()
        self.compliance = None
        if self.method.applies_forces and cfg["solver"] == "compliance":
            # Columns are computed when a pair first touches a DOF: only the contact zone
            # is ever solved for.
            self.compliance = Compliance(problem.factor, problem.dofmap.free, problem.n_dofs)
        # Contact-stabilized Newmark (Deuflhard, Krause & Ertel 2008): the predictor is
        # projected onto the admissible set in the mass norm before each dynamic step.
        self.mass_compliance = None
        dynamic = problem.scene.time.mode == "dynamic"
        self.stabilized = bool(self.method.applies_forces and cfg["stabilized"] and dynamic)
        if self.stabilized:
            self.mass_factor = problem.integrator.mass_factor  # shared with the integrator
            self.mass_compliance = Compliance(self.mass_factor, problem.dofmap.free, problem.n_dofs)
        # In the stabilized scheme the reaction of a constraint (Lagrange, Uzawa) acts within
        # its step only (StepContext.add_force): it must not keep pushing the bodies apart in
        # the next step while they separate, which gained energy on non-matching meshes. A
        # penalty force is a force law of the current overlap and stays in the recursion.
        self.transient = self.stabilized and self.method.constraint
        # The recorded contact force is the momentum contact gave each node in the step,
        # divided by h: a transient force f moves it by gamma (1 + alpha) h f (all in its step),
        # a force in the recursion by h f (spread over two steps), and the velocity projection
        # of the predictor by its impulse G^T nu.
        integ = problem.integrator
        self.h = getattr(integ, "h", None)
        self.force_weight = integ.gamma * (1.0 + integ.alpha) if self.transient else 1.0
        self.impulse = np.zeros(problem.n_dofs)  # the predictor's velocity impulse this step
        self.setup_seconds = time.perf_counter() - t0
        self.seconds = 0.0
        self.last = None
        self._warned = {}
        self._work_state = None
        self._contact_work = 0.0
        self.x_prev = X.copy()
        self._warn_weak_kappa(problem)
        self.force_full = np.zeros(problem.n_dofs)
        self.probe_nodes = [problem.nearest_node(p) for p in problem.scene.output.probes]

    def _warn_weak_kappa(self, problem) -> None:
        """Warns when kappa is far below the contact stiffness scale of the surfaces
        (K_ii / a_i ~ E / h): the penetration then stays large, or the augmentations start
        from almost nothing (the paper's kappa_0 = 1 read as 1 Pa/m)."""
        cfg = self.config
        nodes = self.plane_nodes
        a = self.areas[nodes]
        diag = problem.K.diagonal().reshape(-1, 3)[nodes].mean(axis=1)
        ok = a > 0
        self.kappa_scale = float(np.median(diag[ok] / a[ok])) if ok.any() else None
        if cfg["method"] not in ("penalty", "augmented_lagrange") or "kappa" not in cfg or not ok.any():
            return
        scale = self.kappa_scale
        if cfg["kappa"] < 1e-3 * scale:
            what = ("the penetration will be large" if cfg["method"] == "penalty" else
                    f"the augmentations start from almost nothing (kappa grows by a factor {cfg['growth']:g} "
                    f"per augmentation, at most {cfg['max_augmentations']} per step)")
            warnings.warn(
                f"[contact] kappa = {cfg['kappa']:g} Pa/m is far below the contact stiffness scale of these "
                f"surfaces, K_ii / a_i ~ E / h = {scale:.3g} Pa/m: {what}. Try kappa of order {scale:.0e}.",
                VfrsWarning, stacklevel=3)

    # -- detection -----------------------------------------------------------------------
    def _detect(self, x) -> tuple:
        """Pairs at positions x (n, 3), with the per-pair weight (0.5 between bodies, 1 for
        planes) and the per-pair offset c such that gap = G x - c."""
        parts, weights, offsets = [], [], []
        for d in self.detectors:
            if isinstance(d, InterfaceMesh):
                p = d.detect(x)
            else:
                p = self._beside_patch_removed(d.detect(x, self.search), x)
            parts.append(p)
            weights.append(np.full(len(p), self.pair_weight))
            offsets.append(np.zeros(len(p)))
        for plane in self.planes:
            p = node_to_plane(x, self.plane_nodes, plane.point, plane.normal, self.search, self.areas[self.plane_nodes])
            parts.append(p)
            weights.append(np.ones(len(p)))
            offsets.append(np.full(len(p), float(np.dot(plane.normal, plane.point))))
        pairs = ContactPairs.concatenate(parts)
        return pairs, np.concatenate(weights) if weights else np.zeros(0), np.concatenate(offsets) if offsets else np.zeros(0)

    def _beside_patch_removed(self, pairs, x):
        """Drops BVH pairs whose closest point lies on a boundary edge or vertex of an open
        master surface while the node is behind the surface and further outside the rim (in
        the plane) than behind the plane: the node is beside the patch, not through it (it
        would get a negative gap and a sideways normal). A node that went in through the face
        near the rim and spread sideways a little (up to 1 % of an element, or less than its
        depth) stays. Interface meshes leave such nodes
        out at build time for the same reason."""
        if len(pairs) == 0:
            return pairs
        cand = (pairs.feature > 0) & (pairs.gap < 0) & (pairs.triangle >= 0)
        if not cand.any():
            return pairs
        drop = np.zeros(len(pairs), dtype=bool)
        N = np.stack([1.0 - pairs.xi - pairs.zeta, pairs.xi, pairs.zeta], axis=1)
        tol = 1e-9
        for k in np.flatnonzero(cand):
            on = np.flatnonzero(N[k] > tol)  # master nodes the closest point depends on
            nodes = pairs.master[k][on]
            rim = (len(nodes) == 1 and int(nodes[0]) in self.boundary_nodes) or (
                len(nodes) == 2 and (min(nodes), max(nodes)) in self.boundary_edges)
            if rim:
                xm = x[pairs.master[k]]
                n = np.cross(xm[1] - xm[0], xm[2] - xm[0])
                n /= np.sqrt(np.sum(n * n))
                s_ = x[pairs.slave[k]]
                depth = float(np.sum((xm[0] - s_) * n))  # behind the plane: > 0
                in_plane = s_ + depth * n  # projection onto the plane
                xbar = N[k] @ xm  # closest point of the triangle (on its rim)
                outside = float(np.sqrt(np.sum((in_plane - xbar) ** 2)))
                # Spreading past the rim by a sliver of an element is not "beside".
                drop[k] = outside > max(depth, 1e-2 * self.h_surface)
        return pairs.select(~drop) if drop.any() else pairs

    @staticmethod
    def _merge(carried, pairs, weight, offset, x, n_points):
        """Carried pairs (gaps refreshed at x with their frozen geometry) plus the new pairs
        that are not among them."""
        old, w_old, off_old = carried
        if len(old) == 0:
            return pairs, weight, offset
        old.gap = old.constraint_matrix(n_points) @ x.ravel() - off_old

        def keys(pp):
            # A surface pair is its slave and master triangle; a plane pair its slave and plane.
            return [
                (sl, tr) if tr >= 0 else (sl, tr, tuple(nn))
                for sl, tr, nn in zip(pp.slave.tolist(), pp.triangle.tolist(), np.round(pp.normal, 9).tolist())
            ]

        key_old = set(keys(old))
        new = np.array([k not in key_old for k in keys(pairs)], dtype=bool)
        merged = ContactPairs.concatenate([old, pairs.select(new)])
        return merged, np.concatenate([w_old, weight[new]]), np.concatenate([off_old, offset[new]])

    def _stiffness(self, pairs, x, weight):
        cfg = self.config
        if cfg["method"] == "penalty_volume":
            xm = x[pairs.master]
            a_t = 0.5 * np.linalg.norm(np.cross(xm[:, 1] - xm[:, 0], xm[:, 2] - xm[:, 0]), axis=1)
            return cfg["kappa"] * a_t / 3.0
        kappa = cfg.get("kappa", 1.0)
        return kappa * pairs.area * weight

    # -- the step ------------------------------------------------------------------------
    def predict(self, step) -> None:
        """Contact-stabilized predictor: the closest admissible u~ in the mass norm,
        u~ + M^-1 G^T mu with mu >= 0, g(u~) + G M^-1 G^T mu >= 0, complementary. Without it,
        enforcing the gap at t_n+1 inside Newmark/HHT makes contact chatter and the energy
        grow (DESIGN.md, "Energy in dynamic contact")."""
        if self.mass_compliance is None or step.u_tilde is None:
            return
        t0 = time.perf_counter()
        self.impulse[:] = 0.0
        p = self.problem
        full = np.zeros(p.n_dofs)
        full[p.fixed] = p.fixed_values(step.t)
        full[step.free] = step.u_tilde
        x = p.points + full.reshape(-1, 3)
        pairs, weight, offset = self._detect(x)
        if len(pairs):
            G = pairs.constraint_matrix(p.n_points)
            W = self.mass_compliance.delassus(G)
            from . import active_set

            # Every method keeps its own law here (Lagrange: the exact projection; penalty and
            # Uzawa: their penalty, augmentations included), or the projection would enforce the
            # gap exactly and kappa would no longer control the overlap. Over the predictor's
            # h^2 (1/2 - beta), a pair force f moves u~ by M^-1 G^T f times that, so the pair
            # stiffness is scaled by it.
            integ = self.problem.integrator
            scale = integ.h**2 * (0.5 - integ.beta)
            mu, info = self.method.solve(W, pairs.gap, scale * self._stiffness(pairs, x, weight), final=False)
            hard = self.method.constraint
            if not info.converged and self.config["strict"]:
                self._fail(step, pairs, mu, info)
            if mu.any():
                du = self.mass_factor.solve((G.T @ mu)[step.free])
                step.u_tilde += du
                moved = float(np.abs(du).max())
                if moved > 0.5 * self.h_surface and not self._warned.get("predictor"):
                    self._warned["predictor"] = True
                    warnings.warn(
                        f"t = {step.t:.6g}: the stabilized predictor moved contact nodes by {moved:.3g} m, more "
                        f"than half the surface element size ({self.h_surface:.3g} m): the step is too large for "
                        "this impact speed: the first element layer is crushed in one step (a penalty can then "
                        "return more energy than came in, and every method loses accuracy). Use a smaller time step.",
                        VfrsWarning, stacklevel=2)
                # The pairs the projection closed must not keep approaching: the predicted
                # normal velocity is projected too (same mass norm, on those pairs only).
                # Otherwise a node resting in contact keeps the velocity -(1 - gamma) h a of
                # the start-of-step acceleration forever, and damping acts on it.
                on = np.flatnonzero(mu > 0) if hard else np.zeros(0, dtype=np.int64)
                full[:] = 0.0
                full[step.free] = step.v_tilde
                vn = G[on] @ full
                if on.size and (vn < 0).any():
                    nu, _ = active_set.lagrange(W[np.ix_(on, on)], vn, max_iterations=self.config["max_iterations"])
                    if nu.any():
                        impulse = G[on].T @ nu  # momentum given to the nodes (N s)
                        step.v_tilde += self.mass_factor.solve(impulse[step.free])
                        self.impulse += impulse
        self.seconds += time.perf_counter() - t0

    def correct(self, step) -> None:
        t_start = time.perf_counter()
        p = self.problem
        static = step.u_tilde is None
        fixed_u = p.fixed_values(step.t, static=static)
        u0 = step.u.copy()
        free = step.free
        full = np.zeros(p.n_dofs)
        full[p.fixed] = fixed_u

        def positions(u_free):
            full[free] = u_free
            return p.points + full.reshape(-1, 3)

        for d in self.detectors:
            if isinstance(d, InterfaceMesh):
                d.update(self.x_prev)
        f_applied = np.zeros(p.n_dofs)
        info_total = None
        loaded_prev = None
        lam = np.zeros(0)
        pairs = ContactPairs.empty()
        offset = np.zeros(0)
        carried = None
        settled = False
        for detection in range(1, self.config["max_detections"] + 1):
            x = positions(step.u)
            G = None  # this round's constraint matrix, kept for the record
            pairs, weight, offset = self._detect(x)
            if detection > 1 and carried is not None:
                pairs, weight, offset = self._merge(carried, pairs, weight, offset, x, p.n_points)
            if not self.method.applies_forces or len(pairs) == 0:
                lam = np.zeros(len(pairs))
                if f_applied.any():
                    step.add_force(-f_applied, transient=self.transient)
                    f_applied[:] = 0.0
                settled = True
                break
            G = pairs.constraint_matrix(p.n_points)
            Gf = G[:, free]
            # Gaps of the contact-free solution with this geometry frozen.
            g0 = pairs.gap - Gf @ (step.u - u0)
            k = self._stiffness(pairs, x, weight)
            if self.config["solver"] == "refactor":
                lam, info = self._refactor_penalty(step, Gf, g0, k, u0)
            else:
                W = self.compliance.delassus(G, step.force_scale)
                lam, info = self.method.solve(W, g0, k)
            info_total = info
            if not info.converged and self.config["strict"]:
                self._fail(step, pairs, lam, info)
            f_new = G.T @ lam
            step.add_force(f_new - f_applied, transient=self.transient)
            f_applied = f_new
            # Loaded pairs stay in the next round even if they no longer penetrate (the
            # interface mesh reports inverted tets only, and enforcement brings them to g = 0).
            carried = (pairs.select(lam > 0), weight[lam > 0], offset[lam > 0])
            loaded = set(zip(pairs.slave[lam > 0].tolist(), pairs.triangle[lam > 0].tolist()))
            if loaded == loaded_prev:
                settled = True
                break
            loaded_prev = loaded
        # Re-detection that does not settle (pairs flickering at the rim of the contact
        # zone) is reported in the history ("contact_settled" = 0), not raised.
        x = positions(step.u)
        if self.config["detection"] == "bvh" and self.method.applies_forces:
            moved = float(np.linalg.norm(x[self.plane_nodes] - self.x_prev[self.plane_nodes], axis=1).max())
            if moved > self.search and not self._warned.get("motion"):
                self._warned["motion"] = True
                warnings.warn(
                    f"t = {step.t:.6g}: contact-surface nodes moved {moved:.3g} m in one step, more than the "
                    f"BVH search distance {self.search:.3g} m: a surface crossed between two steps is not seen. "
                    'Use detection = "interface_mesh", a larger search_distance or a smaller time step.',
                    VfrsWarning, stacklevel=2)
        self.x_prev = x.copy()
        # What the history, the probes and the field output call the contact force: the
        # momentum contact gave each node in this step, over h (see setup).
        self.force_full = self.force_weight * f_applied
        if self.stabilized:
            self.force_full = self.force_full + self.impulse / self.h
        if self.method.applies_forces:
            step.implicit_by_effect[self.name] = self.force_full.copy()
        self.last = (pairs, lam, info_total, x, detection, offset, settled, G)
        self.converged = bool(settled and (info_total is None or info_total.converged))
        self.seconds += time.perf_counter() - t_start

    def step_index(self, step) -> int:
        h = getattr(self.problem.integrator, "h", None)
        if h:
            return int(round(step.t / h))
        # Static runs: t is the load factor k / load_steps.
        n = getattr(self.problem.scene.time, "load_steps", None)
        return int(round(step.t * n)) if n else -1

    def _fail(self, step, pairs, lam, info):
        nodes = sorted(set(pairs.slave[lam > 0].tolist()))[:10]
        if "max_gap_violation" in info.extra and "gap_tol" in info.message:
            scale = f" (the surfaces' contact stiffness scale E/h is about {self.kappa_scale:.1e} Pa/m)" if self.kappa_scale else ""
            hint = (f"Try more max_augmentations, a larger kappa{scale}, a larger gap_tol, or strict = false "
                    "to record and continue.")
        else:
            hint = "Try a smaller time step or kappa, more max_iterations, or strict = false to record and continue."
        raise ConvergenceError(
            f"step {self.step_index(step)}, t = {step.t:.6g}: {self.config['method']} did not converge: "
            f"{info.message}; slave nodes involved {nodes}. {hint}"
        )

    def _refactor_penalty(self, step, Gf, g0, k, u0):
        """Reference path: refactor K_eff + s G_A^T diag(k) G_A on the penalty active set."""
        from ..linalg import cholesky
        from .base import SolveInfo

        integ = self.problem.integrator
        K = integ.K_eff if hasattr(integ, "K_eff") else integ.K
        s = step.force_scale
        r = K @ u0
        active = g0 < 0
        seen = set()
        info = SolveInfo()
        lam = np.zeros(len(g0))
        for it in range(1, self.config["max_iterations"] + 1):
            key = active.tobytes()
            if key in seen:
                info.converged, info.cycle, info.message = False, True, "penalty active set cycles (refactor path)"
                break
            seen.add(key)
            GA = Gf[np.flatnonzero(active)]
            kA = k[active]
            A = (K + s * (GA.T @ sp.diags(kA) @ GA)).tocsr()
            rhs = r + s * (GA.T @ (kA * (GA @ u0 - g0[active])))
            u = cholesky(A).solve(rhs)
            g = g0 + Gf @ (u - u0)
            lam = np.where(active, k * np.maximum(-g, 0.0), 0.0)
            info.iterations = it
            new = g < 0
            if np.array_equal(new, active):
                break
            active = new
        else:
            info.converged = False
            info.message = f"penalty active set not settled in {self.config['max_iterations']} iterations (refactor path)"
        return lam, info

    # -- diagnostics ---------------------------------------------------------------------
    def record(self, state, history) -> None:
        p = self.problem
        h = history
        if self.last is None:
            # The initial row: detection only (no forces yet), so that a body starting inside
            # another shows its penetration from t = 0.
            x = state.points
            pairs, _, offset = self._detect(x)
            lam, info, n_det, settled, G = np.zeros(len(pairs)), None, 0, True, None
        else:
            pairs, lam, info, x, n_det, offset, settled, G = self.last
        # Gaps at the final positions, with the pairs' frozen geometry (G from the step's last
        # round when it built one).
        if len(pairs):
            if G is None:
                G = pairs.constraint_matrix(p.n_points)
            gap = G @ x.ravel() - offset
        else:
            gap = np.zeros(0)
        loaded = lam > 0
        h.setdefault("contact_pairs", []).append(len(pairs))
        h.setdefault("active_pairs", []).append(int(loaded.sum()))
        h.setdefault("iterations", []).append(info.iterations if info else 0)
        h.setdefault("augmentations", []).append(info.augmentations if info else 0)
        h.setdefault("detections", []).append(n_det)
        h.setdefault("contact_settled", []).append(int(settled))
        h.setdefault("contact_converged", []).append(int(getattr(self, "converged", True)))
        # Work of the contact forces on the bodies (trapezoidal in time): lets an energy
        # balance separate contact from the loads (external_work includes both).
        f_now = self.force_full
        if self._work_state is not None:
            x_old, f_old = self._work_state
            self._contact_work += 0.5 * float(np.sum((f_old + f_now) * (x.ravel() - x_old)))
        self._work_state = (x.ravel().copy(), f_now.copy())
        h.setdefault("contact_work", []).append(self._contact_work)
        h.setdefault("max_penetration", []).append(float(np.maximum(-gap, 0.0).max()) if len(gap) else 0.0)
        h.setdefault("intersection_volume", []).append(self._intersection_volume(x, pairs, gap))
        h.setdefault("condition", []).append(info.condition if info else 1.0)
        f = self.force_full.reshape(-1, 3)
        for part in p.bodies:
            h.setdefault(f"contact_force.{part.name}", []).append(f[part.nodes].sum(axis=0))
        loaded_nodes = np.flatnonzero(np.abs(f).sum(axis=1) > 0)
        area = 0.0
        for tri in self.surface_of.values():
            area += contact_area(x, tri, loaded_nodes) if loaded_nodes.size else 0.0
        h.setdefault("contact_area", []).append(area)
        # Cumulative right-hand sides solved for the compliance columns (the reduced
        # space's cost: one solve per contact DOF the first time a pair touches it).
        h.setdefault("compliance_solves", []).append(
            sum(c.solves for c in (self.compliance, self.mass_compliance) if c is not None)
        )
        for i, n in enumerate(self.probe_nodes):
            h.setdefault(f"contact_force_probe.{i}", []).append(f[n].copy())

    def _intersection_volume(self, x, pairs, gap) -> float:
        if self.config["detection"] == "interface_mesh":
            return float(sum(d.intersection_volume(x) for d in self.detectors))
        w = np.where(pairs.triangle >= 0, self.pair_weight, 1.0) if len(pairs) else np.zeros(0)
        return float(np.sum(w * pairs.area * np.maximum(-gap, 0.0))) if len(gap) else 0.0

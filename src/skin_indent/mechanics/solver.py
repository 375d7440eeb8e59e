"""Incremental Newton solution of the indentation problem under depth control.

:class:`IndentationProblem` joins the body (:class:`~.axisymmetric.AxisymmetricSolid`),
the contact (:class:`~.contact.SphereContact`) and the boundary conditions, and
:meth:`IndentationProblem.solve` pushes the sphere through a list of depths. The
first increment from the undeformed body starts from Hertz's shape
(:func:`~.predictor.hertz_start`, frictionless contact), the others from the
self-similar image of the previous states (geometric depths) or a linear
extrapolation, with the contact zone of the last state kept against the sphere on
loading steps (:class:`~.predictor.SurfaceFit`). Newton's method evaluates the
residual first and the consistent tangent only when it goes on; close to the
solution (relative residual below ``modified_below`` and falling tenfold per
iteration) it keeps the last tangent and its factorisation (modified Newton). It
shortens a step that overshoots the minimum
of the potential along the Newton direction (a line search on its directional
derivative), and halves the increment when Newton fails (an elastic,
frictionless body then keeps the depth step that converged for the next increments,
see :data:`EASY_ITERATIONS`). When even small increments fail,
:class:`ConvergenceError` says where and why. An iterate converges when its residual
relative to the forces is below ``rtol``, or, for a tolerance float64 cannot attain, when it
is within the residual's round-off floor and the Newton increment is negligible
(:func:`~.convergence.newton_converged`). On the default mesh a 12-increment
curve takes ~2.7 Newton iterations per increment, ~9 LU factorisations and ~24
solves by conjugate gradients preconditioned with an earlier factorisation
(:class:`~.linear.TangentSolver`).

With friction or adhesion (never for the frictionless, non-adhesive contact), a
reversal of the sphere (first unloading step) is predicted along the last increment
backwards instead of from the deepest state, a trial step whose residual is not
finite (inverted elements, typically at first touch with adhesion) is halved instead
of ending the increment, and the non-symmetric frictional tangents are solved by
:class:`~.linear.FrictionalTangentSolver`.
"""

from __future__ import annotations

import math
import time
import numpy as np

from .axisymmetric import AxisymmetricSolid, SparsityPattern
from .contact import SphereContact
from .contact_law import ContactLaw, SphericalIndenter
from .convergence import ConvergenceError, NewtonReport, newton_converged, roundoff_floor
from .layers import SQUEEZE_FROM, ConfinedPenalty, LayeredSample
from .linear import FrictionalTangentSolver, TangentSolver
from .materials import Material
from .predictor import SimilarityPredictor, SurfaceFit, hertz_start
from .mesh import IndentationMesh


#: A new tangent is factorised at once, without first trying conjugate gradients
#: preconditioned with the stored factorisation, when more contact quadrature points than
#: this changed state (touching or not) since that factorisation. Measured on the default
#: mesh: such preconditioned solves failed (12 iterations without converging, then a
#: factorisation anyway) in 67 % of the cases on a half-space and 83 % on a layer on a
#: rigid base, against 4 % and 14 % when at most this many changed.
REFACTORISE_AFTER_CONTACT_CHANGES = 10
#: Elastic, frictionless problems: after an increment fails, the halved depth step (a
#: fraction 1/2^k of the requested depth's range) is kept for the next increments, also
#: toward the next requested depth, and doubled again only after an increment that needed
#: at most :data:`EASY_ITERATIONS` Newton iterations. Before, every increment after a cut
#: tried twice the last step, and every requested depth first the whole range: on a 1 mm
#: layer on a rigid base pressed to 0.6 mm (60 % compressed) one attempt in two failed
#: (15 cuts in 27 increments). The step is never below 1/2^max_cuts of a range, so each
#: depth is reached in a bounded number of increments or the solve stops with
#: :class:`ConvergenceError`. A curve that never fails is solved exactly as before.
EASY_ITERATIONS = 3


class IndentationProblem:
    """A rigid sphere pressed into an axisymmetric body, ready to be solved.

    Parameters
    ----------
    imesh : IndentationMesh
        Mesh of the truncated half-space (lengths in mm).
    material : Material or None
        Constitutive law of the whole body, or None when ``regions`` is given.
    indenter : SphericalIndenter
    max_depth_mm : float
        Largest depth that will be applied, mm.
    penalty : float
        Dimensionless penalty factor: epsilon = penalty * E_ref / a (kPa/mm), with
        ``a = sqrt(R h_max)`` the design contact radius of the mesh. Independent of
        the element size, so a mesh-convergence study sees discretisation error only.
        For layers on a rigid base (frictionless contact) it is multiplied by a factor
        of the depth (:class:`ConfinedPenalty`).
    regions : sequence of (element indices, Material), optional
        Materials per element group (layered bodies).
    rtol : float
        Newton tolerance on the free residual relative to the larger of the internal and
        contact force vectors. Below the residual's round-off floor (``roundoff_floor``), an
        iterate at that floor whose Newton increment is negligible is accepted instead
        (:func:`~.convergence.newton_converged`): any tolerance converges, on any floating-point path.
    max_iterations : int
        Newton iterations allowed per increment before it is cut.
    max_cuts : int
        How often one increment may be halved before giving up.
    modified_below : float
        Relative residual below which (while it falls tenfold per iteration) Newton
        reuses the last tangent and its factorisation instead of assembling a new one;
        0 disables it. The converged state meets the same tolerance either way.
    bottom : {"clamped", "rigid-base"}
        Bottom boundary condition (both fix u_r and u_z on z = -L).
    contact : ContactLaw, optional
        Friction and adhesion between sphere and body (default frictionless,
        non-adhesive). Friction is history dependent: solve every depth in order.
    """

    def __init__(self, imesh: IndentationMesh, material: Material | None, indenter: SphericalIndenter,
                 max_depth_mm: float, penalty: float = 1.2e4, regions=None, rtol: float = 1e-6,
                 max_iterations: int = 25, max_cuts: int = 8, contact: ContactLaw | None = None,
                 modified_below: float = 1e-3):
        self.imesh = imesh
        self.indenter = indenter
        self.solid = AxisymmetricSolid(imesh.mesh, material, regions=regions)
        e_ref = max(m.reference_modulus for _, m in self.solid.regions)
        a = math.sqrt(indenter.radius_mm * max_depth_mm)
        # residual scale when nothing touches the sphere (unloading): a tiny force ~ E a^2
        self.force_floor = 1e-9 * e_ref * a**2
        self.contact = SphereContact(imesh.mesh, indenter, max_depth_mm, penalty * e_ref / a,
                                     small_strain=self.solid.small_strain, law=contact)
        #: the depth-dependent factor of the penalty of layers on a rigid base (frictionless,
        #: non-adhesive contact), else None
        self.penalty_scale = None
        law = self.contact.law
        if (isinstance(material, LayeredSample) and material.rigid_base and not (law.frictional or law.adhesive)
                and max_depth_mm > SQUEEZE_FROM * material.total_thickness_mm):
            # only for a layer pressed into its squeezed regime: thicker ones keep the half-space's
            # penalty exactly (the factor's kink at 1, crossed within a curve and moving with nu,
            # left a two-layer fit in the loop on a 3.3 mm stack short of the noise)
            self.penalty_scale = ConfinedPenalty(material, indenter.radius_mm, e_ref)
            self.contact.penalty_scale = self.penalty_scale
        b = self.solid.basis
        fixed = np.zeros(b.N, dtype=bool)
        fixed[b.get_dofs("axis").all("u^1")] = True
        fixed[b.get_dofs("outer").all("u^1")] = True
        fixed[b.get_dofs("bottom").all()] = True
        self.free = ~fixed
        self.pattern = SparsityPattern(self.solid.element_dofs, self.free)
        self.pattern.register(self.contact.element_dofs)
        self.rtol = rtol
        self.linear_solver = (TangentSolver() if self.contact.symmetric_tangent else FrictionalTangentSolver())
        #: (factorisation count, contact points touching) when Newton last factorised a tangent
        self._factorised = None
        self.max_iterations = max_iterations
        #: below this relative residual (and while it drops 10x per iteration) Newton
        #: keeps the last tangent and its factorisation instead of assembling a new one
        self.modified_below = modified_below
        self.max_cuts = max_cuts
        # frictionless, non-adhesive contact: exactly the original iteration
        self._plain_contact = not (self.contact.law.frictional or self.contact.law.adhesive)
        # the u_z dof of the surface point on the axis (the tip of the indentation)
        top_z = b.get_dofs("top").all("u^2")
        on_axis = top_z[np.isclose(b.doflocs[0, top_z], 0.0) & np.isclose(b.doflocs[1, top_z], 0.0)]
        self.axis_top_dof = int(on_axis[0]) if on_axis.size else None
        self._surface_fit = SurfaceFit(self.solid, indenter, self.free, small_strain=self.solid.small_strain)

    @property
    def n_dofs(self) -> int:
        return self.solid.n_dofs

    def _evaluate(self, u, depth, tangent=True):
        # trial states may invert elements (J <= 0): the residual is then not finite
        # and the iteration fails cleanly (step cut) instead of warning
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            f_int, Ke = self.solid.forces(u, tangent)
            f_c, Kc, force = self.contact.forces(u, depth, tangent)
        return f_int, Ke, f_c, Kc, force

    def _residual(self, u, depth):
        """Internal and contact force vectors (mN) and the force on the sphere, without tangents."""
        f_int, _, f_c, _, force = self._evaluate(u, depth, tangent=False)
        return f_int, f_c, force

    def _tangent(self, u, depth, contact_tangent=True):
        """Assembled tangent over the free dofs at ``u`` (after :meth:`_residual` at the same ``u``:
        the solid reuses its kinematics)."""
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            Ke = self.solid.tangent(u)
            Kc = self.contact.forces(u, depth, tangent=contact_tangent)[1]
        return self.pattern.assemble([(self.solid.element_dofs, Ke), (self.contact.element_dofs, Kc)])

    def _active_points(self, u, depth):
        """Contact quadrature points touching the sphere at ``u`` (frictionless contact), else None."""
        return self.contact.state(u, depth).pressure_kPa > 0 if self._plain_contact else None

    def roundoff_floor(self, u: np.ndarray, depth: float, active=None) -> float:
        """Norm of the round-off (mN) that the residual carries at ``u`` (after :meth:`_residual` at ``u``),
        the floor of :func:`~.convergence.newton_converged`: see :func:`~.convergence.roundoff_floor`.
        ``active``: the touching contact quadrature points, if known."""
        return roundoff_floor(self.solid, self.contact, u, depth, self.free, active)

    def _contact_set_moved(self, active) -> bool:
        """Whether more than :data:`REFACTORISE_AFTER_CONTACT_CHANGES` contact points (``active``: the
        touching ones now) changed state since the stored factorisation was computed in Newton."""
        stored = self._factorised
        if active is None or stored is None or stored[0] != self.linear_solver.factorisations:
            return False
        return int(np.count_nonzero(active != stored[1])) > REFACTORISE_AFTER_CONTACT_CHANGES

    def _directional(self, u, du, alpha, depth):
        """Directional derivative of the potential, du . r(u + alpha du), on the free dofs."""
        f_int, f_c, _ = self._residual(u + alpha * du, depth)
        return float((f_int + f_c)[self.free] @ du[self.free])

    def _line_search(self, u, du, g0, g1, depth, report):
        """Step length where the directional derivative of the potential has dropped.

        Uses only internal forces (no energy values, whose round-off on a 1000 mm
        mesh exceeds the changes near convergence): regula falsi on
        g(alpha) = du . r(u + alpha du) between g(0) < 0 and g(1) > 0.
        """
        lo, g_lo, hi, g_hi = 0.0, g0, 1.0, g1
        alpha, side = 1.0, 0
        for _ in range(8):
            alpha = lo - g_lo * (hi - lo) / (g_hi - g_lo)
            g = self._directional(u, du, alpha, depth)
            report.line_search_backtracks += 1
            if abs(g) <= 0.5 * abs(g0):
                break
            if g < 0:  # Illinois: halve the weight of the end point kept twice in a row
                lo, g_lo = alpha, g
                if side == -1:
                    g_hi *= 0.5
                side = -1
            else:
                hi, g_hi = alpha, g
                if side == 1:
                    g_lo *= 0.5
                side = 1
        return alpha

    def _newton(self, u: np.ndarray, depth: float, report: NewtonReport):
        """Newton iterations at fixed depth from the predictor ``u`` (modified in place).

        Residuals are evaluated first and the tangent only when the iteration goes
        on (no tangent at converged states or at rejected trial steps).
        """
        free = self.free
        f_int, f_c, force = self._residual(u, depth)
        rel, K = np.inf, None
        for it in range(self.max_iterations + 1):
            r = (f_int + f_c)[free]
            ref = max(np.linalg.norm(f_c[free]), np.linalg.norm(f_int[free]), self.force_floor,
                      1e-3 * self.solid.gross_force)
            rel_before, rel = rel, np.linalg.norm(r) / ref
            if newton_converged(rel, self.rtol):
                return True, it, rel, force
            if it == self.max_iterations or not np.isfinite(rel):
                break
            active = self._active_points(u, depth)
            fresh = False
            if K is not None and rel < self.modified_below and rel < 0.1 * rel_before:
                # close to the solution and converging: keep the tangent of the last
                # iterate and its factorisation (a modified-Newton step, no assembly)
                report.modified_steps += 1
            else:
                K = self._tangent(u, depth)
                report.tangents += 1
                fresh = self._contact_set_moved(active)
            factorisations = self.linear_solver.factorisations
            try:
                # inexact Newton: the linear residual need only be small next to Newton's own
                du_free = self.linear_solver.solve(K, -r, rtol=min(1e-3, max(1e-2 * rel, 1e-10)), refactorise=fresh)
            except RuntimeError:  # singular tangent
                break
            if self.linear_solver.factorisations > factorisations:
                self._factorised = (self.linear_solver.factorisations, active)
            norm_u = float(np.linalg.norm(u[free]))
            if norm_u > 0 and newton_converged(rel, self.rtol, self.roundoff_floor(u, depth, active) / ref,
                                               float(np.linalg.norm(du_free)) / norm_u):
                # stagnation at round-off: the increment would move the state within it
                report.roundoff_stops += 1
                return True, it, rel, force
            du = np.zeros_like(u)
            du[free] = du_free
            g0 = float(r @ du_free)
            if not g0 < 0 and self.contact.convex_fallback:  # adhesion: retry with a positive-definite tangent
                K = self._tangent(u, depth, contact_tangent="convex")
                du_free = self.linear_solver.solve(K, -r, rtol=min(1e-3, max(1e-2 * rel, 1e-10)))
                du[free] = du_free
                g0 = float(r @ du_free)
            if not g0 < 0:  # not a descent direction: the tangent is not positive definite here
                # (a non-symmetric, frictional tangent has no potential to descend: go on)
                if self.contact.symmetric_tangent or not np.isfinite(g0):
                    break
            f_int, f_c, force = self._residual(u + du, depth)
            g1 = float((f_int + f_c)[free] @ du_free)
            if not self._plain_contact:  # a trial state that inverts elements: shorten the step
                for _ in range(12):
                    if np.isfinite(g1):
                        break
                    du *= 0.5
                    du_free = du[free]
                    report.line_search_backtracks += 1
                    f_int, f_c, force = self._residual(u + du, depth)
                    g1 = float((f_int + f_c)[free] @ du_free)
            if g0 < 0 and g1 > 0.9 * abs(g0):  # overshoot: by the trapezoid rule the potential did not decrease
                alpha = self._line_search(u, du, g0, g1, depth, report)
                f_int, f_c, force = self._residual(u + alpha * du, depth)
                du *= alpha
            elif not self.contact.symmetric_tangent:  # frictional: halve steps that raise the residual
                alpha = 1.0
                while np.linalg.norm((f_int + f_c)[free]) > np.linalg.norm(r) and alpha > 0.02:
                    alpha *= 0.5
                    report.line_search_backtracks += 1
                    f_int, f_c, force = self._residual(u + alpha * du, depth)
                du *= alpha
            u += du
        return False, it, rel, force

    def _check_times(self, times_s, depths):
        """Times with the start state prepended: ``times[0]`` is the time of depth 0."""
        if times_s is None:
            if not self.solid.path_independent:
                raise ValueError("a history-dependent (e.g. viscoelastic) model needs the times of the depths")
            return np.arange(depths.size + 1, dtype=float)
        t = np.asarray(times_s, dtype=float)
        if t.shape != depths.shape or not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise ValueError("times must be finite, non-decreasing and one per depth")
        # the sphere starts at depth 0; the first step lasts as long as the second (or 0)
        dt0 = t[1] - t[0] if t.size > 1 else 0.0
        return np.concatenate([[t[0] - dt0 if t[0] - dt0 >= 0 else 0.0], t])

    def _predict(self, u, u_prev, h_prev, h_cur, h_try, similarity):
        """First iterate at depth ``h_try`` from the converged states at ``h_cur`` and ``h_prev``."""
        trial = self._extrapolate(u, u_prev, h_prev, h_cur, h_try, similarity)
        if self._plain_contact:  # loading: the contact zone kept against the sphere (predictor.SurfaceFit)
            trial = self._surface_fit(trial, u, h_cur, h_try)
        return trial

    def _extrapolate(self, u, u_prev, h_prev, h_cur, h_try, similarity):
        if similarity is not None and h_cur > 0 and np.isclose(h_try / h_cur, similarity.ratio, rtol=1e-9):
            geometric = u_prev is not None and h_prev > 0 and np.isclose(h_cur / h_prev, similarity.ratio, rtol=1e-9)
            return similarity(u, u_prev if geometric else None)
        if u_prev is not None and h_cur != h_prev and (h_try - h_cur) * (h_cur - h_prev) > 0:
            return u + (u - u_prev) * ((h_try - h_cur) / (h_cur - h_prev))
        if (not self._plain_contact and u_prev is not None and h_cur != h_prev
                and 0 < (h_try - h_cur) / (h_prev - h_cur) <= 1):
            # reversal (friction, adhesion): back along the last increment, towards the previous
            # state (for an elastic, frictionless body exactly the unloading path)
            return u + (u_prev - u) * ((h_try - h_cur) / (h_prev - h_cur))
        return u.copy()

    def solve(self, depths_mm, progress=None, predictor: str = "auto", times_s=None, on_converged=None,
              initial=None):
        """Move the sphere through ``depths_mm`` and return the forces.

        Parameters
        ----------
        depths_mm : array_like
            Depths at which the state is solved and the force recorded, mm (any
            sequence: loading, holds and unloading; contact is lost when the
            surface no longer touches the sphere).
        times_s : array_like, optional
            Times of the depths, s, non-decreasing (required for history-dependent
            laws; the time steps drive their evolution). The body starts at rest at
            depth 0, one time step before ``times_s[0]`` (or at ``times_s[0]`` = 0).
        progress : callable, optional
            Called as ``progress(i)`` after each requested depth.
        predictor : {"auto", "linear", "similarity"}
            First iterate of each increment: linear extrapolation in depth, or the
            self-similar map of :mod:`.predictor` (needs geometrically spaced depths;
            "auto" uses it when they are, and for the steps of the common ratio when
            increasing depths start with three such steps).
        on_converged : callable, optional
            Called as ``on_converged(i, u, depth)`` with the converged displacement
            field ``u`` (mm, not to be modified) at each requested depth (mm), before
            ``progress``; used for the parameter sensitivities
            (:mod:`.sensitivity`).
        initial : sequence, optional
            A first iterate (a displacement field, mm) per requested depth, or None where
            there is none: a warm start, e.g. the converged states of a nearby sample on a
            mesh of the same topology, used instead of the predictor when the depth is
            reached in one step (a step that fails from it is cut and predicted as usual).
            Only for path-independent problems (elastic laws, no friction): the state at a
            depth is then a function of that depth alone, and the solution is the one of
            the predictor's path to the Newton tolerance.

        Returns
        -------
        forces : ndarray
            Force on the sphere at each depth, mN.
        u : ndarray
            Final displacement field, mm.
        report : NewtonReport
        """
        depths = np.asarray(depths_mm, dtype=float)
        times = self._check_times(times_s, depths)
        if initial is not None:
            if not self.solid.path_independent or self.contact.law.frictional:
                raise ValueError("a warm start (initial) needs a path-independent problem (elastic, no friction)")
            if len(initial) != depths.size:
                raise ValueError(f"initial must hold one field (or None) per depth: {len(initial)} for {depths.size}")
            if any(u0 is not None and np.shape(u0) != (self.n_dofs,) for u0 in initial):
                raise ValueError(f"initial fields must have {self.n_dofs} values (this mesh's degrees of freedom)")
        if predictor not in ("auto", "linear", "similarity"):
            raise ValueError(f"predictor must be 'auto', 'linear' or 'similarity', got {predictor!r}")
        # frictionless, non-adhesive contact: the first increment from the undeformed
        # body starts from Hertz's shape (see predictor.hertz_start)
        start = predictor != "linear" and self._plain_contact and self.axis_top_dof is not None
        similarity = None
        with np.errstate(divide="ignore", invalid="ignore"):
            ratios = depths[1:] / depths[:-1]
        geometric = (self.solid.path_independent and ratios.size > 0 and np.all(depths > 0)
                     and np.allclose(ratios, ratios[0], rtol=1e-9) and ratios[0] > 1)
        if predictor == "similarity" and not geometric:
            raise ValueError("the similarity predictor needs geometrically spaced depths")
        # loading depths whose first steps share one ratio, with other depths after them (the extra
        # depths of a layer squeezed on a rigid base): the steps of that ratio use the map too
        leading = (predictor == "auto" and not geometric and self.solid.path_independent and ratios.size > 2
                   and np.all(depths > 0) and np.all(ratios > 1) and ratios[0] > 1
                   and np.allclose(ratios[:3], ratios[0], rtol=1e-9))
        if predictor != "linear" and (geometric or leading):
            similarity = SimilarityPredictor(self.solid, ratios[0], self.free)
        t0 = time.perf_counter()
        factorisations0, cg0 = self.linear_solver.factorisations, self.linear_solver.cg_solves
        report = NewtonReport()
        u = np.zeros(self.n_dofs)
        u_prev, h_prev, h_cur, t_cur = None, 0.0, 0.0, times[0]
        forces = np.empty(depths.size)
        # elastic, frictionless: after a failed increment the halved depth step is kept
        # (also toward the next depth) and doubled again only after an easy increment,
        # instead of trying twice the last step (see EASY_ITERATIONS)
        adaptive = self.solid.path_independent and self._plain_contact
        kept = None  # the reduced depth step the last target ended with (mm), if any
        for i, target in enumerate(depths):
            cuts, span = 0, target - h_cur
            warm = None if initial is None else initial[i]  # tried once: a step that fails from it is cut
            if adaptive and kept is not None and span != 0:  # start from that step, not the whole range
                cuts = min(max(math.ceil(math.log2(abs(span) / kept) - 1e-9), 0), self.max_cuts)
            while True:
                if cuts and adaptive and abs(target - h_cur) > abs(span) / 2**cuts * (1.0 + 1e-9):
                    h_try = h_cur + span / 2**cuts
                    t_try = t_cur + (times[i + 1] - t_cur) * (h_try - h_cur) / (target - h_cur)
                elif cuts and not adaptive:
                    h_try = h_cur + (target - h_cur) / 2**cuts
                    t_try = t_cur + (times[i + 1] - t_cur) / 2**cuts
                else:  # exactly the target (h + (target - h) may differ from it in the last bit)
                    h_try, t_try = target, times[i + 1]
                if warm is not None and h_try == target:
                    trial = np.array(warm, dtype=float)  # a warm start (a copy: Newton updates it)
                    warm = None
                elif start and u_prev is None and h_cur == 0 and h_try > 0 and not np.any(u):
                    trial = hertz_start(self, h_try)
                else:
                    trial = self._predict(u, u_prev, h_prev, h_cur, h_try, similarity)
                self.solid.begin_step(t_try - t_cur)
                self.contact.begin_step(t_try - t_cur)
                ok, its, rel, force = self._newton(trial, h_try, report)
                if ok:
                    self.solid.commit(trial, t_try - t_cur)
                    self.contact.commit(trial, h_try)
                    u_prev, h_prev, h_cur, t_cur, u = u, h_cur, h_try, t_try, trial
                    report.increments += 1
                    report.iterations.append(its)
                    report.residuals.append(rel)
                    if h_cur > 0:
                        pen = self.contact.state(u, h_cur).max_penetration_mm
                        report.max_penetration_ratio = max(report.max_penetration_ratio, pen / h_cur)
                    if not adaptive or its <= EASY_ITERATIONS:
                        cuts = max(cuts - 1, 0)
                    if h_try == target:
                        kept = abs(span) / 2**cuts if cuts else None
                        break
                    continue
                cuts += 1
                report.step_cuts += 1
                if cuts > self.max_cuts:
                    report.wall_time_s = time.perf_counter() - t0
                    raise ConvergenceError(
                        f"Newton did not converge at depth {h_try:.6g} mm (target {target:.6g} mm) after "
                        f"{self.max_cuts} step cuts: relative residual {rel:.2e} > {self.rtol:.0e}"
                    )
            forces[i] = force
            if on_converged is not None:
                on_converged(i, u, float(h_cur))
            if progress is not None:
                progress(i)
        report.wall_time_s = time.perf_counter() - t0
        report.factorisations = self.linear_solver.factorisations - factorisations0
        report.preconditioned_solves = self.linear_solver.cg_solves - cg0
        return forces, u, report

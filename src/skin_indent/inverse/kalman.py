"""Extended Kalman filters over a force-depth curve (Delalleau et al. 2006, Sec. 2.3-2.4).

The unknown parameters are a static state: ``x_n = x_{n-1}`` (F = I, process noise
Q, zero by default). Each measured point (h_n, F_n) is one scalar measurement
``z_n = F_n`` with measurement function ``Hx = F_model(h_n; theta(x))`` and
linearisation ``H = dF_model/dx`` at ``h_n`` (one row of the model Jacobian), fed to
:class:`filterpy.kalman.ExtendedKalmanFilter` ``update(z, HJacobian, Hx)``.

"Global stabilization" (the paper's Fig. 8): sweep forward through the points, then
backward, then forward again, ...; the estimate at the end of a sweep starts the
next one.

Two filters:

:func:`fit_ekf_paper` (:mod:`.kalman_paper`)
    Faithful to the paper: raw (E, nu) state, fixed P0/R, one update per point,
    stop after an odd sweep when every free parameter changed by less than ``tol``
    (absolute) over that sweep.
:func:`fit_ekf`
    Well-conditioned: internal coordinates ``(log E*, nu)`` whitened by the Fisher
    information, P0 from the information and the box, R from the noise level;
    classic (point-linearised) EKF sweeps to get close, then iterated-EKF sweeps
    (each a damped Gauss-Newton step) to land on the least-squares optimum. A
    handful of sweeps suffice.

Both keep the model inside its box: whenever the model is evaluated at the state,
the state was projected (clipped) into the box after the previous update. Both run the
filter of :mod:`._ekf` (the filter, the order of the sweeps and what they record).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping

import numpy as np

from ._coords import Coordinates
from ._ekf import SweepRecorder, make_filter, sweep_order
from ._units import in_force_units
from ._problem import make_problem
from .kalman_paper import PAPER_MEASUREMENT_STD_MN, PAPER_P0_STD, fit_ekf_paper
from .noise import estimate_noise
from .result import IdentificationResult, build_result

__all__ = ["fit_ekf_paper", "fit_ekf", "PAPER_P0_STD", "PAPER_MEASUREMENT_STD_MN", "BOX_PRIOR_SPANS"]

#: fit_ekf: prior standard deviation of each internal coordinate, in box spans (weak; it
#: only keeps P0 finite along directions the data do not determine).
BOX_PRIOR_SPANS: float = 3.0


@in_force_units
def fit_ekf(model, depth, force, x0, *, fixed: Mapping[str, float] | None = None,
            noise_mN: float | None = None, tol: float = 1e-6, max_sweeps: int = 20,
            coordinates: str = "auto", prior_weight: float = 0.01, linearization: str = "hybrid",
            covariance: str = "filter") -> IdentificationResult:
    """A well-conditioned EKF: whitened (log E*, nu) state, P0 and R from the data.

    At the start of every sweep, around the current estimate ``x_c``:

    1. internal coordinates ``u`` (``coordinates="auto"``: ``(log E*, nu)``,
       ``E* = E/(1-nu^2)``, which straightens the Hertz E-nu valley; log of other
       moduli), Jacobian ``J_u`` of the whole curve (one model call);
    2. ``R_k = max(noise_mN^2, mean misfit^2 at x_c)``: the noise level (given, else
       :func:`estimate_noise` of the data), or the current misfit while that is
       larger. Far from the solution a single point can have an innovation of
       10^5 sigma on noise-free data; treating the misfit as noise keeps each
       update within the validity of the linearisation (the role the damping
       plays in Levenberg-Marquardt). At convergence R_k = noise_mN^2 unless the
       model misfits;
    3. information ``I = J_u^T J_u / R_k``; prior information
       ``P0^-1 = prior_weight * I + diag(1 / (3 span_u)^2)`` (span_u = the box in
       u; :data:`BOX_PRIOR_SPANS` = 3 keeps P0 finite where the data say nothing);
    4. whitened state ``s = L^-1 (u - u_c)`` with ``P0 = L L^T``, so the filter
       starts at s = 0, P = I and every direction is equally well scaled;
    5. one filterpy ``update`` per point, sweeps alternating direction like the
       paper's global stabilization.

    ``linearization`` decides where H and Hx are evaluated:

    ``"point"``
        the classic EKF: the model at the running state (projected into the box
        after every update). Robust far from the solution, but the result depends
        on the processing order: on noisy data forward and backward sweeps settle
        on two different points (up to ~1 standard error apart at 0.1 mN noise) and
        ``tol`` is never met.
    ``"sweep"``
        the iterated EKF in batch form: H and Hx linearised at ``u_c`` for the
        whole sweep. With the prior centred on ``u_c`` a sweep is exactly one
        Gauss-Newton step damped by ``prior_weight`` (Bell & Cathey 1993), so the
        fixed point is the least-squares solution, independent of the order.
        Bounds: coordinates that would leave the box are held on it and the sweep
        is repeated (active set).
    ``"hybrid"`` (default)
        ``"point"`` sweeps until the estimate settles (change within the posterior
        standard deviation or below 1e-3, or 5 sweeps), then ``"sweep"`` sweeps.

    Parameters
    ----------
    model, depth, force, x0, fixed
        As :func:`fit_ekf_paper`.
    noise_mN : float, optional
        Measurement sigma (mN); default estimated from the data (floored at
        ``1e-12 * max|F|`` so that noise-free curves work).
    tol : float
        Stop when every free parameter changed by less than ``tol`` over a sweep, in
        internal units: relative change for log parameters (E), change divided by
        the box span for the others (nu).
    max_sweeps : int
    coordinates : {"auto", "hertz", "log", "linear"}
    prior_weight : float
        Weight of the data information in the prior (0.01 = the prior is 1% of the
        information): the damping of each Gauss-Newton-like sweep.
    linearization : {"hybrid", "point", "sweep"}
    covariance : {"filter", "jacobian"}
        Reported covariance: the final sweep's P mapped back to raw units (default;
        it contains the small prior, so it is ~``prior_weight/2`` too small), or
        ``noise_mN^2 (J^T J)^-1`` at the estimate. Both are in ``info``
        (``covariance_filter``, ``covariance_jacobian``). The filter's uses the
        last ``R_k`` (noise or misfit, whichever is larger: ``info["R_final"]``);
        the Jacobian one uses ``noise_mN`` only, so on a misfitting model it is the
        optimistic one (``chi2 / (n - p) >> 1`` tells). When a parameter ends on a
        bound the Jacobian covariance is reported.

    Returns
    -------
    IdentificationResult
        ``method="ekf"``; ``iterations`` = sweeps; ``history`` in raw units
        (``sweep_covariance`` row k = P after sweep k, row 0 = the first prior;
        ``first_pass`` = the first, point-linearised, sweep);
        ``info["sweep_modes"]`` lists the linearization of every sweep.

    Notes
    -----
    On the paper's blind tests (analytic stand-in, noise-free) it converges to
    ``tol = 1e-6`` in 4-6 sweeps and is within 0.1% in E and 0.002 in nu after
    2-3 sweeps, from every start. On noisy data (0.01-0.5 mN) it reproduces the
    least-squares estimate to < 1e-3 standard errors in 5-9 sweeps.
    """
    problem = make_problem(model, depth, force, x0, fixed)
    names = problem.free_names
    lo, hi = problem.params.free_bounds()
    p, n = len(names), problem.n
    if linearization not in ("hybrid", "point", "sweep"):
        raise ValueError(f"linearization must be 'hybrid', 'point' or 'sweep', got {linearization!r}")
    if covariance not in ("filter", "jacobian"):
        raise ValueError(f"covariance must be 'filter' or 'jacobian', got {covariance!r}")
    if not (tol > 0 and math.isfinite(tol)):
        raise ValueError(f"tol must be a positive number, got {tol}")
    if int(max_sweeps) < 1:
        raise ValueError(f"max_sweeps must be >= 1, got {max_sweeps}")
    if not (prior_weight > 0 and math.isfinite(prior_weight)):
        raise ValueError(f"prior_weight must be positive, got {prior_weight}")
    max_sweeps = int(max_sweeps)
    scale = float(np.max(np.abs(problem.force_mN))) or 1.0
    if noise_mN is None:
        sigma = estimate_noise(problem.depth, problem.force_mN) if n >= 7 else 0.0
        noise_source = "estimated from the data"
    else:
        if not (noise_mN > 0 and math.isfinite(noise_mN)):
            raise ValueError(f"noise_mN must be a positive number, got {noise_mN}")
        sigma, noise_source = float(noise_mN), "given"
    sigma = max(sigma, 1e-12 * scale)
    R = sigma**2

    coords = Coordinates(names, lo, hi, coordinates)
    lo_u, hi_u = coords.bounds
    box_info = np.diag(1.0 / (BOX_PRIOR_SPANS * (hi_u - lo_u)) ** 2)
    u_scale = np.where(coords.is_log, 1.0, hi_u - lo_u)
    z = problem.force_mN
    hs = [problem.depth[i : i + 1] for i in range(n)]
    fr: dict = {}  # the current sweep's frame: u_c, L (u = u_c + L s), C (L^-1 = C^T on the free block)

    def to_u(s):
        return fr["u_c"] + fr["L"] @ s

    def to_s(u):
        return fr["Ct"] @ (u - fr["u_c"])

    def h_jacobian(s, i):  # linearization="point": the model at the current state
        x, dxdu = coords.external(to_u(s))
        return problem.model_jacobian(x, hs[i]) @ dxdu @ fr["L"]

    def h_x(s, i):
        return problem.model_force(coords.external(to_u(s))[0], hs[i])

    def h_jacobian_lin(s, i):  # linearization="sweep": the model linearised at u_c
        return fr["Js"][i : i + 1]

    def h_x_lin(s, i):
        return fr["Fc"][i : i + 1] + fr["Js"][i : i + 1] @ s

    def set_frame(u_c, active):
        """Linearise at u_c; prior over the free (non-active) coordinates only."""
        x_c, dxdu = coords.external(u_c)
        J_u = problem.model_jacobian(x_c) @ dxdu
        F_c = problem.model_force(x_c)
        misfit = z - F_c
        R_k = max(R, float(misfit @ misfit) / n)  # the misfit acts as noise while it exceeds it
        P0_inv = prior_weight * (J_u.T @ J_u) / R_k + box_info
        f = np.flatnonzero(~active)
        Cf = np.linalg.cholesky(P0_inv[np.ix_(f, f)])  # P0_f = L_f L_f^T, L_f = Cf^-T
        L, Ct = np.zeros((p, p)), np.zeros((p, p))
        L[np.ix_(f, f)] = np.linalg.inv(Cf).T  # tiny (p x p) triangular
        Ct[np.ix_(f, f)] = Cf.T
        fr.update(u_c=u_c, L=L, Ct=Ct, Js=J_u @ L, Fc=F_c, R=R_k)
        kf.R = np.array([[R_k]])

    def raw_cov(s, P):
        x, dxdu = coords.external(to_u(s))
        A = dxdu @ fr["L"]
        return x, A @ P @ A.T

    kf = make_filter(p, R)
    rec = SweepRecorder(n, p, max_sweeps)
    x = problem.params.to_array()
    rec.sweeps[0] = x
    status, message, k = 0, f"stopped: max sweeps reached ({max_sweeps})", max_sweeps
    at_bound: list[str] = []
    t0 = time.perf_counter()
    mode = "point" if linearization in ("point", "hybrid") else "sweep"
    modes = []
    for sweep in range(1, max_sweeps + 1):
        hj, hx = (h_jacobian, h_x) if mode == "point" else (h_jacobian_lin, h_x_lin)
        modes.append(mode)
        u_c = coords.internal(x)
        active = np.zeros(p, bool)
        for _ in range(p + 1):  # active set: re-run the sweep with violated bounds held
            set_frame(u_c, active)
            if sweep == 1 and not active.any():
                rec.sweep_cov[0] = raw_cov(np.zeros(p), np.eye(p))[1]  # the first prior
            kf.x, kf.P = np.zeros(p), np.eye(p)
            for i in sweep_order(n, sweep):
                kf.update(z[i : i + 1], hj, hx, args=(i,), hx_args=(i,))
                if mode == "point":  # the model sees the state: keep it in the box
                    kf.x = to_s(coords.project(to_u(kf.x)))
                if sweep == 1:
                    rec.first[i], rec.first_cov[i] = raw_cov(kf.x, kf.P)
                rec.innovation[i], rec.innovation_var[i] = kf.y[0], kf.S[0, 0]
            if not (np.all(np.isfinite(kf.x)) and np.all(np.isfinite(kf.P))):
                break
            u_end = to_u(kf.x)
            u_proj = coords.project(u_end)
            violated = (np.abs(u_proj - u_end) > 1e-12 * np.maximum(1.0, np.abs(u_end))) & ~active
            if mode == "point" or not violated.any() or (active | violated).all():
                break
            active |= violated
            u_c = np.where(violated, u_proj, u_c)  # hold them on the bound, refit the rest
        if not (np.all(np.isfinite(kf.x)) and np.all(np.isfinite(kf.P))):
            status, message, k = -1, f"failed: non-finite state or covariance in sweep {sweep}", sweep
            break
        kf.x = to_s(coords.project(to_u(kf.x)))
        x_new, P_x = raw_cov(kf.x, kf.P)
        rec.sweeps[sweep], rec.sweep_cov[sweep] = x_new, P_x
        du = np.abs(coords.internal(x_new) - coords.internal(x))
        change = du / u_scale
        x = x_new
        at_bound = [nm for nm, a in zip(names, active) if a]
        if mode == "point" and linearization == "hybrid":
            # settled within the posterior spread (or 1e-3), or enough global sweeps: polish
            sd_u = np.sqrt(np.maximum(np.diag(fr["L"] @ kf.P @ fr["L"].T), 0.0))
            if sweep >= 2 and (np.all(change < 1e-3) or np.all(du <= sd_u) or sweep >= 5):
                mode = "sweep"
                continue
        if np.all(change < tol):
            k, status = sweep, 1
            message = f"converged: all free parameters changed by < {tol:g} (relative/span-scaled) over sweep {sweep}"
            if at_bound:
                message += f"; at bound: {', '.join(at_bound)}"
            break
    elapsed = time.perf_counter() - t0
    P_filter = rec.sweep_cov[k] if status >= 0 else None
    # a parameter held on a bound has no filter variance: report the Jacobian covariance then
    use_filter = covariance == "filter" and P_filter is not None and not at_bound
    result_cov = P_filter if use_filter else None
    return build_result(
        problem, x, method="ekf", iterations=k, status=status, message=message, noise_mN=sigma,
        covariance=result_cov, covariance_source="filter" if result_cov is not None else "jacobian",
        history=rec.history(k),
        info={"time_s": elapsed, "R": R, "R_final": float(fr.get("R", R)), "noise_source": noise_source,
              "prior_weight": prior_weight, "linearization": linearization, "sweep_modes": modes,
              "active_bounds": at_bound,
              "coordinates": coords.kind, "covariance_filter": P_filter, "tol": tol,
              "x0": dict(zip(names, rec.sweeps[0]))},
    )

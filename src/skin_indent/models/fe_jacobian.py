"""The Jacobian of the finite-element core, :meth:`~.fe_core.FECore.jacobian`.

dF/dtheta of :class:`~.fe_core.FECore` at depths 0 < h <= its ceiling: exact in E (the force
is proportional to it); by direct differentiation of the run (its sensitivities, through the
cheap map from ``theta`` to the materials) where a parameter acts on the material parameters
only; by one-sided differences of runs (:data:`RELATIVE_STEP`, made at once, in parallel, on a
morphed mesh) where it moves the geometry or changes the set of materials, carried between
fresh differences by secant (Broyden) updates within a fit's iterations
(:data:`SECANT_REFRESH`); at a face that changes the body once left (a rigid base), by the
slope just inside it (:func:`face_columns`). The functions read and keep the core's runs and
its secant state.
"""

from __future__ import annotations

import numpy as np

from .fe_runs import geometry, material_parameters

#: relative step of the one-sided finite differences in the core parameters
RELATIVE_STEP = 1e-4
#: within a fit (:meth:`~.fe_core.FECore.iterating`), the differenced columns (thicknesses) of a Jacobian
#: are recomputed by runs every this many Jacobians and carried by secant updates in between
SECANT_REFRESH = 3


def jacobian(core, depth_mm, theta, columns=None) -> np.ndarray:
    """dF/dtheta (mN per unit) of ``core`` at depths 0 < h <= its ceiling: :meth:`~.fe_core.FECore.jacobian`."""
    from ..simulate import not_a_knot_spline

    theta = core._check(theta)
    h = np.asarray(depth_mm, dtype=float)
    stiff = core._stiff(theta)
    if stiff is not None:
        return core._stiff_jacobian(h, theta, columns, *stiff)
    lo, hi = core.bounds
    rest = theta[1:]
    core._run([rest], sensitivities=True)
    h_s, F_s, S = core._curves[core._key(rest)]
    sample0 = core.spec(rest).sample(merge=False)
    p0 = material_parameters(sample0)
    geometry0 = geometry(sample0)
    wanted = set(range(1, theta.size)) if columns is None else {int(i) for i in np.arange(theta.size)[columns]}
    # unit-force derivatives (mN/kPa per unit) at the solved depths: by the chain rule, or numeric
    D = np.zeros((h_s.size, theta.size))
    numeric, faces = [], []
    for i in sorted(wanted - {0}):
        step = RELATIVE_STEP * max(abs(theta[i]), 1e-2 * (hi[i] - lo[i]))
        t = theta.copy()
        t[i] = theta[i] + step if theta[i] + step <= hi[i] else theta[i] - step
        tiny = theta.copy()
        tiny[i] = theta[i] + 1e-3 * (t[i] - theta[i])
        sample1 = core.spec(tiny[1:]).sample(merge=False)
        p1 = material_parameters(sample1)
        if S is not None and geometry(sample1) == geometry0 and p1.keys() == p0.keys():
            if p1 == p0 and core.spec(t[1:]).sample(merge=False) != sample0:
                # a face where the probe changes nothing and the step changes the body (a compliance
                # of 0, a rigid base, stays rigid below 1e-6): the slope on the side of the step
                faces.append(i)
                continue
            dd = tiny[i] - theta[i]
            D[:, i] = sum((S[k] * (p1[k] - p0[k]) / dd for k in p0 if p1[k] != p0[k]), np.zeros_like(F_s))
        else:
            numeric.append((i, t))
    if faces:
        face_columns(core, theta, faces, D, h_s)
    columns_n = [i for i, _ in numeric]
    last = core._last
    if (numeric and core._secant and last is not None and last["numeric"] == columns_n
            and last["age"] < SECANT_REFRESH and np.array_equal(last["h"], h_s)):
        # Broyden: the change of the unit curve not explained by the exact columns (trapezoid
        # of the old and new ones) updates the differenced block along the step
        dr = rest - last["rest"]
        exact = [i for i in range(1, theta.size) if i not in columns_n]
        y = F_s - last["F"] - 0.5 * (D[:, exact] + last["D"][:, exact]) @ dr[np.array(exact, dtype=int) - 1]
        block = last["D"][:, columns_n]
        s = dr[np.array(columns_n) - 1]
        if float(s @ s) > 0:
            block = block + np.outer(y - block @ s, s) / float(s @ s)
        D[:, columns_n] = block
        age = last["age"] + 1
    else:
        if numeric:
            core._run([t[1:] for _, t in numeric])
            for i, t in numeric:
                # on the depths solved here: a rigid base's run solves depths near it, which move
                # with a thickness (measured: a layer 1.5 mm on a rigid base, the column at 0.6 mm
                # +41.7 from the runs' forces at different depths, -65.4 on one set of depths)
                h_t, F_t, _ = core._curves[core._key(t[1:])]
                if not np.array_equal(h_t, h_s):
                    F_t = not_a_knot_spline(h_t, F_t / h_t**1.5, h_s) * h_s**1.5
                D[:, i] = (F_t - F_s) / (t[i] - theta[i])
        age = 0
    if core._secant:
        core._last = {"rest": rest.copy(), "h": h_s, "F": F_s, "D": D, "numeric": columns_n, "age": age}

    def spline(values):
        return not_a_knot_spline(h_s, values / h_s**1.5, h) * h**1.5

    J = np.zeros((h.size, theta.size))
    J[:, 0] = spline(F_s)  # dF/dE: the unit force
    for i in wanted - {0}:
        J[:, i] = theta[0] * spline(D[:, i])
    return J


def face_columns(core, theta, faces: list, D, h_s) -> None:
    """The columns ``faces`` of ``D`` (unit-force derivatives at the solved depths) where ``theta``
    stands on a face of the range that changes the body once left: a layer's compliance at 0 (a
    rigid base, whose mesh has no material below). There the run's own sensitivities have no
    base to differentiate (the column would be 0 and a fit could never leave a rigid base), and
    a difference across the rigid and the finite-base meshes measures their discretisation: the
    slope is taken by direct differentiation of a run at 1% of the range inside the face (a base
    12.5 times stiffer than the layer for a compliance in [0, 8]; the force is nearly linear in
    the compliance there, as for springs in series), interpolated to the depths ``h_s`` solved
    at ``theta``."""
    from ..simulate import not_a_knot_spline

    lo, hi = core.bounds
    inside = []
    for i in faces:
        t = theta.copy()
        t[i] = theta[i] + 1e-2 * (hi[i] - lo[i]) * (1.0 if theta[i] - lo[i] <= hi[i] - theta[i] else -1.0)
        inside.append((i, t))
    core._run([t[1:] for _, t in inside], sensitivities=True)
    for i, t in inside:
        h_t, _, S = core._curves[core._key(t[1:])]
        if S is None:
            continue
        tiny = t.copy()
        tiny[i] = t[i] + 1e-3 * (t[i] - theta[i])
        p0 = material_parameters(core.spec(t[1:]).sample(merge=False))
        p1 = material_parameters(core.spec(tiny[1:]).sample(merge=False))
        dd = tiny[i] - t[i]
        slope = sum((S[k] * (p1[k] - p0[k]) / dd for k in p0 if k in p1 and p1[k] != p0[k]), np.zeros(h_t.size))
        D[:, i] = not_a_knot_spline(h_t, slope / h_t**1.5, h_s) * h_s**1.5

"""The seam between the mechanics and everything else: :func:`simulate`.

Response surfaces, inversion and diagnosis reach the finite-element model only
through this module, so they can be tested against :mod:`skin_indent.mechanics.analytic`
without running finite elements.

Example
-------
>>> from skin_indent import simulate, NeoHooke, SphericalIndenter
>>> curve = simulate(NeoHooke(E_kPa=10, nu=0.4), SphericalIndenter(6.22), depth_mm=0.6, points=100)
>>> curve.depth_mm[0], curve.depth_mm[-1]          # doctest: +SKIP
(0.006, 0.6)
"""

from __future__ import annotations

import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .mechanics.contact_law import ContactLaw, SphericalIndenter
from .mechanics.layers import LayeredSample
from .mechanics.materials import Material, NeoHooke
from .mechanics.mesh import DEFAULT_MESH, IndentationMesh, graded_mesh, load_mesh
from .mechanics.convergence import NewtonReport
from .mechanics.solver import IndentationProblem
from .mechanics.protocol import Protocol
from .mechanics.fields import write_vtu
from .mechanics.sensitivity import DirectSensitivity
from .mechanics.sensitivity import check_differentiable
from .runtime.json_io import jsonable
from .runtime.atomic import atomic_write
from .runtime.provenance import provenance as make_provenance, provenance_comment_lines

#: Dimensionless contact penalty: epsilon = PENALTY * E / sqrt(R h_max) (kPa/mm),
#: i.e. ~1e3 E / s0 on the medium mesh. Keeps the penetration below 0.07% of the
#: depth (checked in the tests); a 3x stiffer penalty costs 25% more Newton
#: iterations and changes the force by 7e-4.
PENALTY = 1.2e4
#: Newton tolerance on the residual relative to the contact force vector. Against
#: 1e-9, measured on the default mesh (half-space, layer over a soft half-space, layer
#: on a rigid base, stiffening, nu = 0.499, viscoelastic load-unload, friction ramp):
#: 1e-5 changes the forces by at most 2e-6 relative (1e-6: 2.4e-7; 1e-4: 4e-5) and
#: saves 5-10 % of the Newton iterations of 1e-6.
RTOL = 1e-5
#: Increments for path-independent laws; the force between them is interpolated
#: (cubic spline of F / h^1.5). Measured on the default mesh against direct solves at
#: all 100 depths (E = 10 kPa, nu = 0.4 and E = 5 kPa, nu = 0.48): 12 increments
#: deviate by at most 7.5e-4 for h >= 0.05 mm, 20 by 6.0e-4, 40 by 6.8e-4 - the direct
#: solves themselves scatter by ~5e-4 about a smooth curve (quadrature points entering
#: contact), so more increments buy nothing measurable; 8 increments give 1.5e-3.
DEFAULT_INCREMENTS = 12


@dataclass
class ForceDepthCurve:
    """A simulated force-depth curve.

    Attributes
    ----------
    depth_mm : ndarray
        Depths of the sphere below the undeformed surface, mm.
    force_mN : ndarray
        Force on the sphere, mN.
    material : Material
    indenter : SphericalIndenter
    mesh_name : str
        Which mesh was used and how it was obtained.
    report : NewtonReport
        Newton statistics.
    time_s : ndarray or None
        Times of the depths (s) when a protocol drove the simulation.
    solved_depth_mm, solved_force_mN : ndarray
        Depths (mm) at which equilibrium was solved and the forces there (mN). For
        path-independent laws these are geometrically spaced and the output forces
        come from a cubic spline of the smooth ratio F / h^1.5 (Hertz: F ~ h^1.5).
    sensitivities : dict or None
        With ``simulate(..., sensitivities=True)``: ``(k, name) -> ndarray`` of the
        total derivatives dF/dp at ``depth_mm`` (mN per unit of p: mN/kPa for
        moduli, mN for nu), ``k`` the index of the material (0 for one material;
        layers top first, then the substrate unless rigid) and ``name`` a field of
        its dataclass (``"E_kPa"``, ``"nu"``, ``"C20_kPa"``). See
        :mod:`skin_indent.mechanics.sensitivity`.
    solved_fields : list of ndarray or None
        With ``simulate(..., keep_fields=True)``: the converged displacement field (mm)
        at every solved depth, the warm start of a run of a nearby sample on the same mesh
        (``initial_fields``).
    """

    depth_mm: np.ndarray
    force_mN: np.ndarray
    material: Material
    indenter: SphericalIndenter
    mesh_name: str
    report: NewtonReport
    solved_depth_mm: np.ndarray
    solved_force_mN: np.ndarray
    _state: tuple | None = field(default=None, repr=False)
    time_s: np.ndarray | None = None
    sensitivities: dict | None = None
    solved_fields: list | None = None

    def model_description(self) -> dict:
        """What was simulated: the law, its parameters, the sphere radius and the mesh (JSON-safe)."""
        material = self.material
        return jsonable({"material": getattr(material, "name", type(material).__name__),
                         "law": type(material).__name__, "parameters": material.parameters(),
                         "radius_mm": self.indenter.radius_mm, "mesh": self.mesh_name})

    def to_csv(self, path: str | Path, provenance: dict | None = None) -> Path:
        """Write ``depth_mm,force_mN`` (with ``time_s`` first when known) to ``path``, atomically.

        Parameters
        ----------
        path : str or Path
        provenance : dict, optional
            :func:`skin_indent.runtime.provenance.provenance` of the run (the CLI's records
            the command line and every option); default a record of this API call.

        Returns
        -------
        Path

        Notes
        -----
        ``#`` comment lines before the header hold the provenance, the model
        (``# model: {"material", "law", "parameters", "radius_mm", "mesh"}``) and the
        sphere radius as :func:`skin_indent.measurement.load_csv` reads it
        (``# radius_mm: R``): the file loads back as a measurement with its radius.
        """
        path = Path(path)
        model = self.model_description()
        if provenance is None:
            provenance = make_provenance(settings=model, api="skin_indent.ForceDepthCurve.to_csv")
        columns, header = [self.depth_mm, self.force_mN], "depth_mm,force_mN"
        if self.time_s is not None:
            columns, header = [self.time_s] + columns, "time_s," + header
        buf = io.StringIO()
        np.savetxt(buf, np.column_stack(columns), delimiter=",", header=header, comments="", fmt="%.10g")
        lines = [*provenance_comment_lines(provenance), f"# model: {json.dumps(model, sort_keys=True)}",
                 f"# radius_mm: {self.indenter.radius_mm!r}"]
        text = "\n".join(lines) + "\n" + buf.getvalue()
        return atomic_write(path, lambda fh: fh.write(text.encode("utf-8")))

    def write_vtu(self, path: str | Path) -> Path:
        """Write the deformed mesh and fields at the deepest depth (needs ``keep_state=True``)."""
        if self._state is None:
            raise ValueError("no field state kept: call simulate(..., keep_state=True)")

        problem, u, depth = self._state
        return write_vtu(problem, u, depth, path)


def not_a_knot_spline(x: np.ndarray, y: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Values at ``xi`` of the cubic spline through ``(x, y)`` with not-a-knot ends.

    The same interpolant as ``scipy.interpolate.CubicSpline(x, y, bc_type="not-a-knot")``
    (tested to round-off), without importing :mod:`scipy.interpolate` (about 0.25 s of a
    process's start). ``x`` strictly increasing; ``xi`` inside ``[x[0], x[-1]]``
    (outside, the end cubics are extended). The result is linear in ``y``.
    """
    x, y, xi = np.asarray(x, float), np.asarray(y, float), np.asarray(xi, float)
    n = x.size
    if n < 4:  # a line or a parabola: the rare short case is left to scipy
        from scipy.interpolate import CubicSpline

        return CubicSpline(x, y, bc_type="not-a-knot")(xi)
    dx = np.diff(x)
    m = np.diff(y) / dx
    # slopes s_i at the knots: continuity of the second derivative inside, and a
    # continuous third derivative at the second and last-but-one knots
    A = np.zeros((n, n))
    b = np.empty(n)
    i = np.arange(1, n - 1)
    A[i, i - 1] = dx[1:]
    A[i, i] = 2.0 * (dx[:-1] + dx[1:])
    A[i, i + 1] = dx[:-1]
    b[1:-1] = 3.0 * (dx[1:] * m[:-1] + dx[:-1] * m[1:])
    d = x[2] - x[0]
    A[0, 0], A[0, 1] = dx[1], d
    b[0] = ((dx[0] + 2.0 * d) * dx[1] * m[0] + dx[0] ** 2 * m[1]) / d
    d = x[-1] - x[-3]
    A[-1, -2], A[-1, -1] = d, dx[-2]
    b[-1] = (dx[-1] ** 2 * m[-2] + (2.0 * d + dx[-1]) * dx[-2] * m[-1]) / d
    s = np.linalg.solve(A, b)
    k = np.clip(np.searchsorted(x, xi, side="right") - 1, 0, n - 2)
    t = xi - x[k]
    c2 = (3.0 * m[k] - 2.0 * s[k] - s[k + 1]) / dx[k]
    c3 = (s[k] + s[k + 1] - 2.0 * m[k]) / dx[k] ** 2
    return y[k] + t * (s[k] + t * (c2 + t * c3))


def output_depths(depth_mm: float, points: int) -> np.ndarray:
    """``points`` equally spaced depths from ``depth_mm / points`` to ``depth_mm`` (mm)."""
    return depth_mm * np.arange(1, points + 1) / points


def _check_depths(depth_mm, points) -> np.ndarray:
    if np.ndim(depth_mm) == 0:
        d = float(depth_mm)
        if not math.isfinite(d) or d <= 0:
            raise ValueError(f"depth must be a finite number > 0 mm, got {depth_mm!r}")
        if not isinstance(points, (int, np.integer)) or points < 2:
            raise ValueError(f"points must be an integer >= 2, got {points!r}")
        return output_depths(d, int(points))
    d = np.asarray(depth_mm, dtype=float)
    if d.ndim != 1 or d.size < 2:
        raise ValueError("depths must be a 1-D array of at least 2 values")
    if not np.all(np.isfinite(d)) or np.any(d <= 0) or np.any(np.diff(d) <= 0):
        raise ValueError("depths must be finite, > 0 mm and strictly increasing")
    return d


def _mesh_for(mesh, indenter: SphericalIndenter, max_depth: float, sample=None) -> IndentationMesh:
    if isinstance(mesh, IndentationMesh):
        return mesh
    if isinstance(mesh, (str, Path)) and Path(mesh).suffix:
        return load_mesh(mesh)
    if isinstance(sample, LayeredSample):
        interfaces = sample.interfaces_mm
        if sample.rigid_base:
            return graded_mesh(indenter.radius_mm, max_depth, mesh, interfaces_mm=interfaces[:-1],
                               rigid_base_mm=float(interfaces[-1]))
        return graded_mesh(indenter.radius_mm, max_depth, mesh, interfaces_mm=interfaces)
    return graded_mesh(indenter.radius_mm, max_depth, mesh)


def simulate(material: Material, indenter: SphericalIndenter | None = None, depth_mm=0.6, points: int = 100,
             *, mesh=DEFAULT_MESH, increments: int | None = None, solve_at_outputs: bool = False,
             protocol: Protocol | None = None, offset_mm: float = 0.0, penalty: float = PENALTY,
             rtol: float = RTOL, keep_state: bool = False, progress=None,
             contact: ContactLaw | None = None, sensitivities: bool = False, initial_fields=None,
             keep_fields: bool = False) -> ForceDepthCurve:
    """Simulate the indentation of a half-space by a rigid sphere.

    Parameters
    ----------
    material : Material or LayeredSample
        Constitutive law of the half-space (e.g. :class:`NeoHooke`), or bonded
        layers over a half-space or a rigid base.
    indenter : SphericalIndenter, optional
        The sphere (default radius 6.22 mm).
    depth_mm : float or array_like
        Largest depth in mm (with ``points``), or the increasing depths themselves.
    points : int
        Number of equally spaced output depths when ``depth_mm`` is a number.
    mesh : str, path or IndentationMesh
        ``"coarse"``, ``"medium"`` (default) or ``"fine"`` (built for this radius
        and depth), a mesh file, or a mesh object.
    increments : int, optional
        Number of solved increments for path-independent (elastic, frictionless)
        laws, geometrically spaced from ``min(h_1, h_max / 100)`` to ``h_max``
        (default ``DEFAULT_INCREMENTS`` = 12), plus, for layers on a rigid base pressed
        beyond 0.4 of their thickness, the depths of
        :meth:`~skin_indent.mechanics.layers.LayeredSample.squeeze_depths_mm`; the force at
        the output depths is interpolated.
    solve_at_outputs : bool
        Solve equilibrium exactly at the output depths instead.
    protocol : Protocol, optional
        Depth history with time (ramp, hold, unloading, or a measurement's); then
        ``depth_mm`` and ``points`` are ignored and every protocol point is solved.
        Required for history-dependent laws (viscoelastic).
    offset_mm : float
        Contact-point offset: contact begins at this *recorded* depth, so the
        recorded force is F(depth - offset) and zero before (mm, either sign).
    penalty : float
        Dimensionless contact penalty (epsilon = penalty * E / sqrt(R h_max)).
    rtol : float
        Newton tolerance.
    keep_state : bool
        Keep the final displacement field so that :meth:`ForceDepthCurve.write_vtu` works.
    progress : callable, optional
        ``progress(i, n)`` after each solved increment.
    contact : ContactLaw, optional
        Friction and adhesion between sphere and skin (default frictionless and
        non-adhesive). Friction is history dependent: it needs a ``protocol``.
    sensitivities : bool
        Also compute the derivatives of the returned forces with respect to the
        material parameters, by differentiation of every solved state (one tangent
        assembly and one adjoint solve per solved depth, preconditioned by the
        Newton iterations' factorisation), into
        :attr:`ForceDepthCurve.sensitivities`. Only for :class:`NeoHooke` and
        :class:`NeoHookeStiffening` samples (one material or layers of them) with
        frictionless, non-adhesive contact. The derivatives are exact for the
        discrete model (contact penalty scaling and force interpolation included);
        they are as accurate as the converged states, so use a tight ``rtol``
        (e.g. 1e-10) when they matter.
    initial_fields : sequence, optional
        A warm start: a displacement field (or None) per solved depth, the first iterate of
        Newton's method there instead of the predictor (e.g. ``solved_fields`` of a nearby
        sample on a mesh of the same topology; the solution is the same to ``rtol``, in a
        fraction of the iterations). Path-independent laws without a protocol or an offset.
    keep_fields : bool
        Keep the converged field at every solved depth in :attr:`ForceDepthCurve.solved_fields`.

    Returns
    -------
    ForceDepthCurve

    Raises
    ------
    ValueError
        Bad input (one-line message).
    skin_indent.mechanics.convergence.ConvergenceError
        Newton's method failed even with step cutting.
    """
    if not isinstance(material, (Material, LayeredSample)):
        raise ValueError(f"material must be a skin_indent Material or LayeredSample, got {type(material).__name__}")
    indenter = indenter or SphericalIndenter()
    if not (isinstance(offset_mm, (int, float, np.floating)) and math.isfinite(offset_mm)):
        raise ValueError(f"offset must be a finite number in mm, got {offset_mm!r}")
    if sensitivities:
        check_differentiable(material, contact)
    if (initial_fields is not None or keep_fields) and (offset_mm != 0.0 or protocol is not None):
        raise ValueError("initial_fields and keep_fields need a path-independent run without protocol or offset")
    if offset_mm != 0.0:
        return _simulate_with_offset(material, indenter, depth_mm, points, float(offset_mm), protocol, mesh=mesh,
                                     increments=increments, solve_at_outputs=solve_at_outputs, penalty=penalty,
                                     rtol=rtol, keep_state=keep_state, progress=progress, contact=contact,
                                     sensitivities=sensitivities)
    if protocol is not None:
        return _simulate_protocol(material, indenter, protocol, mesh, penalty, rtol, keep_state, progress, contact,
                                  sensitivities)
    if not material.path_independent:
        raise ValueError(f"{material.name} depends on the loading history: give a protocol (time and depth)")
    if not getattr(contact, "path_independent", True):
        raise ValueError("friction depends on the loading history: give a protocol (time and depth)")
    depths = _check_depths(depth_mm, points)
    imesh = _mesh_for(mesh, indenter, depths[-1], material)
    problem = IndentationProblem(imesh, material, indenter, depths[-1], penalty=penalty, rtol=rtol, contact=contact)
    if solve_at_outputs:
        solved = depths
    else:
        n_solve = DEFAULT_INCREMENTS if increments is None else increments
        if not isinstance(n_solve, (int, np.integer)) or n_solve < 2:
            raise ValueError(f"increments must be an integer >= 2, got {increments!r}")
        # geometric spacing: dense where F changes fastest (relatively), and a constant
        # depth ratio lets the self-similar predictor work (see mechanics.predictor)
        solved = np.geomspace(min(depths[0], depths[-1] / 100.0), depths[-1], int(n_solve))
        if isinstance(material, LayeredSample):  # a layer squeezed on a rigid base: where F steepens
            solved = np.union1d(solved, material.squeeze_depths_mm(depths[-1]))
    cb = (lambda i: progress(i, solved.size)) if progress else None
    sens = _direct_sensitivity(problem, material, solved.size) if sensitivities else None
    fields = [] if keep_fields else None
    hook = sens
    if fields is not None:
        def hook(i, u, depth):
            fields.append(u.copy())
            if sens is not None:
                sens(i, u, depth)
    if initial_fields is not None and len(initial_fields) != solved.size:
        raise ValueError(f"initial_fields must hold one field (or None) per solved depth ({solved.size})")
    forces, u, report = problem.solve(solved, progress=cb, on_converged=hook, initial=initial_fields)
    if solved is depths:
        out = forces
    else:
        # F / h^1.5 is smooth and finite as h -> 0 (Hertz), so a cubic spline of it is
        # accurate down to the smallest depths; the result is linear in the forces.
        out = not_a_knot_spline(solved, forces / solved**1.5, depths) * depths**1.5
    state = (problem, u, float(solved[-1])) if keep_state else None
    curve = ForceDepthCurve(depths, out, material, indenter, imesh.name, report, solved, forces, state,
                            solved_fields=fields)
    if sens is not None:  # the output forces are linear in the solved ones: so are their derivatives
        curve.sensitivities = {key: d if solved is depths else
                               not_a_knot_spline(solved, d / solved**1.5, depths) * depths**1.5
                               for key, d in sens.values.items()}
    return curve


def _direct_sensitivity(problem, material, n_depths):
    return DirectSensitivity(problem, material, n_depths)


def _simulate_with_offset(material, indenter, depth_mm, points, offset, protocol, **kwargs) -> ForceDepthCurve:
    """The recorded curve F(depth - offset), zero where the sphere has not reached the surface."""
    if protocol is not None:
        shifted = simulate(material, indenter, protocol=Protocol(protocol.time_s, protocol.depth_mm - offset), **kwargs)
        shifted.depth_mm = protocol.depth_mm
        return shifted
    recorded = _check_depths(depth_mm, points)
    touching = recorded > offset
    if np.count_nonzero(touching) < 2:
        raise ValueError(f"with an offset of {offset:g} mm fewer than 2 depths reach the surface")
    curve = simulate(material, indenter, recorded[touching] - offset, **kwargs)
    force = np.zeros_like(recorded)
    force[touching] = curve.force_mN
    curve.depth_mm, curve.force_mN = recorded, force
    if curve.sensitivities is not None:  # zero before contact, like the force
        curve.sensitivities = {key: _scatter(d, touching) for key, d in curve.sensitivities.items()}
    return curve


def _scatter(values: np.ndarray, where: np.ndarray) -> np.ndarray:
    """``values`` at the True entries of ``where``, zero elsewhere."""
    out = np.zeros(where.shape)
    out[where] = values
    return out


def _simulate_protocol(material, indenter, protocol: Protocol, mesh, penalty, rtol, keep_state, progress,
                       contact=None, sensitivities=False):
    """Solve at every point of a depth-time history."""
    imesh = _mesh_for(mesh, indenter, protocol.max_depth_mm, material)
    problem = IndentationProblem(imesh, material, indenter, protocol.max_depth_mm, penalty=penalty, rtol=rtol,
                                 contact=contact)
    cb = (lambda i: progress(i, protocol.depth_mm.size)) if progress else None
    sens = _direct_sensitivity(problem, material, protocol.depth_mm.size) if sensitivities else None
    forces, u, report = problem.solve(protocol.depth_mm, progress=cb, times_s=protocol.time_s, on_converged=sens)
    state = (problem, u, float(protocol.depth_mm[-1])) if keep_state else None
    return ForceDepthCurve(protocol.depth_mm, forces, material, indenter, imesh.name, report, protocol.depth_mm,
                           forces, state, time_s=protocol.time_s,
                           sensitivities=None if sens is None else sens.values)


def fe_unit_curve(nu: float, depth_mm, *, radius_mm: float = 6.22, mesh: str = DEFAULT_MESH) -> np.ndarray:
    """Force (mN) of a neo-Hookean half-space with E = 1 kPa at the given depths.

    The force of this law is exactly proportional to E at fixed nu, so response
    surfaces store this unit curve once per nu and multiply by E.

    Parameters
    ----------
    nu : float
        Poisson's ratio.
    depth_mm : array_like
        Increasing depths, mm.
    radius_mm : float
        Sphere radius, mm.
    mesh : str
        Mesh family member.
    """
    return simulate(NeoHooke(1.0, nu), SphericalIndenter(radius_mm), np.asarray(depth_mm, float), mesh=mesh).force_mN

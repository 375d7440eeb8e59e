"""Several curves of one sample, one force model: the material shared, each measurement its own.

A sample measured several ways (two spheres, two depths, two speeds, a ramp and a
ramp-hold) is one set of material and effect parameters seen through several recorded
histories. :class:`JointModel` binds one :class:`~skin_indent.models.ComposedModel` per
curve (its own sphere radius, elastic core, history and contact point) and presents them
as one force model over the concatenated points (the force-model protocol of
:mod:`skin_indent.inverse`), so the fits, their covariance and the diagnosis treat a
sample as they treat a curve:

- the parameters of the material and of every effect that is not
  :attr:`~skin_indent.effects.Effect.per_curve` are shared: one value for all curves
  (their range the intersection of the curves' ranges);
- those of a per-curve effect (the contact point, ``offset_mm``) are one per curve,
  named with the curve's number in input order: ``offset_mm[1]``, ``offset_mm[2]``.

Finite-element runs of several curves (one elastic core per curve: the sphere radius
differs) are made side by side, each curve's runs in worker processes
(:meth:`~skin_indent.models.fe_core.FECore.in_workers`), so that the runs of all curves
of one model go to the workers together.
"""

from __future__ import annotations

import contextlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from .composed import reported_parameters


def curve_name(name: str, k: int) -> str:
    """The name of curve ``k``'s (0-based) own parameter ``name``: ``offset_mm[2]`` for k = 1."""
    return f"{name}[{k + 1}]"


def split_name(name: str) -> tuple[str, int | None]:
    """``"offset_mm[2]"`` -> ``("offset_mm", 1)``; a shared name -> ``(name, None)``."""
    if name.endswith("]") and "[" in name:
        base, _, k = name[:-1].rpartition("[")
        if k.isdigit() and int(k) >= 1:
            return base, int(k) - 1
    return name, None


@dataclass(frozen=True)
class JointEvaluation:
    """All stages of every curve at one parameter vector, concatenated in input order."""

    h_mm: np.ndarray
    force_mN: np.ndarray


class JointModel:
    """Per-curve composed models sharing their material and effect parameters.

    Parameters
    ----------
    parts : sequence of ComposedModel
        One per curve, in input order, each bound to its curve (the same effects; the
        contact point only where a curve is recorded from before contact).

    Attributes
    ----------
    parameter_names : tuple of str
        The shared parameters (in the first curve's order), and each curve's own after
        its name (``offset_mm[2]``).
    bounds : (ndarray, ndarray)
        A shared parameter's range is the intersection of the curves' ranges.
    depth_mm : ndarray
        The curves' recorded depths, concatenated (mm).
    slices : list of slice
        Each curve's points in the concatenation.

    Raises
    ------
    ValueError
        The curves admit no common value of a shared parameter.
    """

    def __init__(self, parts):
        self.parts = list(parts)
        if len(self.parts) < 2:
            raise ValueError("a joint model needs at least two curves")
        names, lo, hi = [], [], []
        self._index = []
        for k, part in enumerate(self.parts):
            own = {n for e in part.effects if e.per_curve for n in e.fit_names}
            idx = []
            for i, n in enumerate(part.parameter_names):
                joint = curve_name(n, k) if n in own else n
                a, b = float(part.bounds[0][i]), float(part.bounds[1][i])
                if joint in names:
                    j = names.index(joint)
                    lo[j], hi[j] = max(lo[j], a), min(hi[j], b)
                else:
                    names.append(joint)
                    lo.append(a)
                    hi.append(b)
                idx.append(names.index(joint))
            self._index.append(np.array(idx, dtype=int))
        for n, a, b in zip(names, lo, hi):
            if not a <= b:
                raise ValueError(f"the curves admit no common value of {n}: their ranges do not overlap")
        self.parameter_names = tuple(names)
        self.bounds = (np.array(lo, dtype=float), np.array(hi, dtype=float))
        stops = np.cumsum([0] + [p.depth_mm.size for p in self.parts])
        self.slices = [slice(int(a), int(b)) for a, b in zip(stops[:-1], stops[1:])]
        self.depth_mm = np.concatenate([p.depth_mm for p in self.parts])
        self.effects = self.parts[0].effects
        self.depth_range = (min(p.depth_range[0] for p in self.parts), max(p.depth_range[1] for p in self.parts))

    @property
    def name(self) -> str:
        return self.parts[0].name

    @property
    def cores(self) -> tuple:
        """Every curve's elastic core."""
        return tuple(c for p in self.parts for c in p.cores)

    @property
    def core(self):
        """The first curve's elastic core (what a single curve's model calls its core)."""
        return self.parts[0].core

    @property
    def in_loop(self) -> bool:
        """Some curve is fitted with the finite-element model in the loop."""
        return any(c.in_loop for c in self.cores)

    def part(self, k: int, x) -> tuple:
        """``(ComposedModel, its fit vector)`` of curve ``k`` (0-based) at the joint vector ``x``."""
        return self.parts[k], np.asarray(x, dtype=float)[self._index[k]]

    def index(self, k: int) -> np.ndarray:
        """Positions in the joint vector of curve ``k``'s parameters (its model's order)."""
        return self._index[k]

    # ------------------------------------------------------------- evaluation
    def _check_depth(self, depth_mm):
        d = np.asarray(depth_mm, dtype=float)
        if d.shape != self.depth_mm.shape or not np.array_equal(d, self.depth_mm):
            raise ValueError(f"model {self.name} of {len(self.parts)} curves is bound to their recorded "
                             "histories: pass its own depths")

    def _each(self, fn):
        """``[fn(k, part)]`` over the curves: side by side (threads, each curve's runs in worker
        processes) when more than one curve is fitted with finite elements in the loop."""
        looped = [k for k, p in enumerate(self.parts) if p.in_loop]
        if len(looped) < 2:
            return [fn(k, p) for k, p in enumerate(self.parts)]
        with contextlib.ExitStack() as stack:
            for k in looped:
                for c in self.parts[k].cores:
                    stack.enter_context(c.in_workers())
            with ThreadPoolExecutor(max_workers=len(self.parts)) as pool:
                return list(pool.map(lambda kp: fn(*kp), enumerate(self.parts)))

    def start_workers(self) -> None:
        """Start the worker processes of every curve's finite-element core now, from the calling
        (main) thread, before threads that make runs in them start."""
        for c in self.cores:
            c.start_workers()

    def evaluate(self, theta) -> JointEvaluation:
        """Every curve's stages at ``theta``: the indentation below each curve's contact point and
        the force, concatenated."""
        evs = self._each(lambda k, p: p.evaluate(np.asarray(theta, dtype=float)[self._index[k]]))
        return JointEvaluation(np.concatenate([e.h_mm for e in evs]), np.concatenate([e.force_mN for e in evs]))

    def force(self, depth_mm, theta) -> np.ndarray:
        self._check_depth(depth_mm)
        theta = np.asarray(theta, dtype=float)
        return np.concatenate(self._each(lambda k, p: p.force(p.depth_mm, theta[self._index[k]])))

    def jacobian(self, depth_mm, theta, columns=None) -> np.ndarray:
        """dF/dtheta: each curve's Jacobian (:meth:`ComposedModel.jacobian`) in its rows and its
        parameters' columns; only the ``columns`` asked for (default all) are computed."""
        self._check_depth(depth_mm)
        theta = np.asarray(theta, dtype=float)
        wanted = np.zeros(theta.size, dtype=bool)
        wanted[np.arange(theta.size) if columns is None else columns] = True

        def one(k, p):
            idx = self._index[k]
            return p.jacobian(p.depth_mm, theta[idx], columns=np.flatnonzero(wanted[idx]))

        J = np.zeros((self.depth_mm.size, theta.size))
        for k, Jk in enumerate(self._each(one)):
            J[self.slices[k], self._index[k]] = Jk
        return J

    def iterating(self):
        """The iterations of a fit: every curve's (:meth:`ComposedModel.iterating`)."""
        stack = contextlib.ExitStack()
        for p in self.parts:
            stack.enter_context(p.iterating())
        return stack

    def screening(self):
        """Cheap runs that only rank start vectors, on every curve's core."""
        stack = contextlib.ExitStack()
        for p in self.parts:
            stack.enter_context(p.screening())
        return stack

    def prefetch(self, xs) -> None:
        """The finite-element runs of several joint vectors, every curve's at once."""
        xs = [np.asarray(x, dtype=float) for x in xs]
        self._each(lambda k, p: p.prefetch([x[self._index[k]] for x in xs]))

    # ------------------------------------------------------------- parameters
    def model_parameters(self, x) -> dict:
        """The shared model parameters (as users read them), then each curve's own (``offset_mm[2]``)."""
        x = np.asarray(x, dtype=float)
        out, own = {}, {}
        for k, p in enumerate(self.parts):
            values = p.model_parameters(x[self._index[k]])
            mine = {n for e in p.effects if e.per_curve for n in e.parameter_names}
            for n, v in values.items():
                if n in mine:
                    own[curve_name(n, k)] = v
                else:
                    out.setdefault(n, v)
        return {**out, **own}

    def reported(self, x, cov) -> tuple[dict, dict]:
        """Model parameters and their standard deviations (delta method with ``cov`` of ``x``)."""
        return reported_parameters(self, x, cov)

    def curve_parameters(self, params: dict, k: int) -> dict:
        """Curve ``k``'s model parameters under their own names: the shared ones and its own
        (``offset_mm[2]`` -> ``offset_mm``), without the other curves'."""
        out = {}
        for n, v in params.items():
            base, j = split_name(n)
            if j is None or j == k:
                out[base] = v
        return out

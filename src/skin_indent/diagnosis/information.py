r"""What a measurement would determine when fitted together with what was recorded.

:func:`joint_std` (a part of the engine of the next measurement,
:func:`~.identifiability.weigh`): the standard deviations of the parameters when a
candidate is fitted together with what was recorded: the information matrices of the
curves (:class:`Block`) summed (the shared parameters; each curve keeps its own contact
point where the fitted model fits one), with the priors' rows,
:math:`\mathrm{cov} = (\sum_k J_k^T W_k J_k + P^T P)^{-1}`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..effects import DEPTH
from ..inverse.result import jacobian_covariance
from ..models.joint import split_name


@dataclass(frozen=True)
class Block:
    """One curve's rows of a joint fit: its Jacobian and error model.

    Attributes
    ----------
    J : ndarray (n, p)
        dF/dtheta at the fitted values (mN per unit).
    names : tuple of str
        The coordinates of the columns.
    sigma : ndarray (n,)
        Standard deviation of each point (mN).
    own : bool
        The curve's :data:`~skin_indent.effects.DEPTH` coordinates (its contact point)
        are its own, not the model's (every curve but the one the model was fitted to).
    """

    J: np.ndarray
    names: tuple
    sigma: np.ndarray
    own: bool = True


def _stack(rung, blocks, free) -> tuple[np.ndarray, list]:
    """Whitened rows of ``blocks`` over the columns: the rung's ``free`` coordinates, then each block's
    own depth coordinates; and the index (in the rung's vector) of each rung column."""
    depth = {k for e in rung.bound_model.effects if e.stage == DEPTH for k in e.fit_names}
    names = list(rung.bound_model.parameter_names)
    joint = any(split_name(n)[1] is not None for n in names)  # fitted to several curves: offset_mm[2]...
    if joint:  # every curve's contact point is its own column; the shared coordinates are the rung's
        free = [i for i in free if split_name(names[i])[1] is None]
    columns = [names[i] for i in free]
    extra = []
    for k, b in enumerate(blocks):
        if b.own or joint:
            extra += [(k, n) for n in b.names if n in depth and (joint or names.index(n) in free)]
    width = len(columns) + len(extra)
    rows = []
    for k, b in enumerate(blocks):
        R = np.zeros((b.J.shape[0], width))
        for j, n in enumerate(b.names):
            if (k, n) in extra:
                R[:, len(columns) + extra.index((k, n))] = b.J[:, j]
            elif n in columns:
                R[:, columns.index(n)] = b.J[:, j]
        rows.append(R / np.asarray(b.sigma, dtype=float)[:, None])
    return np.vstack(rows), [names.index(n) for n in columns]


def joint_std(rung, blocks, free, prior_terms=(), prior_rows=None) -> dict:
    """Standard deviations of the reported parameters of ``rung`` fitted to every block together.

    Parameters
    ----------
    rung : FitResult
        The fitted model (``bound_model``, ``x``).
    blocks : sequence of Block
        The curves fitted together.
    free : sequence of int
        Indices of the rung's fit coordinates that are fitted (the others held).
    prior_terms : sequence
        The priors ``(g, mean, sd)`` on the model (:meth:`Fitter.prior_terms`).
    prior_rows : callable, optional
        :func:`skin_indent.fitting.knowledge.prior_rows`, needed with priors.

    Returns
    -------
    dict
        ``{reported parameter: standard deviation}`` from cov = (sum_k J_k^T W_k J_k + priors)^-1
        (``inf`` where the information is rank deficient).
    """
    model, x = rung.bound_model, np.asarray(rung.x, dtype=float)
    rows, index = _stack(rung, blocks, free)
    if prior_terms:
        lo, hi = model.bounds
        P = np.zeros((len(prior_terms), rows.shape[1]))
        P[:, :len(index)] = prior_rows(list(prior_terms), x, index, lo, hi)
        rows = np.vstack([rows, P])
    cov_all, _ = jacobian_covariance(rows)
    cov = np.zeros((x.size, x.size))
    cov[np.ix_(index, index)] = cov_all[: len(index), : len(index)]
    return model.reported(x, cov)[1]


def free_columns(rung) -> list[int]:
    """Indices of the fit coordinates a rung's covariance treats as fitted: its free ones,
    without those on a face of their range when its covariance with them free is not finite
    (held there, as :meth:`~skin_indent.fitting.multistart.Fitter.fit` does)."""
    names = list(rung.bound_model.parameter_names)
    cov = getattr(rung, "covariance", None)
    held = set() if cov is not None and np.all(np.isfinite(cov)) else set(getattr(rung, "at_bounds", ()))
    return [names.index(n) for n in rung.free_names if n not in held and n in names]

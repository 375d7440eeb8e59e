"""Several models of one fitter at once: the fits with the finite-element model in the loop side by side,
one thread per elastic core (:func:`side_by_side`, what :meth:`~.multistart.Fitter.fit_all` does)."""

from __future__ import annotations

import contextlib
from concurrent.futures import ThreadPoolExecutor

from ..effects.order import same_model


def side_by_side(fitter, keys) -> dict:
    """Fit several sets of effects: ``{key: FitResult or ValueError}`` (the error of a set that
    cannot be fitted), in the order of ``keys``.

    Sets fitted with the finite-element model in the loop (two layers, layer and
    stiffening) are fitted at once, one thread per elastic core whose runs go to worker
    processes (:meth:`~skin_indent.models.fe_core.FECore.in_workers`): a fit's evaluations
    are serial, so two fits side by side keep both cores busy. Each fit is the one
    :meth:`~.multistart.Fitter.fit` makes alone (its own core, its own warm start from the rungs
    fitted before this call or in its own thread, whichever thread finishes first). The same model
    in another order is fitted once (:func:`~skin_indent.effects.order.same_model`).
    """
    before = set(fitter.fits)

    def attempt(group, threaded=False):
        # a fit in a thread starts only from the fits made before this call and those of its own
        # group: whether another thread's fit has finished yet must not change where it starts
        if threaded:
            fitter._seen.keys = set(before)
        out = {}
        try:
            for key in group:
                try:
                    out[key] = fitter.fit(key)
                except ValueError as err:
                    out[key] = err
                if threaded:
                    fitter._seen.keys.add(key)
        finally:
            if threaded:
                fitter._seen.keys = None
        return out

    keys = [tuple(k) for k in keys]
    groups: dict[int, list] = {}  # new in-loop fits by core: a core serves one thread
    done = {}
    later = []  # the same model as a key before it, in another order: relabelled once that one is fitted
    for i, key in enumerate(keys):
        if key in fitter.fits or fitter.twin(key) is not None:
            done.update(attempt([key]))
            continue
        if any(same_model(k, key) for k in keys[:i]):
            later.append(key)
            continue
        try:
            fitter.check_points_before_building(key)  # a curve too short for it builds nothing
            cores = fitter.model(key).cores  # the cores are made here, in this thread
        except ValueError as err:
            done[key] = err
            continue
        looped = tuple(id(c) for c in cores if c.in_loop)
        if looped:
            groups.setdefault(looped, []).append(key)
        else:
            done.update(attempt([key]))
    if len(groups) > 1:
        cores = [c for group in groups.values() for c in fitter.model(group[0]).cores if c.in_loop]
        with contextlib.ExitStack() as stack:
            for core in cores:
                stack.enter_context(core.in_workers())
                core.start_workers()  # forked from this (the main) thread, not from the fits'
            pool = ThreadPoolExecutor(max_workers=len(groups))
            try:
                for out in pool.map(lambda g: attempt(g, threaded=True), groups.values()):
                    done.update(out)
            except BaseException:  # an interrupt: the other threads stop at their next run
                for core in cores:
                    core.cancel()
                raise
            finally:
                pool.shutdown(wait=True)
    else:
        for group in groups.values():
            done.update(attempt(group))
    for key in later:  # the fit of its first order, or that order's error
        first = done[next(k for k in keys if same_model(k, key))]
        done.update({key: first} if isinstance(first, ValueError) else attempt([key]))
    return {key: done[key] for key in keys}

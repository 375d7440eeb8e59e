"""A second explanation that becomes the first one with an effect the data do not ask for is not climbed.

The diagnosis climbs the best candidate of its first examination and the runner-up (a beam of
two). When the runner-up's branch reaches a rung that holds a rung of the first explanation and
one effect more, and that effect does not lower the BIC there (the contact points of two curves
that start in contact, at 0 on top of the layer rung), the branch is that explanation with the
effect along for nothing: it stops there, and no finite-element fit is made on top of it (issue
39). An effect that lowers the BIC, even by less than ``STRONG``, keeps its branch (the
explanations compared as before). Given fits, no model evaluated.
"""

import math

import pytest
from test_fit_ended import _Fitter as _Given, _Rung  # the ladder's given fits

from skin_indent.diagnosis import branches, workflow
from skin_indent.diagnosis.criteria import STRONG, Scores


class _Fitter(_Given):
    """The fits a climb asks for, given (any other: KeyError), and which were asked for."""

    def __init__(self, fits):
        super().__init__(dict(fits))
        self.asked = []

    def fit(self, key):
        self.asked.append(tuple(key))
        return super().fit(key)

    def fit_all(self, keys):
        return {tuple(k): self.fit(k) for k in keys}


N = 100


def _fits(offset_gain: float) -> dict:
    """One layer explains most; two layers more; the contact point on top of the layer rung lowers the
    BIC by ``offset_gain`` (the chi-square by that and its one parameter's ln n)."""
    one = 300.0
    with_offset = one - offset_gain - math.log(N)
    return {("layer",): _Rung(("layer",), one, 4), ("layer", "layer"): _Rung(("layer", "layer"), 100.0, 6),
            ("offset",): _Rung(("offset",), 900.0, 3), ("offset", "layer"): _Rung(("offset", "layer"), with_offset, 5),
            ("offset", "stiffening"): _Rung(("offset", "stiffening"), 800.0, 4)}


@pytest.mark.parametrize("gain", [0.0, -3.0])
def test_a_branch_that_joins_a_climbed_rung_stops_there(monkeypatch, gain):
    monkeypatch.setattr(workflow, "settled", lambda rung, fitter: False)
    fitter = _Fitter(_fits(gain))
    scores = Scores(N, N)
    steps = []
    key, joined = workflow._climb(fitter, ("offset",), ("layer", "stiffening"), scores, 2, steps,
                                  kept=[("layer",), ("layer", "layer")])
    assert key == ("offset", "layer") and joined == ("layer",)
    assert [s.rung.effects for s in steps] == [("offset",)]  # (offset, layer) not examined: nothing fitted on it
    assert not any(len(k) > 2 for k in fitter.asked)
    assert branches.joins(fitter, key, [("layer",)], scores) == ("layer",)
    assert branches.joins(fitter, key, [("stiffening",)], scores) is None  # not a rung it holds


@pytest.mark.parametrize("gain", [2.8, STRONG + 5.0])
def test_an_effect_that_lowers_the_bic_keeps_its_branch(monkeypatch, gain):
    monkeypatch.setattr(workflow, "settled", lambda rung, fitter: False)
    fits = _fits(gain)
    fits.update({("offset", "layer", "layer"): _Rung(("offset", "layer", "layer"), 80.0, 7),
                 ("offset", "layer", "stiffening"): _Rung(("offset", "layer", "stiffening"), 95.0, 6)})
    fitter = _Fitter(fits)
    steps = []
    key, joined = workflow._climb(fitter, ("offset",), ("layer", "stiffening"), Scores(N, N), 2, steps,
                                  kept=[("layer",), ("layer", "layer")])
    assert joined is None and key == ("offset", "layer", "layer")
    assert [s.rung.effects for s in steps] == [("offset",), ("offset", "layer")]
    # without rungs climbed before (the first explanation), nothing is joined
    steps = []
    assert workflow._climb(_Fitter(fits), ("offset",), ("layer", "stiffening"), Scores(N, N), 2, steps) == (
        ("offset", "layer", "layer"), None)

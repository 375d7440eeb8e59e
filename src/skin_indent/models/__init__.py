"""Force models for fits: adapters that implement the :class:`~skin_indent.inverse.ForceModel` protocol.

- :class:`ComposedModel`: an elastic core (a response surface over E, nu and the
  elastic effects) plus the effects that move the depth (the contact point) or act on
  the force (relaxation, adhesion, ...), bound to one measured history;
- :class:`JointModel`: several curves of one sample, each a composed model, sharing the
  material's parameters (each curve its own contact point);
- :class:`HertzModel`: Hertz's sphere, for comparison.
"""

from .composed import ComposedModel
from .hertz import HertzModel
from .joint import JointModel

__all__ = ["ComposedModel", "HertzModel", "JointModel"]

"""Which equations solve which mechanism: the systems layer (between the search and the trust layer).

:data:`SYSTEMS` (:mod:`spherekin.systems.base`) holds, in order of preference, the platform system
(:mod:`spherekin.systems.platform`: Eq. (1), three unknowns, for three R-R-R legs with the base
joints actuated) and the loop-equation system (:mod:`spherekin.systems.loops`: any mechanism).
"""

from .base import AUTO, ON_CAP_CHOICES, ON_CAP_COVER, ON_CAP_RAISE, SYSTEMS, Compiled, Strategy, System, choose, system_choices
from .platform import Platform      # registered first: the fastest, where it accepts
from .loops import LOOP_FORMULATION, Loops

__all__ = ["AUTO", "ON_CAP_CHOICES", "ON_CAP_COVER", "ON_CAP_RAISE", "SYSTEMS", "Compiled", "Strategy", "System", "choose", "system_choices", "Platform", "Loops",
           "LOOP_FORMULATION"]

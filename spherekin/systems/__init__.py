"""Which equations solve which mechanism: the systems layer (between the search and the trust layer).

:data:`SYSTEMS` (:mod:`spherekin.systems.base`) holds, in order of preference, the platform system
(:mod:`spherekin.systems.platform`: Eq. (1), three unknowns, for three R-R-R legs with the base
joints actuated) and the loop-equation system (:mod:`spherekin.systems.loops`: any mechanism).
"""

from .base import (AUTO, CONTINUUM_TOL, ON_CAP_CHOICES, ON_CAP_COVER, ON_CAP_RAISE, SYSTEMS, CappedSearchWarning, Compiled,
                   Found, Passed, Strategy, System, chain, choose, formulation_choices, system_choices,
                   system_of_formulation)
from .platform import Platform      # registered first: the fastest, where it accepts
from .loops import LOOP_FORMULATION, Loops

__all__ = ["AUTO", "CONTINUUM_TOL", "ON_CAP_CHOICES", "ON_CAP_COVER", "ON_CAP_RAISE", "SYSTEMS", "CappedSearchWarning",
           "Compiled", "Found", "Passed", "Strategy", "System", "chain", "choose", "formulation_choices",
           "system_choices", "system_of_formulation", "Platform", "Loops", "LOOP_FORMULATION"]

"""Which equations solve which mechanism: the systems layer (between the search and the trust layer).

:data:`SYSTEMS` (:mod:`spherekin.systems.base`) holds, in order of preference, the complete-count
system (:mod:`spherekin.systems.complete`: all 8 complex roots of Eq. (1) proven at once, Bezout's
bound reached, no subdivision; base-actuated 3-RRR), the platform system
(:mod:`spherekin.systems.platform`: Eq. (1), three unknowns, for three R-R-R legs with one joint
of each actuated) and the loop-equation system (:mod:`spherekin.systems.loops`: any mechanism).
"""

from .base import (AUTO, CONTINUUM_TOL, ON_CAP_CHOICES, ON_CAP_COVER, ON_CAP_RAISE, SEARCH_CHUNK, SYSTEMS, CappedSearchWarning, Compiled,
                   Found, Passed, Proven, Strategy, System, chain, choose, formulation_choices, system_choices,
                   system_of_formulation)
from .platform import Platform
from .one_loop import OneLoop       # registered first (first=True), then the complete count before it:
from .complete import Complete      # the fastest first, where they accept (they accept different mechanisms)
from .loops import LOOP_FORMULATION, Loops

__all__ = ["AUTO", "CONTINUUM_TOL", "ON_CAP_CHOICES", "ON_CAP_COVER", "ON_CAP_RAISE", "SEARCH_CHUNK", "SYSTEMS", "CappedSearchWarning",
           "Compiled", "Found", "Passed", "Proven", "Strategy", "System", "chain", "choose", "formulation_choices",
           "system_choices", "system_of_formulation", "Complete", "OneLoop", "Platform", "Loops", "LOOP_FORMULATION"]

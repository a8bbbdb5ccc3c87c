"""Singular sets: the parallel (Type-2) singularities of a mechanism over a plane or a line of inputs.

A layer of its own above the pipeline (the cover's line check and the mode change solve and track
through :mod:`spherekin.problem`); each part reaches the mechanism's equations through the systems'
seam (:func:`spherekin.singularities.planes.plane_system`), not by naming a system:

* :mod:`.planes`: the augmented systems (closure equations plus the Jacobian's determinant) each
  system provides, with the plane's inputs as unknowns;
* :mod:`.blowup`: a stationary assembly's neighbourhood blown up (the agile eye);
* :mod:`.cells`: the cover projected onto cells of the plane, their certificates and the cusps';
* :mod:`.cover`: :func:`singular`, the certified set (:class:`spherekin.results.SingularSet`);
* :mod:`.mode_change`: a proven assembly-mode change around a cusp.

Free boxes (:mod:`spherekin.trust.free_box`) stay in the trust layer: a free box is a certificate of
one assembly (``Problem.free_box``), a method of the pipeline, which this package sits above.
"""

from .cover import SINGULAR_TOL, check_singular_tol, singular, singular_min_tol
from .mode_change import mode_change

__all__ = ["SINGULAR_TOL", "check_singular_tol", "singular", "singular_min_tol", "mode_change"]

"""Singular sets: the parallel (Type-2) singularities of a mechanism over a plane or a line of inputs.

A layer of its own above the pipeline (the cover's line check and the mode change solve and track
through :mod:`spherekin.problem`); each part reaches the mechanism's equations through the systems'
seam (:func:`spherekin.singularities.planes.plane_system`), not by naming a system:

* :mod:`.planes`: the augmented systems (closure equations plus the Jacobian's determinant) each
  system provides, with the plane's inputs as unknowns;
* :mod:`.blowup`: a stationary assembly's neighbourhood blown up (the agile eye);
* :mod:`.cell_width`: the cell width T, its bounds and its check (light: no SciPy);
* :mod:`.cells`: the cover projected onto cells of the plane, their certificates and the cusps';
* :mod:`.cover`: :func:`singular`, the certified set (:class:`spherekin.results.SingularSet`);
* :mod:`.modes`: a proven assembly-mode change around a cusp;
* :mod:`.tolerant`: the singular set under tolerances (issue 45): the cells of a plane not proven free
  of parallel singularities for every geometry within a mechanism's tolerances.

Free boxes (:mod:`spherekin.trust.free_box`) stay in the trust layer: a free box is a certificate of
one assembly (``Problem.free_box``), a method of the pipeline, which this package sits above.
"""


#: What the package offers, loaded on first use: the cover imports SciPy (~0.5 s), which a command
#: that only checks a cell width (:mod:`.cell_width`) must not pay.
_LAZY = {"SINGULAR_TOL": "cell_width", "check_singular_tol": "cell_width", "singular_min_tol": "cell_width",
         "singular": "cover", "mode_change": "modes", "tolerant_singular": "tolerant"}


def __getattr__(name):
    import importlib

    if name in _LAZY:
        return getattr(importlib.import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *_LAZY})


__all__ = list(_LAZY)

"""The array module of a kernel's arguments: the seam between the box loop's kernels and numpy.

The kernels of one box-loop iteration (Bernstein restriction, the projected-polyhedron bounds, the
Krawczyk test's evaluations: see docs/layout.md, "The array engine") start with
``xp = namespace_of(c, lo, hi)`` and call only functions of the Python array API standard through
``xp`` (``xp.stack``, ``xp.min(x, axis=...)``, ``xp.reshape``, ...). On numpy arrays ``xp`` is numpy
itself, so the numbers are numpy's, bit for bit; on CuPy, JAX or ``array_api_strict`` arrays the same
code runs in that module. The module comes from the standard's ``x.__array_namespace__()``, which
numpy 2.x, CuPy, JAX and array_api_strict arrays have; a kernel's arguments must all come from one
module (and, for creation functions that follow an argument, one device).
"""

from __future__ import annotations

import numpy as np

__all__ = ["namespace_of"]


def namespace_of(*arrays):
    """The array module (numpy, array_api_strict, cupy, jax.numpy, ...) of ``arrays``.

    numpy.ndarray arguments take a fast path (no method call; these kernels run ~10-30 times an
    iteration); an argument without ``__array_namespace__`` (a Python scalar, None, a list: what the
    kernel's ``xp.asarray`` converts) is skipped. With no array among the arguments the module is
    numpy. ValueError when arrays of two modules are mixed.
    """
    found = None
    for a in arrays:
        if type(a) is np.ndarray:
            xp = np
        else:
            get = getattr(a, "__array_namespace__", None)
            if get is None:
                continue
            xp = get()
        if found is None:
            found = xp
        elif xp is not found:
            raise ValueError(f"expected arrays of one array module, got {found.__name__} and {xp.__name__}")
    return np if found is None else found

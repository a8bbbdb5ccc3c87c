"""spherekin: direct kinematics of parallel spherical mechanisms with Bernstein polynomials.

``spherekin.solve(mechanism, inputs, ...)``, ``spherekin.compile(mechanism, ...)`` (then
``problem.solve(inputs)`` / ``problem.solve_many(rows)``) and ``spherekin.load_mechanism(path)`` are
the entry points (loaded on first use, so that ``import spherekin`` stays cheap); see README.md.
"""
__version__ = "0.1.0"

_LAZY = {"solve": ("spherekin.problem", "solve"), "compile": ("spherekin.problem", "compile"),
         "solve_system": ("spherekin.search.boxloop", "solve_system"),
         "load_mechanism": ("spherekin.mechanism", "load_mechanism")}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module 'spherekin' has no attribute {name!r}")


__all__ = ["__version__", *_LAZY]

"""spherekin: direct kinematics of parallel spherical mechanisms with Bernstein polynomials.

Entry points (loaded on first use, so that ``import spherekin`` stays cheap; see README.md):

* ``solve(mechanism, inputs, *, formulation=..., pruner=..., tol=..., ...)`` -- every assembly of a
  mechanism (a SphericalMechanism, or the path of a .toml file) at actuator inputs (radians, one per
  actuated joint): a SolveReport (``report.table()``, ``report.frame()``, ``report.as_dict()``);
* ``compile(mechanism, *, formulation=..., ...)`` -- a Problem compiled once for a strategy, then
  ``problem.solve(inputs)``, ``problem.solve_many(rows)``, ``problem.track(path, start=...)``;
* ``inverse_kinematics(mechanism, R)`` -- every input set placing the output link at the pose R
  (legs: their closed form; any graph: the loop equations with the knowns swapped);
* ``singular(mechanism, x=("beta1", lo, hi), y=("beta2", lo, hi), fixed={"beta3": 0.5}, tol=...)`` --
  the certified parallel-singular set in a plane of inputs: a SingularSet (``.as_dict()``: JSON);
* ``load_mechanism(path)`` -- read a mechanism file (docs/mechanism-format.md);
* ``solve_system(build, ranges, ...)`` -- the box loop on a system of closure equations of your own.

Subpackages, imported on first use too: ``spherekin.batch`` (families of inputs on Dask),
``spherekin.plot`` (figures: ``plot_solutions``, ``plot_assembly_map``, ``plot_track``),
``spherekin.mechanism`` (the model and presets).
"""
__version__ = "0.1.0"

_LAZY = {"solve": ("spherekin.problem", "solve"), "compile": ("spherekin.problem", "compile"),
         "inverse_kinematics": ("spherekin.problem", "inverse_kinematics"),
         "solve_system": ("spherekin.search.boxloop", "solve_system"),
         "load_mechanism": ("spherekin.mechanism", "load_mechanism"),
         "singular": ("spherekin.singularities", "singular")}
#: Subpackages reachable as attributes once ``spherekin`` is imported (imported on first use).
_SUBMODULES = ("batch", "plot", "mechanism")


def __getattr__(name):
    import importlib

    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    if name in _SUBMODULES:
        return importlib.import_module(f"spherekin.{name}")
    raise AttributeError(f"module 'spherekin' has no attribute {name!r}")


def __dir__():
    """The module's names with the entry points loaded on first use (``dir(spherekin)``, completion)."""
    return sorted({*globals(), *_LAZY, *_SUBMODULES})


__all__ = ["__version__", *_LAZY]

"""The search: strategies by name (parameterizations, formulations, pruners, LP backends), Krawczyk
isolation in Bernstein form and the box loop of Section 4, on equations handed over as data.

Nothing here imports the mechanism package, the systems (:mod:`spherekin.systems`) or the trust layer.
"""

"""The search: strategies by name (parameterizations, formulations, pruners, LP backends), the platform
formulation, Krawczyk isolation in Bernstein form and the box loop of Section 4.

Nothing here imports the trust layer.
"""

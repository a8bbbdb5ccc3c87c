"""The math core: angles, rotations, Bernstein polynomials, interval arithmetic, enclosures of cos and sin.

Pure functions on numpy arrays; nothing here knows a mechanism.
"""

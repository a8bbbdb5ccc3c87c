"""Exact building blocks of the verification, written from the definitions with sympy.

Nothing here calls spherekin: these are the independent references the paper's formulas (and
spherekin's implementation of them) are checked against.

* The normalized factor of Eq. (2) multiplied by q = 1 + t^2 (tangent-half-angle substitution
  t = tan(theta/2), Section 2.2) is the polynomial matrix

      q Rx(phi) Z = [[0, -q, 0], [c, 0, -s], [s, 0, c]],   c = q cos(phi), s = q sin(phi).

  For phi = d + sign * theta:  c = cos d (1 - t^2) - sign sin d (2t),
                               s = sin d (1 - t^2) + sign cos d (2t).
* :func:`bernstein_coefficients` converts a polynomial of degree <= m in each variable to the
  tensor-product Bernstein basis of Section 3, B_I(t) = prod_k C(m, i_k) t_k^i_k (1 - t_k)^(m - i_k),
  by the change of basis t^j = sum_{i >= j} [C(i, j) / C(m, j)] b_{i,m}(t) applied along each axis;
  :func:`bernstein_polynomial` expands a Bernstein tensor back (used to test the conversion).
"""

from __future__ import annotations

import itertools
from fractions import Fraction
from math import comb
from typing import Sequence

import numpy as np
import sympy as sp

__all__ = [
    "DEGREE",
    "Z_SYM",
    "rx_sym",
    "rz_sym",
    "ry_sym",
    "unit_factor",
    "shifted_factor",
    "known_factor",
    "factor_matrix",
    "matmul",
    "chain",
    "closure_polynomials",
    "to_number",
    "bernstein_coefficients",
    "bernstein_polynomial",
    "chi",
    "sigma_index",
    "sigma_inverse_index",
    "permute_indices",
]

#: Degree of every closure polynomial in each tangent-half-angle variable (Section 3: M = (2,...,2)).
DEGREE = 2

Z_SYM = sp.Matrix([[0, -1, 0], [1, 0, 0], [0, 0, 1]])


def rx_sym(a) -> sp.Matrix:
    """Rx(a) as a sympy Matrix (right-handed, active)."""
    return sp.Matrix([[1, 0, 0], [0, sp.cos(a), -sp.sin(a)], [0, sp.sin(a), sp.cos(a)]])


def rz_sym(a) -> sp.Matrix:
    """Rz(a) as a sympy Matrix (right-handed, active)."""
    return sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])


def ry_sym(a) -> sp.Matrix:
    """Ry(a) as a sympy Matrix (right-handed, active)."""
    return sp.Matrix([[sp.cos(a), 0, sp.sin(a)], [0, 1, 0], [-sp.sin(a), 0, sp.cos(a)]])


def unit_factor(t: sp.Symbol, gens: Sequence[sp.Symbol]) -> tuple[sp.Poly, sp.Poly, sp.Poly]:
    """(q, c, s) = (1 + t^2, 1 - t^2, 2t) as Polys in ``gens``: phi itself is the unknown, t = tan(phi/2)."""
    return (sp.Poly(1 + t**2, *gens, domain="QQ"), sp.Poly(1 - t**2, *gens, domain="QQ"),
            sp.Poly(2 * t, *gens, domain="QQ"))


def shifted_factor(t, cos_d, sin_d, sign, gens, domain="QQ") -> tuple[sp.Poly, sp.Poly, sp.Poly]:
    """(q, c, s) of phi = d + sign * theta with t = tan(theta/2), cos d and sin d given."""
    one_minus, two_t = 1 - t**2, 2 * t
    q = sp.Poly(1 + t**2, *gens, domain=domain)
    c = sp.Poly(cos_d * one_minus - sign * sin_d * two_t, *gens, domain=domain)
    s = sp.Poly(sin_d * one_minus + sign * cos_d * two_t, *gens, domain=domain)
    return q, c, s


def known_factor(cos_phi, sin_phi, gens, domain="QQ") -> tuple[sp.Poly, sp.Poly, sp.Poly]:
    """(q, c, s) = (1, cos phi, sin phi) of a known angle (no tangent half-angle is taken)."""
    return (sp.Poly(1, *gens, domain=domain), sp.Poly(cos_phi, *gens, domain=domain),
            sp.Poly(sin_phi, *gens, domain=domain))


def factor_matrix(q, c, s) -> list[list]:
    """q Rx(phi) Z = [[0, -q, 0], [c, 0, -s], [s, 0, c]] as a 3x3 list (entries keep their type)."""
    zero = q * 0
    return [[zero, -q, zero], [c, zero, -s], [s, zero, c]]


def matmul(a: list[list], b: list[list]) -> list[list]:
    """Product of two 3x3 lists of ring elements (sympy Polys, exprs, Fractions)."""
    return [[a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] for j in range(3)]
            for i in range(3)]


def chain(factors: Sequence[tuple]) -> tuple[list[list], object]:
    """prod_k q_k Rx(phi_k) Z and prod_k q_k for factors given as (q, c, s) triples."""
    q0 = factors[0][0]
    one, zero = q0 ** 0, q0 * 0
    out = [[one if i == j else zero for j in range(3)] for i in range(3)]
    qn = one
    for q, c, s in factors:
        out = matmul(out, factor_matrix(q, c, s))
        qn = qn * q
    return out, qn


def closure_polynomials(n: int) -> tuple[list[list], sp.Poly, tuple[sp.Symbol, ...]]:
    """Fbar = q_n F_n (Section 2.2) of n unknown factors phi_k = theta_k, t_k = tan(theta_k/2).

    Returns (Fbar as a 3x3 list of Polys over QQ in t_1..t_n, q_n, (t_1..t_n)). Built from the
    definition: the ordered product of the polynomial matrices (1 + t_k^2) Rx(phi_k) Z.
    """
    if not isinstance(n, int) or n < 1:
        raise ValueError(f"n: expected an integer >= 1, got {n!r}")
    ts = sp.symbols(f"t1:{n + 1}")
    mat, qn = chain([unit_factor(t, ts) for t in ts])
    return mat, qn, ts


def to_number(value, exact: bool):
    """A sympy coefficient as a Fraction (exact) or a float."""
    if exact:
        value = sp.Rational(value)
        return Fraction(int(value.p), int(value.q))
    return float(value)


def bernstein_coefficients(poly: sp.Poly, degree: int = DEGREE, exact: bool | None = None) -> np.ndarray:
    """Control points c_I of ``poly`` in the tensor-product Bernstein basis of degree ``degree`` per
    variable (one axis per generator of ``poly``), as an object array of Fractions (exact) or floats.

    Implements the change of basis of Section 3 from the monomials:
    t^j = sum_{i=j..m} C(i, j)/C(m, j) b_{i,m}(t), applied along every axis.
    ``exact=None`` means exact when the polynomial's domain is ZZ or QQ.
    """
    if not isinstance(poly, sp.Poly):
        raise ValueError(f"poly: expected a sympy Poly, got {type(poly).__name__}")
    n = len(poly.gens)
    if exact is None:
        exact = poly.domain.is_ZZ or poly.domain.is_QQ
    degs = poly.degree_list() if not poly.is_zero else (0,) * n
    if any(d > degree for d in degs):
        raise ValueError(f"poly: expected degree <= {degree} in every variable, got degrees {degs}")
    zero = Fraction(0) if exact else 0.0
    power = np.full((degree + 1,) * n, zero, dtype=object)
    for monom, coeff in poly.terms():
        power[monom] = to_number(coeff, exact)
    basis = np.array([[Fraction(comb(i, j), comb(degree, j)) if j <= i else Fraction(0)
                       for j in range(degree + 1)] for i in range(degree + 1)], dtype=object)
    if not exact:
        basis = basis.astype(float).astype(object)
    out = power
    for axis in range(n):
        moved = np.moveaxis(out, axis, -1)
        out = np.moveaxis(moved @ basis.T, -1, axis)
    return out


def bernstein_polynomial(coeffs: np.ndarray, gens: Sequence[sp.Symbol], degree: int = DEGREE) -> sp.Poly:
    """sum_I c_I B_I(t) expanded (the inverse of :func:`bernstein_coefficients`), exact."""
    coeffs = np.asarray(coeffs, dtype=object)
    if coeffs.ndim != len(gens) or any(k != degree + 1 for k in coeffs.shape):
        raise ValueError(f"coeffs: expected shape {(degree + 1,) * len(gens)}, got {coeffs.shape}")
    total = sp.Poly(0, *gens, domain="QQ")
    basis = [[sp.Poly(comb(degree, i) * g**i * (1 - g) ** (degree - i), *gens, domain="QQ")
              for i in range(degree + 1)] for g in gens]
    for idx in itertools.product(range(degree + 1), repeat=len(gens)):
        c = coeffs[idx]
        if c == 0:
            continue
        term = sp.Poly(sp.Rational(c.numerator, c.denominator) if isinstance(c, Fraction) else c,
                       *gens, domain="QQ")
        for k, i in enumerate(idx):
            term = term * basis[k][i]
        total = total + term
    return total


def chi(index: Sequence[int]) -> int:
    """chi(I) of Prop. 1: the number of entries of I equal to 2."""
    return sum(1 for i in index if i == DEGREE)


def sigma_index(index: Sequence[int]) -> tuple[int, ...]:
    """I^sigma = (i_n, i_1, ..., i_{n-1}) as defined in Section 3."""
    index = tuple(index)
    return index[-1:] + index[:-1]


def sigma_inverse_index(index: Sequence[int]) -> tuple[int, ...]:
    """The opposite shift (i_2, ..., i_n, i_1), used to show the direction of Section 3's shift matters."""
    index = tuple(index)
    return index[1:] + index[:1]


def permute_indices(coeffs: np.ndarray, rule) -> np.ndarray:
    """out[I] = coeffs[rule(I)] for every multi-index I."""
    out = np.empty_like(coeffs)
    for idx in itertools.product(*(range(k) for k in coeffs.shape)):
        out[idx] = coeffs[rule(idx)]
    return out

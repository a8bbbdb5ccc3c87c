"""PHCpack's blackbox solver (``phc -b``) on the 3-RRR direct kinematics: systems in, solutions out.

Two polynomial systems per problem (see ``bench_peers.py``):

* :func:`sincos_system` -- the loop equations spherekin solves, in sin/cos form, derived here with
  sympy from the loop factors (``ClosureLoop.factors``): each unknown passive angle theta_k becomes
  (c_k, s_k) with c_k^2 + s_k^2 - 1 = 0, each factor Rx(phi) Z with phi = offset + sign theta_k has
  cos phi = cos(offset) c_k - sign sin(offset) s_k and sin phi = sin(offset) c_k + sign cos(offset) s_k,
  and each loop contributes the strictly lower-triangular entries (2,1), (3,1), (3,2) of
  prod Rx(phi_i) Z. An upper-triangular rotation is diagonal, so these vanish at closure (F = I) and
  also at the spurious F = diag(1,-1,-1), diag(-1,1,-1), diag(-1,-1,1): :func:`loop_closes` tells them
  apart. sympy is imported only here (the whole-process timing of PHC does not need it).
* :func:`quaternion_system` -- the three leg quadrics of ``peers_closed_form`` plus |q|^2 = 1.

:func:`run_phc` writes a system in PHCpack's input format, runs ``phc -b`` on it in a fresh
temporary folder and parses the solution list that phc appends to its input file, complex and
spurious roots included (:class:`PhcRoot`).
"""

from __future__ import annotations

import math
import os
import re
import resource
import shutil
import subprocess
import tempfile
import time
from dataclasses import dataclass, field

import numpy as np

__all__ = ["PHC", "PHC_SEED", "COEF_SNAP", "IMAG_TOL", "CLOSURE_TOL", "PhcError", "PhcRoot", "PhcRun",
           "phc_available", "poly_to_phc", "system_to_phc", "run_phc", "parse_solutions",
           "quaternion_system", "sincos_system", "loop_closes"]

#: The PHCpack executable (Debian package ``phcpack``).
PHC = "phc"
#: phc's random seed (``phc -0SEED``): the start system and the gamma trick are random; a fixed
#: seed makes the path count, the timing and the solution order reproducible.
PHC_SEED = 20240611
#: |cos| or |sin| of a known angle (or offset) below this is taken as exactly 0. Reason: float
#: multiples of pi/2 have cosines or sines of ~1e-16 instead of 0; keeping them would add spurious
#: monomials with 1e-16 coefficients (the equations change by < 1e-14, far below every tolerance).
COEF_SNAP = 1e-14
#: A root of PHCpack is real when every imaginary part is below this. Reason: phc refines regular
#: roots to ~1e-15 (its "err" column) and prints imaginary parts of ~1e-16..1e-30 for real ones,
#: while genuinely complex roots of these systems have imaginary parts of order 1e-2 or more.
IMAG_TOL = 1e-6
#: A real root of the sin/cos system closes loop k when max |F_k - I| is below this. Reason: roots
#: that really close do so to ~1e-14 after refinement; the spurious ones (F_k = diag(1,-1,-1), ...)
#: miss by 2, so any value in between works; 1e-6 matches the pose tolerance of the comparison.
CLOSURE_TOL = 1e-6


class PhcError(RuntimeError):
    """phc failed, timed out, or printed no solution list."""


def phc_available() -> bool:
    return shutil.which(PHC) is not None


# --------------------------------------------------------------------------------------------
# Writing systems
# --------------------------------------------------------------------------------------------

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def _check_names(names) -> None:
    for n in names:
        if not _NAME.match(n) or n[0] in "eEiI":
            raise ValueError(f"variable {n!r}: PHCpack names start with a letter other than e, E (exponents), "
                             "i, I (the imaginary unit) and contain letters, digits, '_'")


def poly_to_phc(terms: dict, names) -> str:
    """One polynomial as PHCpack text: ``terms`` maps exponent tuples (one per name) to real coefficients."""
    _check_names(names)
    parts = []
    for exps, coef in sorted(terms.items(), reverse=True):
        if coef == 0:
            continue
        mono = "".join(f"*{n}" if e == 1 else f"*{n}^{e}" for n, e in zip(names, exps) if e)
        parts.append(f"{float(coef):+.17E}{mono}")
    if not parts:
        raise ValueError("terms: the polynomial is identically zero")
    return " " + "\n ".join(parts) + ";"


def system_to_phc(polys, names) -> str:
    """A square system in PHCpack's input format (``N`` then N polynomials ending in ';')."""
    if len(polys) != len(names):
        raise ValueError(f"polys: expected a square system, got {len(polys)} equations in {len(names)} unknowns")
    return f"{len(polys)}\n" + "\n".join(poly_to_phc(p, names) for p in polys) + "\n"


def quaternion_system(quadrics: np.ndarray) -> tuple[list[dict], list[str]]:
    """q^T A_i q = 0 (i = 1..3) and q0^2 + qx^2 + qy^2 + qz^2 - 1 = 0, in variables q0, qx, qy, qz."""
    names = ["q0", "qx", "qy", "qz"]
    polys = []
    for a in quadrics:
        terms = {}
        for i in range(4):
            for j in range(i, 4):
                e = [0, 0, 0, 0]
                e[i] += 1
                e[j] += 1
                terms[tuple(e)] = float(a[i, j] if i == j else 2 * a[i, j])
        polys.append(terms)
    unit = {tuple(2 * (j == k) for j in range(4)): 1.0 for k in range(4)}
    unit[(0, 0, 0, 0)] = -1.0
    polys.append(unit)
    return polys, names


def _snap_cos_sin(angle: float) -> tuple[float, float]:
    c, s = math.cos(angle), math.sin(angle)
    if abs(c) < COEF_SNAP:
        c, s = 0.0, math.copysign(1.0, s)
    elif abs(s) < COEF_SNAP:
        c, s = math.copysign(1.0, c), 0.0
    return c, s


def sincos_system(loops, unknown_names):
    """The sin/cos system of the closure loops, derived with sympy.

    ``loops``: ClosureLoop objects (their ``factors``: floats and Terms with ``unknown.name``,
    ``offset``, ``sign``); ``unknown_names``: the passive unknowns, in the order of the variables
    c1, s1, c2, s2, ... Products are expanded in a sympy polynomial ring over the reals (exact
    bookkeeping of monomials, float coefficients). Returns (polys as {exponent tuple: coefficient},
    variable names, the sympy expressions, the sympy symbols (c_k, s_k) per unknown).
    """
    import sympy as sp
    from sympy.polys.domains import RR
    from sympy.polys.rings import ring

    k_of = {n: k for k, n in enumerate(unknown_names)}
    names = [f"{p}{k + 1}" for k in range(len(unknown_names)) for p in "cs"]
    R, *gens = ring(",".join(names), RR)
    cs = list(zip(gens[0::2], gens[1::2]))
    zero, one = R.zero, R.one
    exprs = []
    for li, loop in enumerate(loops):
        prod = [[one, zero, zero], [zero, one, zero], [zero, zero, one]]
        for f in loop.factors:
            if hasattr(f, "unknown"):
                if f.unknown.name not in k_of:
                    raise ValueError(f"loops[{li}]: unknown {f.unknown.name!r} not in unknown_names {unknown_names}")
                c, s = cs[k_of[f.unknown.name]]
                co, so = _snap_cos_sin(f.offset)
                cphi = co * c - f.sign * so * s
                sphi = so * c + f.sign * co * s
            else:
                co, so = _snap_cos_sin(float(f))
                cphi, sphi = co * one, so * one
            fac = [[zero, -one, zero], [cphi, zero, -sphi], [sphi, zero, cphi]]
            prod = [[sum((prod[i][k] * fac[k][j] for k in range(3)), zero) for j in range(3)] for i in range(3)]
        exprs += [prod[1][0], prod[2][0], prod[2][1]]
    exprs += [c * c + s * s - 1 for c, s in cs]
    polys = [{m: float(v) for m, v in e.items() if float(v) != 0.0} for e in exprs]
    symbols = [sp.Symbol(n) for n in names]
    return polys, names, [e.as_expr(*symbols) for e in exprs], list(zip(symbols[0::2], symbols[1::2]))


def loop_closes(loops, unknown_names, theta, tol: float = CLOSURE_TOL) -> bool:
    """Does every loop close (max |prod Rx(phi_i) Z - I| <= tol) at passive angles ``theta`` (radians)?"""
    k_of = {n: k for k, n in enumerate(unknown_names)}
    for loop in loops:
        prod = np.eye(3)
        for f in loop.factors:
            phi = f.offset + f.sign * theta[k_of[f.unknown.name]] if hasattr(f, "unknown") else float(f)
            prod = prod @ np.array([[0.0, -1.0, 0.0], [math.cos(phi), 0.0, -math.sin(phi)],
                                    [math.sin(phi), 0.0, math.cos(phi)]])
        if np.abs(prod - np.eye(3)).max() > tol:
            return False
    return True


# --------------------------------------------------------------------------------------------
# Running phc and reading its answer
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class PhcRoot:
    """One root printed by phc: complex coordinates (variable order of the system) and phc's diagnostics."""

    values: np.ndarray
    err: float
    rco: float
    res: float
    kind: str  # phc's label when it prints one ("real regular", ...), else ""

    def is_real(self, tol: float = IMAG_TOL) -> bool:
        return bool(np.abs(self.values.imag).max() <= tol)


@dataclass(frozen=True)
class PhcRun:
    roots: list
    wall: float
    cpu: float       # user + system CPU of the phc process (RUSAGE_CHILDREN delta)
    paths: int | None
    summary: dict = field(default_factory=dict)


_SOL_HEAD = re.compile(r"^solution\s+\d+\s*:")
_VAR = re.compile(r"^\s*([A-Za-z][A-Za-z0-9_]*)\s*:\s*(\S+)\s+(\S+)\s*$")
_DIAG = re.compile(r"err\s*:\s*(\S+)\s*=\s*rco\s*:\s*(\S+)\s*=\s*res\s*:\s*(\S+)\s*=*\s*(.*?)\s*=*\s*$")


def parse_solutions(text: str, names) -> list[PhcRoot]:
    """The last solution list ("THE SOLUTIONS :" block) of a phc file, roots in the order of ``names``."""
    at = text.rfind("THE SOLUTIONS")
    if at < 0:
        raise PhcError("phc printed no solution list ('THE SOLUTIONS' not found)")
    lines = text[at:].splitlines()
    head = lines[1].split()
    count = int(head[0])
    roots, cur = [], None
    for line in lines[2:]:
        if _SOL_HEAD.match(line):
            cur = {}
            continue
        if cur is None:
            continue
        m = _VAR.match(line)
        if m and m.group(1) in names:
            cur[m.group(1)] = complex(float(m.group(2)), float(m.group(3)))
            continue
        if line.startswith("=="):
            d = _DIAG.search(line)
            if d is None or set(cur) != set(names):
                raise PhcError(f"cannot parse phc's solution {len(roots) + 1}: {line!r} (variables {sorted(cur)})")
            roots.append(PhcRoot(np.array([cur[n] for n in names]), float(d.group(1)), float(d.group(2)),
                                 float(d.group(3)), d.group(4).strip(" =")))
            cur = None
    if len(roots) != count:
        raise PhcError(f"phc announced {count} solutions, parsed {len(roots)}")
    return roots


def _summary(out: str) -> dict:
    keys = {"regular": "Number of regular solutions", "singular": "Number of singular solutions",
            "real": "Number of real solutions", "complex": "Number of complex solutions",
            "at_infinity": "Number of solutions at infinity", "failures": "Number of failures"}
    res = {}
    for k, label in keys.items():
        m = list(re.finditer(re.escape(label) + r"\s*:\s*(\d+)", out))
        if m:
            res[k] = int(m[-1].group(1))
    return res


def run_phc(polys, names, *, timeout: float | None = None, keep: str | None = None) -> PhcRun:
    """Solve a square system with ``phc -b`` (fixed seed, one task); parse every root it returns.

    ``timeout`` (seconds) raises PhcError when exceeded (the phc process is killed). ``keep``: a
    folder to copy phc's input and output files to (for inspection).
    """
    if not phc_available():
        raise PhcError(f"'{PHC}' not found on PATH: install PHCpack (Debian: apt-get install -y phcpack)")
    text = system_to_phc(polys, names)
    with tempfile.TemporaryDirectory(prefix="phc_") as tmp:
        inp, out = os.path.join(tmp, "system.phc"), os.path.join(tmp, "system.out")
        with open(inp, "w") as fh:
            fh.write(text)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        try:
            proc = subprocess.run([PHC, "-b", f"-0{PHC_SEED}", inp, out], stdin=subprocess.DEVNULL,
                                  capture_output=True, text=True, timeout=timeout, cwd=tmp)
        except subprocess.TimeoutExpired:
            raise PhcError(f"phc -b exceeded the time cap of {timeout:.0f} s") from None
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        if proc.returncode != 0:
            raise PhcError(f"phc -b exited with code {proc.returncode}: {(proc.stderr or proc.stdout)[-500:]}")
        with open(inp) as fh:
            solved = fh.read()
        with open(out) as fh:
            report = fh.read()
        if keep:
            os.makedirs(keep, exist_ok=True)
            shutil.copy(inp, os.path.join(keep, "system.phc"))
            shutil.copy(out, os.path.join(keep, "system.out"))
    roots = parse_solutions(solved, names)
    start = re.search(r"START SOLUTIONS\s*:\s*(\d+)\s+\d+", report)
    paths = int(start.group(1)) if start else None   # paths tracked = start solutions
    return PhcRun(roots, wall, cpu, paths, _summary(report))

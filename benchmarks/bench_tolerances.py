"""The mechanism as built (issue 45): certified worst-case bounds against Monte Carlo, in time and in size.

    python -m benchmarks.bench_tolerances [--inputs 100] [--axes-deg 0.1] [--inputs-deg 0.01]
                                          [--mc-inputs 10] [--mc-samples 100000]

For the Gosselin platform (the agile eye) and general_3rrr, at ``--inputs`` seeded inputs (uniform in
[-pi, pi)^3), each mechanism with ``[tolerances] axes_deg, inputs_deg``:

* ``certified``: ``spherekin.compile(mech).solve(x)`` with the tolerances, timed apart from the nominal
  solve (``report.tolerances``: :func:`spherekin.trust.tolerances.analyse`): seconds per input; per
  assembly the proven bound over the searched lower bound (a geometry within the tolerances, solved:
  the truth lies between them; median and largest); the share of inputs whose count is proven constant
  over the tolerances, proven to change (a singular configuration within them), undecided;
* ``Monte Carlo``: on the first ``--mc-inputs`` inputs, ``--mc-samples`` geometries per input drawn
  uniformly in the cones (and inputs uniformly in their intervals), each assembly of each solved by
  Newton's method from the nominal pose (vectorized over the samples; code of its own here): seconds
  per input, and the largest sampled error over the certified bound and over the lower bound (a
  sampling estimate falls short of the worst case; it proves nothing).

Prints a table and writes benchmarks/results/tolerances.json (the tolerances and seeds with the numbers).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import spherekin  # noqa: E402
from spherekin.mechanism import Tolerances, general_3rrr, gosselin  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SEED = 45
MECHANISMS = {"gosselin": gosselin, "general_3rrr": general_3rrr}
#: Newton steps of the Monte Carlo solves (from the nominal pose: the perturbation is ~1e-2 rad, so
#: quadratic convergence reaches rounding in ~5; 8 for margin; a sample not converged is reported).
MC_NEWTON_STEPS = 8
#: Samples per vectorized block (memory: ~100 floats a sample).
MC_BLOCK = 20_000


def _skew(w):
    z = np.zeros(w.shape[:-1])
    return np.stack([np.stack([z, -w[..., 2], w[..., 1]], -1), np.stack([w[..., 2], z, -w[..., 0]], -1),
                     np.stack([-w[..., 1], w[..., 0], z], -1)], -2)


def _exp(w):
    """Rotation matrices (N, 3, 3) of rotation vectors w (N, 3)."""
    angle = np.linalg.norm(w, axis=-1)[..., None, None]
    k = _skew(w / np.where(angle[..., 0] > 0, angle[..., 0], 1.0))
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def _rodrigues(axis, angle, v):
    """v (N, 3) turned about unit axes (N, 3) by angles (N,)."""
    c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
    return v * c + np.cross(axis, v) * s + axis * np.sum(axis * v, axis=1, keepdims=True) * (1.0 - c)


def _cone_samples(a, delta, n, rng):
    """n unit vectors uniform over the cone of half-angle delta about a (3,)."""
    cos_t = rng.uniform(math.cos(delta), 1.0, n)               # uniform in solid angle
    phi = rng.uniform(0.0, 2.0 * math.pi, n)
    u1 = np.cross(a, np.eye(3)[np.argmin(np.abs(a))])
    u1 /= np.linalg.norm(u1)
    u2 = np.cross(a, u1)
    sin_t = np.sqrt(1.0 - cos_t ** 2)
    return cos_t[:, None] * a + sin_t[:, None] * (np.cos(phi)[:, None] * u1 + np.sin(phi)[:, None] * u2)


def monte_carlo(mech, x, rotations, axes_deg, inputs_deg, samples, rng):
    """(largest sampled error per assembly (A,), samples not converged): ``samples`` geometries."""
    delta, eps = math.radians(axes_deg), math.radians(inputs_deg)
    ref = np.asarray(mech.platform_reference_matrix)
    d0s = [np.asarray(r) @ ref.T for r in rotations]
    worst = np.zeros(len(d0s))
    failed = 0
    for start in range(0, samples, MC_BLOCK):
        n = min(MC_BLOCK, samples - start)
        legs = []
        for i, leg in enumerate(mech.legs):
            u, w, v = (np.asarray(j.axis, dtype=float) for j in leg.joints)
            c = float(w @ v)                                   # the distal link angle as given
            uu, ww, vv = (_cone_samples(a, delta, n, rng) for a in (u, w, v))
            beta = x[i] - leg.joints[0].reference_angle + rng.uniform(-eps, eps, n)
            legs.append((_rodrigues(uu, beta, ww), vv, c))
        for k, d0 in enumerate(d0s):
            def residual(wv):
                d = _exp(wv) @ d0
                return np.stack([np.einsum("ni,nij,nj->n", e, d, b) - c for e, b, c in legs], axis=1)

            wv = np.zeros((n, 3))
            for _ in range(MC_NEWTON_STEPS):
                f = residual(wv)
                jac = np.stack([(residual(wv + h) - residual(wv - h)) / 2e-7 for h in np.eye(3) * 1e-7], axis=2)
                wv = wv - np.linalg.solve(jac, f[..., None])[..., 0]
            ok = np.max(np.abs(residual(wv)), axis=1) < 1e-10
            failed += int((~ok).sum())
            worst[k] = max(worst[k], float(np.linalg.norm(wv[ok], axis=1).max(initial=0.0)))
    return worst, failed


def run(n_inputs, axes_deg, inputs_deg, mc_inputs, mc_samples) -> list[dict]:
    out = []
    for index, (label, build) in enumerate(MECHANISMS.items()):
        nominal = build()
        built = dataclasses.replace(nominal, tolerances=Tolerances(axes_deg, inputs_deg))
        plain, problem = spherekin.compile(nominal), spherekin.compile(built)
        rows = np.random.default_rng([SEED, index]).uniform(-math.pi, math.pi, (n_inputs, 3))
        t_plain, t_built, ratios, verdicts, unproven, assemblies = [], [], [], [], 0, 0
        mc_time, mc_over_bound, mc_over_low, mc_failed = [], [], [], 0
        plain.solve(rows[0]), problem.solve(rows[0])                     # warm-up
        for k, x in enumerate(rows):
            t0 = time.perf_counter()
            plain.solve(x)
            t1 = time.perf_counter()
            report = problem.solve(x)
            t2 = time.perf_counter()
            t_plain.append(t1 - t0)
            t_built.append(t2 - t1)
            tr = report.tolerances
            verdicts.append(tr.count_constant_over_tolerances)
            for a in tr.assemblies:
                assemblies += 1
                if a.tightness is None:
                    unproven += 1
                else:
                    ratios.append(a.tightness)
            if k < mc_inputs:
                sols = [(s, a) for s, a in zip(report.solutions, tr.assemblies) if a.tightness is not None]
                t0 = time.perf_counter()
                worst, failed = monte_carlo(nominal, x, [s.platform_rotation for s, _ in sols], axes_deg, inputs_deg,
                                            mc_samples, np.random.default_rng([SEED, index, k]))
                mc_time.append(time.perf_counter() - t0)
                mc_failed += failed
                for (s, a), w in zip(sols, worst):
                    mc_over_bound.append(w / a.worst_case_rotation_error)
                    mc_over_low.append(w / a.worst_case_rotation_error_lower_bound)
        analysis = [b - a for a, b in zip(t_plain, t_built)]
        row = dict(mechanism=label, inputs=n_inputs, axes_deg=axes_deg, inputs_deg=inputs_deg, seed=[SEED, index],
                   seconds_per_input_nominal=statistics.median(t_plain),
                   seconds_per_input_with_tolerances=statistics.median(t_built),
                   seconds_per_input_analysis=statistics.median(analysis),
                   assemblies=assemblies, assemblies_unproven=unproven,
                   bound_over_lower_median=statistics.median(ratios) if ratios else None,
                   bound_over_lower_max=max(ratios) if ratios else None,
                   count_constant_share=sum(v is True for v in verdicts) / n_inputs,
                   count_changes_share=sum(v is False for v in verdicts) / n_inputs,
                   count_undecided_share=sum(v is None for v in verdicts) / n_inputs,
                   mc_inputs=min(mc_inputs, n_inputs), mc_samples=mc_samples,
                   mc_seconds_per_input=statistics.median(mc_time) if mc_time else None,
                   mc_over_bound_median=statistics.median(mc_over_bound) if mc_over_bound else None,
                   mc_over_bound_max=max(mc_over_bound) if mc_over_bound else None,
                   mc_over_lower_median=statistics.median(mc_over_low) if mc_over_low else None,
                   mc_over_lower_max=max(mc_over_low) if mc_over_low else None, mc_not_converged=mc_failed)
        out.append(row)
        print(f"{label}: done", flush=True)
    return out


def print_table(rows) -> None:
    head = (f"{'mechanism':13s} {'inputs':>6s} {'s/input':>8s} {'nominal':>8s} {'bound/low':>13s} {'unproven':>9s} "
            f"{'constant':>8s} {'changes':>7s} {'undecided':>9s} {'MC s/input':>10s} {'MC/bound':>13s} {'MC/low':>13s}")
    print(head)
    print("-" * len(head))
    for r in rows:
        mc_b = (f"{r['mc_over_bound_median']:.3f}/{r['mc_over_bound_max']:.3f}" if r["mc_over_bound_median"] else "-")
        mc_l = (f"{r['mc_over_lower_median']:.3f}/{r['mc_over_lower_max']:.3f}" if r["mc_over_lower_median"] else "-")
        mc_t = f"{r['mc_seconds_per_input']:.2f}" if r["mc_seconds_per_input"] else "-"
        print(f"{r['mechanism']:13s} {r['inputs']:6d} {r['seconds_per_input_analysis']:8.3f} "
              f"{r['seconds_per_input_nominal']:8.4f} {r['bound_over_lower_median']:6.3f}/{r['bound_over_lower_max']:6.3f} "
              f"{r['assemblies_unproven']:4d}/{r['assemblies']:<4d} {r['count_constant_share']:8.0%} "
              f"{r['count_changes_share']:7.0%} {r['count_undecided_share']:9.0%} {mc_t:>10s} {mc_b:>13s} {mc_l:>13s}")
    print("s/input: the tolerance analysis alone (median; the nominal solve beside it); bound/low: the certified "
          "bound over the searched lower bound, median/largest over the proven assemblies; unproven: assemblies "
          "without a proven bound of all; constant/changes/undecided: inputs whose count is proven constant, "
          "proven to change, undecided; MC: the largest error of the Monte Carlo samples over the certified bound "
          "and over the lower bound (median/largest over the assemblies)")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--inputs", type=int, default=100, help="seeded inputs per mechanism")
    parser.add_argument("--axes-deg", type=float, default=0.1, help="each joint axis's cone (degrees)")
    parser.add_argument("--inputs-deg", type=float, default=0.01, help="each input's interval (degrees)")
    parser.add_argument("--mc-inputs", type=int, default=10, help="inputs also sampled by Monte Carlo")
    parser.add_argument("--mc-samples", type=int, default=100_000, help="Monte Carlo geometries per input")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "tolerances.json")
    args = parser.parse_args(argv)
    for key in ("inputs", "mc_samples"):
        if getattr(args, key) < 1:
            parser.error(f"--{key.replace('_', '-')}: expected a whole number >= 1, got {getattr(args, key)}")
    if args.mc_inputs < 0:
        parser.error(f"--mc-inputs: expected a whole number >= 0, got {args.mc_inputs}")
    try:
        Tolerances(args.axes_deg, args.inputs_deg)
    except ValueError as exc:
        parser.error(str(exc))
    try:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        parser.error(f"--out: cannot create {args.out.parent}: {exc}")
    print(f"{args.inputs} inputs per mechanism (seed {SEED}), axes {args.axes_deg} deg, inputs {args.inputs_deg} deg; "
          f"Monte Carlo {args.mc_samples} samples on {args.mc_inputs} inputs; one core; Python "
          f"{platform.python_version()}, numpy {np.__version__}; load average {os.getloadavg()[0]:.1f}", flush=True)
    rows = run(args.inputs, args.axes_deg, args.inputs_deg, args.mc_inputs, args.mc_samples)
    print_table(rows)
    machine = dict(python=platform.python_version(), numpy=np.__version__, cpus=os.cpu_count(),
                   load_average=os.getloadavg(), date=time.strftime("%Y-%m-%d %H:%M"))
    args.out.write_text(json.dumps(dict(benchmark="tolerances", machine=machine, rows=rows), indent=2))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

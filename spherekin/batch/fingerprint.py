"""What wrote a batch output: the fingerprint ``--resume`` compares before it completes a file.

A :class:`Fingerprint` holds the mechanism (its canonical TOML text, :func:`dumps_mechanism`: two
files that load to the same mechanism give the same text, comments and layout aside), the inputs
(their number and a SHA-256 of their float64 values in the job's order, with a description: the CSV
file or the grid specs), the strategy as resolved by :func:`spherekin.compile` (formulation,
pruner, lp_backend, parameterization, tol, isolate, max_boxes, max_depth: every setting that can
change a row; ``jobs`` cannot) and the spherekin version. A Parquet part carries it in its schema
metadata (key ``spherekin.fingerprint``), a CSV file in a sidecar ``<file>.spherekin.json`` (the CSV
itself stays a plain table). docs/results-format.md describes both.

A file is completed only by the job that wrote it: every part of the fingerprint must be equal,
the version too (another version may give other rows for the same input: a table mixing two
versions would be one that no version writes).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from typing import Mapping

import numpy as np

from ..mechanism.io import dumps_mechanism

__all__ = ["SCHEMA", "METADATA_KEY", "SIDECAR_SUFFIX", "STRATEGY_FIELDS", "Fingerprint", "strategy_of",
           "sidecar_path",
           "describe_inputs"]

#: The fingerprint's own format (its JSON ``schema``).
SCHEMA = "spherekin.fingerprint/1"
#: The key of the fingerprint (JSON text) in a Parquet part's schema metadata.
METADATA_KEY = b"spherekin.fingerprint"
#: The sidecar of a CSV output: the CSV's name with this appended.
SIDECAR_SUFFIX = ".spherekin.json"
#: The strategy settings a fingerprint records (those of :class:`spherekin.problem.Strategy` that
#: can change a row: ``jobs`` only says how many processes share a solve).
STRATEGY_FIELDS = ("formulation", "pruner", "lp_backend", "parameterization", "tol", "isolate", "max_boxes",
                   "max_depth")
#: Longest text of one differing mechanism line quoted in an error (a vector line is ~100 characters).
QUOTE_CHARS = 120


def sidecar_path(path):
    """The fingerprint sidecar of the CSV output ``path`` (a Path)."""
    return path.with_name(path.name + SIDECAR_SUFFIX)


def strategy_of(problem) -> dict:
    """The strategy a fingerprint records, from a compiled :class:`spherekin.problem.Problem`
    (``formulation`` resolved: "auto" is recorded as what it chose)."""
    return {name: getattr(problem.strategy, name) for name in STRATEGY_FIELDS}


def describe_inputs(inputs) -> str:
    """Where an :class:`~spherekin.batch.inputs.InputSet` came from, for a message: its grid specs
    and fixed joints, or its source (the CSV file, "array")."""
    if inputs.axes:
        return "grid " + " ".join([a.spec for a in inputs.axes] + [f"{k}={v:.6g}" for k, v in inputs.fixed.items()])
    return str(inputs.source)


def _inputs_hash(inputs: np.ndarray) -> str:
    values = np.ascontiguousarray(inputs, dtype="<f8")
    return hashlib.sha256(repr(values.shape).encode() + values.tobytes()).hexdigest()


@dataclass(frozen=True)
class Fingerprint:
    """What wrote an output (module doc). ``strategy``: (name, value) pairs of STRATEGY_FIELDS, or
    () for an output not written by a batch (``spherekin track --out``)."""

    version: str
    mechanism_toml: str
    n_inputs: int
    inputs_sha256: str
    inputs_source: str
    strategy: tuple[tuple[str, object], ...]

    @classmethod
    def of(cls, mechanism, inputs: np.ndarray, strategy: Mapping | None = None, source: str = "") -> "Fingerprint":
        """The fingerprint of a job: ``mechanism``, ``inputs`` (K, A) radians, ``strategy`` (name ->
        value, :func:`strategy_of`; None: not a batch), ``source`` (where the inputs came from)."""
        from .. import __version__

        strategy = () if strategy is None else tuple((k, strategy[k]) for k in STRATEGY_FIELDS)
        return cls(__version__, dumps_mechanism(mechanism), len(inputs), _inputs_hash(inputs), str(source), strategy)

    def to_json(self) -> str:
        return json.dumps({"schema": SCHEMA, "spherekin_version": self.version,
                           "mechanism": {"sha256": hashlib.sha256(self.mechanism_toml.encode()).hexdigest(),
                                         "toml": self.mechanism_toml},
                           "inputs": {"count": self.n_inputs, "sha256": self.inputs_sha256,
                                      "source": self.inputs_source},
                           "strategy": dict(self.strategy)}, indent=1)

    @classmethod
    def from_json(cls, text, where: str) -> "Fingerprint":
        """The fingerprint in ``text`` (str or bytes); ValueError naming ``where`` if it is not one."""
        try:
            d = json.loads(text)
            if d.get("schema") != SCHEMA:
                raise ValueError(f"schema {d.get('schema')!r}")
            strategy = d["strategy"]
            return cls(str(d["spherekin_version"]), str(d["mechanism"]["toml"]), int(d["inputs"]["count"]),
                       str(d["inputs"]["sha256"]), str(d["inputs"]["source"]),
                       tuple((k, strategy[k]) for k in STRATEGY_FIELDS) if strategy else ())
        except (ValueError, TypeError, KeyError, AttributeError) as exc:
            raise ValueError(f"{where}: its fingerprint cannot be read ({type(exc).__name__}: {exc}); "
                             "pass --overwrite to solve every input again") from None

    def differences(self, job: "Fingerprint") -> list[str]:
        """What differs between this fingerprint (a file's) and ``job``'s, one phrase each (empty: none)."""
        out = []
        if self.version != job.version:
            out.append(f"spherekin version: {self.version} there, {job.version} here (another version may give "
                       "other rows)")
        if self.mechanism_toml != job.mechanism_toml:
            out.append("mechanism: " + _first_difference(self.mechanism_toml, job.mechanism_toml))
        if (self.n_inputs, self.inputs_sha256) != (job.n_inputs, job.inputs_sha256):
            there = f"{self.n_inputs} inputs ({self.inputs_source or 'unknown source'})"
            here = f"{job.n_inputs} ({job.inputs_source or 'unknown source'})"
            same = " with other values" if self.n_inputs == job.n_inputs else ""
            out.append(f"inputs: {there} there, {here} in this job{same}")
        if self.strategy != job.strategy:
            if not self.strategy or not job.strategy:
                which = "written by a batch" if self.strategy else "not written by a batch (spherekin track --out)"
                out.append(f"strategy: the file was {which}")
            else:
                a, b = dict(self.strategy), dict(job.strategy)
                out.append("strategy: " + ", ".join(f"{k} {a[k]!r} there, {b[k]!r} in this job"
                                                    for k in STRATEGY_FIELDS if a[k] != b[k]))
        return out


def _first_difference(there: str, here: str) -> str:
    """The first line where two mechanism texts differ, as 'key: <line there> there, <line here> here'."""
    a, b = there.splitlines(), here.splitlines()
    section = ""
    for k in range(max(len(a), len(b))):
        x = a[k] if k < len(a) else "(nothing)"
        y = b[k] if k < len(b) else "(nothing)"
        if x != y:
            key = (x if x != "(nothing)" else y).partition(" = ")[0].strip()
            where = f"{section} {key}".strip() if not key.startswith("[") else key
            return f"{where} differs ({_clip(x)} there, {_clip(y)} in this job)"
        if x.startswith("["):
            section = x
    return "the text differs"                  # unreachable for two different texts


def _clip(line: str) -> str:
    return line if len(line) <= QUOTE_CHARS else line[:QUOTE_CHARS - 3] + "..."

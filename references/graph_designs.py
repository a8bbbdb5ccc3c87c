"""Kind "graph" mechanism files generated from a topology, axes, a ground and the actuated joints.

Used by benchmarks/singular_campaign.py (issue 40 item 2) and its tests. A topology is the joints' links,
joint name -> (link a, link b) (the file's ``links = [a, b]``: the joint turns b relative to a); every axis
is written in the reference assembly, where every joint reads 0, so any axes close (docs/mechanism-format.md).

* :data:`WATT`: the Watt six-bar chain: the ternary links T1 (J1, J2, J5) and T2 (J1, J4, J7) joined by J1,
  two chains of two binary links between them (B1, B2: J2, J3, J4; B3, B4: J5, J6, J7).
* :data:`STEPHENSON`: the Stephenson six-bar chain: the ternary links T1 (J1, J3, J5) and T2 (J2, J4, J7) not
  joined, three chains between them: L1 (J1, J2), L2 (J3, J4), L3 - L4 (J5, J6, J7). It is the six-bar of
  tests/singular_refs.py section 6 (issue 40) with T1 = ground, T2 = plate, L3 = crank, L4 = conn.
* :data:`FIVE_BAR`: one loop of five links (2 degrees of freedom, A and E driven in examples/five_bar.toml).
* :data:`TWO_LOOP_2DOF`: a five-bar A-B-C-D-E and a dyad F-G-H from the ground to the five-bar's link L2
  (between B and C): seven links, eight joints, two loops, M = 3 x 6 - 2 x 8 = 2.

Each link of a six-bar may be the ground (the inversions); the joints' readings, hence the assemblies at a
reading of the actuated joint, do not depend on which link is the ground (a reading is a relative rotation:
R_b = R_a Rot(axis, theta) holds for R' = R_g^T R too), only the equations spherekin writes for them do.
"""

from __future__ import annotations

import math

import numpy as np

from references.random_designs import unit

__all__ = ["WATT", "STEPHENSON", "FIVE_BAR", "TWO_LOOP_2DOF", "TOPOLOGIES", "MIN_ARC", "links_of", "random_axes",
           "graph_toml", "five_bar_graph_axes", "two_loop_axes", "mobility", "loop_count", "graph_of", "passive_det"]

WATT = {"J1": ("T1", "T2"), "J2": ("T1", "B1"), "J3": ("B1", "B2"), "J4": ("B2", "T2"),
        "J5": ("T1", "B3"), "J6": ("B3", "B4"), "J7": ("B4", "T2")}
STEPHENSON = {"J1": ("T1", "L1"), "J2": ("L1", "T2"), "J3": ("T1", "L2"), "J4": ("L2", "T2"),
              "J5": ("T1", "L3"), "J6": ("L3", "L4"), "J7": ("L4", "T2")}
FIVE_BAR = {"A": ("ground", "L1"), "B": ("L1", "L2"), "C": ("L2", "L3"), "D": ("L3", "L4"), "E": ("ground", "L4")}
TWO_LOOP_2DOF = {**FIVE_BAR, "F": ("ground", "L5"), "G": ("L5", "L6"), "H": ("L6", "L2")}
TOPOLOGIES = {"Watt": WATT, "Stephenson": STEPHENSON}

#: Random axes are redrawn until every two joints of one link are at least this far apart (radians) and this
#: far from antipodal. Reason: a link whose joints (nearly) coincide is a degenerate design (two coaxial joints
#: in series act as one: a continuum), which the loader refuses or which is barely conditioned; 0.2 rad is
#: the floor references/random_designs.random_3rrr uses for its distal arcs.
MIN_ARC = 0.2
#: Redraws of a seed's axes at most (a draw passes with probability ~0.7 for the six-bars).
MAX_DRAWS = 1000


def links_of(topology: dict) -> list[str]:
    """The link names of a topology, in first-mention order."""
    return list(dict.fromkeys(l for pair in topology.values() for l in pair))


def _well_spread(topology: dict, axes: dict) -> bool:
    for link in links_of(topology):
        js = [j for j, pair in topology.items() if link in pair]
        for i in range(len(js)):
            for k in range(i + 1, len(js)):
                c = float(np.clip(axes[js[i]] @ axes[js[k]], -1.0, 1.0))
                if not MIN_ARC <= math.acos(c) <= math.pi - MIN_ARC:
                    return False
    return True


def random_axes(topology: dict, seed: int) -> dict[str, np.ndarray]:
    """Joint -> unit axis, uniform on the sphere from ``numpy.random.default_rng(seed)``, redrawn until every
    link's joints are MIN_ARC apart (:data:`MIN_ARC`)."""
    rng = np.random.default_rng(seed)
    for _ in range(MAX_DRAWS):
        axes = {j: unit(rng) for j in topology}
        if _well_spread(topology, axes):
            return axes
    raise ValueError(f"seed {seed}: no well spread axes in {MAX_DRAWS} draws")


def graph_toml(topology: dict, axes: dict, ground: str, actuated, name: str, output: str | None = None) -> str:
    """The kind "graph" file of ``topology`` with ``axes`` (joint -> (3,)), ``ground`` the fixed link and the
    joints ``actuated`` (a name or a sequence of names) driven; ``output``: a moving link (default: the first
    link other than the ground that is not a neighbour of it, else the last link)."""
    actuated = (actuated,) if isinstance(actuated, str) else tuple(actuated)
    links = links_of(topology)
    if ground not in links:
        raise ValueError(f"ground: {ground!r} is not a link of the topology ({', '.join(links)})")
    for j in actuated:
        if j not in topology:
            raise ValueError(f"actuated: {j!r} is not a joint of the topology")
    if output is None:
        near = {l for pair in topology.values() if ground in pair for l in pair}
        output = next((l for l in links if l not in near), links[-1])
    text = f'kind = "graph"\nname = "{name}"\nground = "{ground}"\noutput = "{output}"\n'
    for joint, (a, b) in topology.items():
        v = ", ".join(repr(float(x)) for x in axes[joint])
        text += f'\n[[joints]]\nname = "{joint}"\nlinks = ["{a}", "{b}"]\naxis = [{v}]\n'
        text += "actuated = true\n" if joint in actuated else ""
    return text


def five_bar_graph_axes() -> dict[str, np.ndarray]:
    """The axes of examples/five_bar.toml (its reference configuration, every reading 0) by joint name."""
    s3 = math.sqrt(3.0) / 2
    return {"A": np.array([-0.5, 0.0, s3]), "B": np.array([-0.35355339059327373, 0.7071067811865476, 0.6123724356957946]),
            "C": np.array([0.0, -0.1492223173516034, 0.9888036711118225]),
            "D": np.array([0.35355339059327373, 0.7071067811865476, 0.6123724356957946]), "E": np.array([0.5, 0.0, s3])}


def _polar(polar_deg: float, azimuth_deg: float) -> np.ndarray:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return np.array([math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p)])


def two_loop_axes() -> dict[str, np.ndarray]:
    """Axes of :data:`TWO_LOOP_2DOF`: the five-bar of examples/five_bar.toml and a dyad F (ground), G, H (on L2,
    the link B-C) chosen by hand (polar, azimuth in degrees) well away from the five-bar's axes."""
    return {**five_bar_graph_axes(), "F": _polar(50, -100), "G": _polar(65, -150), "H": _polar(30, -60)}


# ---------------------------------------------------------------- counting (the generator's own checks)

def mobility(topology: dict) -> int:
    """The spherical Kutzbach count 3 (links - 1) - 2 joints."""
    return 3 * (len(links_of(topology)) - 1) - 2 * len(topology)


def loop_count(topology: dict) -> int:
    """Independent loops: joints - links + 1 (a connected graph)."""
    return len(topology) - len(links_of(topology)) + 1


# ---------------------------------------------------------------- det K_p from the file alone (a reference)

def graph_of(data: dict) -> tuple[dict, dict, str, tuple]:
    """(topology, axes, ground, actuated) of a parsed kind "graph" file (``tomllib.loads``); ValueError for a
    joint with a ``reference_angle`` other than 0 (the readings here are the rotations' angles)."""
    if data.get("kind") != "graph":
        raise ValueError(f"expected a kind \"graph\" file, got kind {data.get('kind')!r}")
    topology, axes, actuated = {}, {}, []
    for j in data["joints"]:
        if float(j.get("reference_angle", 0.0)) != 0.0:
            raise ValueError(f"joint {j['name']}: a reference_angle is not supported here")
        topology[j["name"]] = tuple(j["links"])
        a = np.asarray(j["axis"], float)
        axes[j["name"]] = a / np.linalg.norm(a)
        if j.get("actuated", False):
            actuated.append(j["name"])
    return topology, axes, data["ground"], tuple(actuated)


def _rot(axis, angle: float) -> np.ndarray:
    """Rot(axis, angle) (Rodrigues; right-hand rule)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * (k @ k)


def passive_det(topology: dict, axes: dict, ground: str, actuated, readings: dict) -> float:
    """det K_p of the velocity closure at joint ``readings`` (name -> radians, every joint), written from the
    graph alone, independently of spherekin's loops: link rotations by a breadth-first tree from the ground
    (R_b = R_a Rot(axis, theta) for a joint [a, b]), the joint's current axis w = R_a axis; for each joint
    [a, b] off the tree one loop, omega_a + w theta' - omega_b = 0 with omega_L the sum of +-w theta' along
    the tree path to L. K_p: the columns of the joints not in ``actuated``, in the topology's order. The
    sign depends on these choices only (fixed for a mechanism), so it changes along an assembly exactly
    where det K_p of any other loop basis does."""
    names = list(topology)
    index = {n: k for k, n in enumerate(names)}
    rot = {ground: np.eye(3)}
    path = {ground: {}}                      # link -> {joint: sign} along the tree path from the ground
    tree = set()
    frontier = [ground]
    while frontier:
        nxt = []
        for link in frontier:
            for j in names:
                a, b = topology[j]
                if link not in (a, b) or j in tree:
                    continue
                other, sign = (b, 1.0) if link == a else (a, -1.0)
                if other in rot:
                    continue
                rot[other] = rot[link] @ _rot(axes[j], sign * float(readings[j]))
                path[other] = {**path[link], j: sign}
                tree.add(j)
                nxt.append(other)
        frontier = nxt
    w = {j: rot[topology[j][0]] @ axes[j] for j in names}
    rows = []
    for j in names:
        if j in tree:
            continue
        a, b = topology[j]
        block = np.zeros((3, len(names)))
        for k, s in path[a].items():
            block[:, index[k]] += s * w[k]
        block[:, index[j]] += w[j]
        for k, s in path[b].items():
            block[:, index[k]] -= s * w[k]
        rows.append(block)
    kmat = np.vstack(rows)
    passive = [index[n] for n in names if n not in set(actuated)]
    return float(np.linalg.det(kmat[:, passive]))

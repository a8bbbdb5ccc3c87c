"""A spherical mechanism as a graph: links are vertices, revolute joints are edges (issue 29).

Every joint ``[a, b]`` turns link ``b`` relative to link ``a`` about its axis: with the joint
reading theta, R_b = R_a Rot(axis, theta - reference_angle) (right-hand rule, axes written in the
one reference assembly where every link frame coincides with the ground's), R_ground = I. This
module knows only which joint joins which links; the geometry (axes, the loops' spherical
polygons) is :mod:`.model`'s.

* the **spanning tree**: breadth-first from the ground, joints tried in the order they are listed
  (deterministic); a front end may name its own tree instead (the legs of a 3-RRR: the reference
  leg whole and every other leg without its last joint, so that its loops are the paper's Eq. (5));
* the **loop basis**: each joint off the tree closes one independent loop (loops = joints - links +
  1): from the loop's root (the last link the tree paths to its two ends share) up the tree to the
  joint's first link (the ``up`` chain, the joint itself last) and up the tree to its second link
  (the ``down`` chain); the loop closes when both chains turn their end link the same way, which is
  Eq. (1)/(2) on the spherical polygon ``up`` + reversed ``down``;
* the **mobility** (spherical Kutzbach): M = 3 (links - 1) - 2 joints, the degrees of freedom of
  a mechanism without special geometry;
* the **chains**: when the graph is legs from the ground to the output link (every other link binary),
  those legs, so that what is proven for legs (the platform system, a leg's inverse kinematics)
  applies however the mechanism was written.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..core.angles import check_geometry_angle
from .checks import (check_joint_name, check_name, check_range, given_unit_vector, normalized_floats, parse_angle,
                     shown)

__all__ = ["Joint", "Step", "GraphLoop", "MechanismGraph", "mobility"]


@dataclass(frozen=True)
class Joint:
    """A revolute joint: its axis (unit vector, base frame, reference configuration), whether it is
    actuated, its range (lo, hi) in radians or None (unlimited: the full circle), and its reading
    at the reference configuration (radians). The name is checked by
    :func:`~.checks.check_joint_name` (it names a column of the results); the range ends and the
    reference reading are within :data:`~spherekin.core.angles.MAX_GEOMETRY_ANGLE` of 0.

    ``given_axis``: the axis floats as given (a mechanism file's numbers, norm 1 within
    :data:`~.checks.UNIT_TOL`); the joint's axis is their exact direction, which the proofs in
    extended precision (:mod:`spherekin.trust.extended`) use, and ``axis`` is that direction
    rounded to floats (~1e-16 off), which everything else uses. Left out (None), it is the
    ``axis`` argument; a ``given_axis`` whose float direction is not the ``axis`` argument is
    replaced by it (so ``dataclasses.replace(joint, axis=new)`` gives the joint of ``new``, and
    ``dataclasses.replace(joint, range=None)`` keeps both)."""

    name: str
    axis: tuple
    actuated: bool = False
    range: tuple | None = None
    reference_angle: float = 0.0
    given_axis: tuple | None = field(default=None, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "name", check_joint_name("name", self.name))
        raw = given_unit_vector("axis", self.axis)
        given = None if self.given_axis is None else given_unit_vector("given_axis", self.given_axis)
        if given is None or normalized_floats(given) != raw:
            given = raw
        object.__setattr__(self, "given_axis", given)
        object.__setattr__(self, "axis", normalized_floats(given))
        if not isinstance(self.actuated, (bool, np.bool_)):
            raise ValueError(f"actuated: expected true or false, got {shown(self.actuated)}")
        object.__setattr__(self, "actuated", bool(self.actuated))
        object.__setattr__(self, "range", check_range("range", self.range))
        object.__setattr__(self, "reference_angle", check_geometry_angle(
            "reference_angle", parse_angle("reference_angle", self.reference_angle)))


@dataclass(frozen=True)
class Step:
    """One joint on a path through the graph: ``sign`` +1 when the path crosses it from its first
    link to its second (the joint turns the link ahead by +reading), -1 the other way."""

    joint: str
    sign: int


@dataclass(frozen=True)
class GraphLoop:
    """One independent loop: closed by the off-tree joint ``closing``; ``root`` the link where it
    starts; ``up``: the steps from the root to the closing joint's second link through the closing
    joint (last); ``down``: the tree steps from the root to that same link. Closure: the product of
    the rotations along ``up`` equals the product along ``down``."""

    closing: str
    root: str
    up: tuple
    down: tuple


def mobility(n_links: int, n_joints: int) -> int:
    """Spherical Kutzbach criterion: M = 3 (links - 1) - 2 joints (each revolute removes 2 of a
    link's 3 rotational freedoms)."""
    return 3 * (n_links - 1) - 2 * n_joints


@dataclass(frozen=True)
class MechanismGraph:
    """Links and joints: ``joints`` (:class:`Joint`, in file order) and ``links[k]`` = (a, b), the
    links joint k joins; ``ground`` the fixed link; ``output`` the link whose orientation is the
    pose (None: none named); ``tree``: joint names of a spanning tree chosen by a front end (None:
    breadth-first from the ground). Checked at construction: one clear ValueError per problem."""

    joints: tuple
    links: tuple
    ground: str
    output: str | None = None
    tree: tuple | None = None
    link_names: tuple = field(init=False, repr=False, compare=False, default=())
    parent: dict = field(init=False, repr=False, compare=False, default_factory=dict)
    loops: tuple = field(init=False, repr=False, compare=False, default=())
    #: link -> indices of its joints, and link -> its depth in the tree (the ground 0): built once,
    #: so that loading and the per-link questions stay linear in the joints (issue 42 item 12: a scan
    #: of every joint per link made an 8,000-joint file take 18 s).
    incident: dict = field(init=False, repr=False, compare=False, default_factory=dict)
    depth: dict = field(init=False, repr=False, compare=False, default_factory=dict)

    def __post_init__(self):
        joints = tuple(self.joints)
        if not joints:
            raise ValueError("joints: expected one or more [[joints]] tables, got none")
        if len(self.links) != len(joints):
            raise ValueError(f"links: expected one pair of links per joint ({len(joints)}), got {len(self.links)}")
        names: dict[str, int] = {}
        pairs = []
        for k, (j, pair) in enumerate(zip(joints, self.links)):
            if not isinstance(j, Joint):
                raise ValueError(f"joints[{k}]: expected a Joint, got {j!r}")
            if j.name in names:
                raise ValueError(f"joints[{k}].name: joint name {j.name!r} is used twice (also joints[{names[j.name]}])")
            names[j.name] = k
            if isinstance(pair, (str, bytes)) or not isinstance(pair, (Sequence, tuple)) or len(pair) != 2:
                raise ValueError(f"joints[{k}].links: expected two link names [a, b], got {shown(pair)}")
            a = check_name(f"joints[{k}].links[0]", pair[0])
            b = check_name(f"joints[{k}].links[1]", pair[1])
            if a == b:
                raise ValueError(f"joints[{k}].links: joint {j.name!r} joins link {a!r} to itself; a joint joins "
                                 "two different links")
            pairs.append((a, b))
        seen_pairs: dict = {}
        for k, (a, b) in enumerate(pairs):
            key = frozenset((a, b))
            if key in seen_pairs:
                raise ValueError(
                    f"joints[{k}].links: joints {joints[seen_pairs[key]].name!r} and {joints[k].name!r} both join "
                    f"links {a!r} and {b!r}; two joints between the same two links lock them together (or are "
                    "one joint): join them through a link of their own")
            seen_pairs[key] = k
        ground = check_name("ground", self.ground)
        order = list(dict.fromkeys(link for pair in pairs for link in pair))     # first-seen order, in linear time
        if ground not in order:
            raise ValueError(f"ground: link {ground!r} is joined by no joint; links named by the joints: {order}")
        if self.output is not None:
            out = check_name("output", self.output)
            if out not in order:
                raise ValueError(f"output: link {out!r} is joined by no joint; links named by the joints: {order}")
            if out == ground:
                raise ValueError(f"output: expected a moving link, got the ground {out!r}")
            object.__setattr__(self, "output", out)
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "links", tuple(pairs))
        object.__setattr__(self, "ground", ground)
        object.__setattr__(self, "link_names", (ground, *[x for x in order if x != ground]))
        parent = self._spanning_tree()
        object.__setattr__(self, "parent", parent)
        object.__setattr__(self, "loops", self._loop_basis())

    # ------------------------------------------------------------------ tree and loops

    def _spanning_tree(self) -> dict:
        """link -> (joint index, sign, parent link) of the tree (the ground has none)."""
        incident: dict[str, list[int]] = {n: [] for n in self.link_names}
        for k, (a, b) in enumerate(self.links):
            incident[a].append(k)
            incident[b].append(k)
        object.__setattr__(self, "incident", {n: tuple(ks) for n, ks in incident.items()})
        allowed = None
        if self.tree is not None:
            wanted = tuple(self.tree)
            unknown = [n for n in wanted if n not in {j.name for j in self.joints}]
            if unknown:
                raise ValueError(f"tree: unknown joint(s) {unknown}")
            allowed = {k for k, j in enumerate(self.joints) if j.name in wanted}
            if len(allowed) != len(self.link_names) - 1:
                raise ValueError(f"tree: expected {len(self.link_names) - 1} joints (links - 1), got {len(allowed)}")
        parent: dict = {}
        depth = {self.ground: 0}
        queue = deque([self.ground])
        while queue:
            here = queue.popleft()
            for k in incident[here]:
                if allowed is not None and k not in allowed:
                    continue
                a, b = self.links[k]
                there, sign = (b, 1) if a == here else (a, -1)
                if there in depth:
                    continue
                depth[there] = depth[here] + 1
                parent[there] = (k, sign, here)
                queue.append(there)
        reached = depth
        object.__setattr__(self, "depth", depth)
        missing = [n for n in self.link_names if n not in reached]
        if missing and allowed is not None and not self._unreachable():
            raise ValueError(f"tree: the joints {list(self.tree)} do not connect every link to the ground "
                             f"(not reached: {missing})")
        if missing:
            raise ValueError(
                f"links: {missing} are not connected to the ground {self.ground!r} by any chain of joints "
                "(a mechanism is one connected graph of links)")
        return parent

    def _unreachable(self) -> list[str]:
        """Links no chain of joints (tree or not) joins to the ground."""
        reached, stack = {self.ground}, [self.ground]
        while stack:
            here = stack.pop()
            for k in self.incident[here]:
                for y in self.links[k]:
                    if y not in reached:
                        reached.add(y)
                        stack.append(y)
        return [n for n in self.link_names if n not in reached]

    def path(self, link: str) -> tuple[Step, ...]:
        """The tree's steps from the ground to ``link`` (ground first)."""
        return self._steps_between(self.ground, link)

    def path_links(self, link: str) -> tuple[str, ...]:
        """The links on the tree path from the ground to ``link`` (both included)."""
        out = [link]
        while out[-1] != self.ground:
            out.append(self.parent[out[-1]][2])
        return tuple(reversed(out))

    def _steps_between(self, root: str, link: str) -> tuple[Step, ...]:
        """The tree's steps from ``root`` down to ``link`` (``root`` an ancestor of ``link``)."""
        steps = []
        here = link
        while here != root:
            k, sign, up = self.parent[here]
            steps.append(Step(self.joints[k].name, sign))
            here = up
        return tuple(reversed(steps))

    def _common_ancestor(self, a: str, b: str) -> str:
        """The deepest link on both tree paths from the ground to ``a`` and ``b``: found by walking
        up from the deeper one, so it costs the loop's length, not the depth of the tree."""
        depth, parent = self.depth, self.parent
        while depth[a] > depth[b]:
            a = parent[a][2]
        while depth[b] > depth[a]:
            b = parent[b][2]
        while a != b:
            a, b = parent[a][2], parent[b][2]
        return a

    def _loop_basis(self) -> tuple[GraphLoop, ...]:
        tree_joints = {k for k, _, _ in self.parent.values()}
        loops = []
        for k, (a, b) in enumerate(self.links):
            if k in tree_joints:
                continue
            root = self._common_ancestor(a, b)
            up = self._steps_between(root, a) + (Step(self.joints[k].name, 1),)
            down = self._steps_between(root, b)
            loops.append(GraphLoop(self.joints[k].name, root, up, down))
        return tuple(loops)

    # ------------------------------------------------------------------ counts

    @property
    def mobility(self) -> int:
        """Spherical Kutzbach mobility of the graph (:func:`mobility`)."""
        return mobility(len(self.link_names), len(self.joints))

    def joints_of(self, link: str) -> tuple[int, ...]:
        """Indices of the joints on ``link`` (in file order)."""
        return self.incident[link]

    def chains(self) -> tuple[tuple[int, ...], ...] | None:
        """The graph as legs: joint indices of each chain from the ground to the output link (in the
        order of the ground's joints), every joint written [link nearer the ground, link nearer the
        output]; None when the graph is not legs (no output, a link other than the ground and the
        output with other than two joints, or a joint written the other way)."""
        if self.output is None:
            return None
        for link in self.link_names:
            if link not in (self.ground, self.output) and len(self.joints_of(link)) != 2:
                return None
        chains, used = [], set()
        for k in self.joints_of(self.ground):
            chain, here, joint = [], self.ground, k
            while True:
                a, b = self.links[joint]
                if a != here:
                    return None
                chain.append(joint)
                used.add(joint)
                if b == self.output:
                    break
                if b == self.ground:
                    return None
                nxt = [m for m in self.joints_of(b) if m != joint]
                here, joint = b, nxt[0]
            chains.append(tuple(chain))
        if len(used) != len(self.joints):
            return None
        return tuple(chains)

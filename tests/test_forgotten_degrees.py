"""An angle beyond a full turn is refused everywhere an input or a pose angle is read (issue 27, item 3).

Angles are read modulo 2 pi, so "17" without --degrees used to be solved as 17 rad = 17 - 2 pi*2
(a plausible, wrong answer for someone who meant 17 degrees). solve, ik, batch, track and the Python
API share one check (spherekin.core.angles.check_turn); each test here would pass the value through
before that check existed.
"""

import math

import numpy as np
import pytest

import spherekin
from spherekin.cli import main
from spherekin.mechanism import general_3rrr

EXAMPLE = "examples/general_3rrr.toml"


def _error(capsys, argv) -> str:
    assert main(argv) == 2
    err = capsys.readouterr()
    assert err.out == ""                         # refused before any output
    lines = err.err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_solve_refuses_17_radians_and_names_the_joint(capsys):
    line = _error(capsys, ["solve", EXAMPLE, "--inputs", "17,-11,29"])
    assert "beta1" in line and "full turn" in line and "--degrees" in line


def test_solve_accepts_the_same_numbers_in_degrees(capsys):
    assert main(["solve", EXAMPLE, "--inputs", "17,-11,29", "--degrees", "--quiet"]) == 0
    assert "direct kinematics at beta1 = +17 deg" in capsys.readouterr().out


def test_ik_refuses_euler_angles_in_degrees_without_the_flag(capsys):
    line = _error(capsys, ["ik", EXAMPLE, "--euler", "10,-20,30"])
    assert "--euler" in line and "full turn" in line


def test_batch_refuses_a_csv_row_beyond_a_turn(tmp_path, capsys):
    path = tmp_path / "in.csv"
    path.write_text("beta1,beta2,beta3\n0.1,0.2,0.3\n0.1,45,0.3\n")
    line = _error(capsys, ["batch", EXAMPLE, "--inputs", str(path), "--out", str(tmp_path / "o.csv")])
    assert "line 3" in line and "beta2" in line and "full turn" in line
    assert not (tmp_path / "o.csv").exists()


def test_batch_refuses_a_grid_beyond_a_turn(tmp_path, capsys):
    line = _error(capsys, ["batch", EXAMPLE, "--grid", "beta1=-180:180:5", "--fix", "beta2=0", "--fix",
                           "beta3=0", "--out", str(tmp_path / "o.csv")])
    assert "beta1" in line and "full turn" in line


def test_track_refuses_a_path_beyond_a_turn(tmp_path, capsys):
    path = tmp_path / "p.csv"
    path.write_text("beta1,beta2,beta3\n0.1,0.2,0.3\n10,0.2,0.3\n")
    line = _error(capsys, ["track", EXAMPLE, "--path", str(path), "--start-solution", "1"])
    assert "beta1" in line and "full turn" in line


def test_python_solve_refuses_and_accepts_reduced_values():
    mech = general_3rrr()
    with pytest.raises(ValueError, match="full turn"):
        spherekin.solve(mech, [17.0, 0.2, 0.3])
    with pytest.raises(ValueError, match="full turn"):
        spherekin.compile(mech).solve_many([[0.1, 0.2, 0.3], [0.1, -1e17, 0.3]])
    # 2 pi itself is one turn: accepted, and it is the pose of 0 (independent: the same rotation)
    a = spherekin.solve(mech, [2 * math.pi, 0.2, 0.3])
    b = spherekin.solve(mech, [0.0, 0.2, 0.3])
    ra = sorted(np.round(s.platform_rotation, 8).ravel().tolist() for s in a.solutions)
    rb = sorted(np.round(s.platform_rotation, 8).ravel().tolist() for s in b.solutions)
    assert ra == rb and len(ra) >= 1


@pytest.mark.parametrize("plane, names", [
    (["--x", "beta1=100000:100000.5", "--y", "beta2=0:0.5", "--fix", "beta3=0.1"], "--x (beta1) lo"),
    (["--x", "beta1=0:0.5", "--y", "beta2=0:0.5", "--fix", "beta3=1e5"], "--fix (beta3)"),
    (["--x", "beta1=0:0.5", "--fix", "beta2=0.2", "--fix", "beta3=-8"], "--fix (beta3)"),
])
def test_singular_refuses_a_plane_beyond_a_turn_as_solve_does(capsys, plane, names):
    """Issue 42 item 12: `singular` covered a plane at 1e5 rad that `solve` refuses as an input."""
    line = _error(capsys, ["singular", EXAMPLE, *plane, "--tol", "0.1"])
    assert names in line and "full turn" in line, line
    with pytest.raises(ValueError, match="full turn"):
        spherekin.singular(general_3rrr(), ("beta1", 1e5, 1e5 + 0.5), ("beta2", 0.0, 0.5), {"beta3": 0.1}, tol=0.1)

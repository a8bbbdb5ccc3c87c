"""spherekin.batch.inputs: grids, CSV files and arrays of actuator inputs, checked before any solve."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherekin.batch.inputs import (MAX_INPUTS, array_inputs, grid_inputs, parse_fix, parse_grid,
                                    read_inputs_csv)
from spherekin.mechanism import general_3rrr


def test_a_grid_spec_is_linspace_with_both_ends():
    ax = parse_grid("beta1=-pi:pi/2:4")
    assert ax.name == "beta1"
    np.testing.assert_allclose(ax.values, [-math.pi, -math.pi / 2, 0.0, math.pi / 2], atol=1e-15)
    np.testing.assert_allclose(parse_grid("b=-90:90:3", degrees=True).values, [-math.pi / 2, 0.0, math.pi / 2])


@pytest.mark.parametrize("spec, match", [
    ("beta1", "expected name=lo:hi:n"), ("beta1=0:1", "expected name=lo:hi:n"), ("=0:1:3", "expected name=lo:hi:n"),
    ("beta1=0:1:x", "whole number"), ("beta1=0:1:1", "n >= 2"), ("beta1=1:0:3", "lo < hi"),
    ("beta1=a:1:3", "beta1 \\(lo\\)"), ("beta1=0:nan:3", "beta1 \\(hi\\)"),
])
def test_a_bad_grid_spec_is_named(spec, match):
    with pytest.raises(ValueError, match=match):
        parse_grid(spec)


def test_degrees_and_pi_do_not_mix():
    with pytest.raises(ValueError, match="with --degrees, expected a number of degrees"):
        parse_grid("b=-pi:pi:3", degrees=True)
    with pytest.raises(ValueError, match="with --degrees"):
        parse_fix("b=pi/2", degrees=True)


def test_grid_rows_first_axis_slowest_and_fixed_columns(mech):
    got = grid_inputs(mech, ["beta2=0:1:3", "beta1=-1:1:2"], ["beta3=0.5"])
    assert got.names == ("beta1", "beta2", "beta3")
    expected = [(b1, b2, 0.5) for b2 in (0.0, 0.5, 1.0) for b1 in (-1.0, 1.0)]
    np.testing.assert_array_equal(got.values, expected)
    assert [a.name for a in got.axes] == ["beta2", "beta1"]
    assert got.where(3) == "grid point 3 (beta2 = 0.5, beta1 = 1)"


@pytest.mark.parametrize("grids, fixed, match", [
    (["beta1=0:1:2", "beta2=0:1:2"], [], "no value for beta3"),
    (["beta1=0:1:2", "beta2=0:1:2"], ["beta3=0", "beta1=1"], "beta1 given more than once"),
    (["beta1=0:1:2", "gamma1=0:1:2"], ["beta3=0"], "gamma1 is not an actuated joint"),
    ([], ["beta1=0", "beta2=0", "beta3=0"], "at least one grid axis"),
    (["beta1=0:1:2"], ["beta2", "beta3=0"], "expected name=value"),
])
def test_bad_grids_are_named(mech, grids, fixed, match):
    with pytest.raises(ValueError, match=match):
        grid_inputs(mech, grids, fixed)


def test_a_huge_grid_is_refused_before_it_is_built(mech):
    n = int(MAX_INPUTS ** 0.5) + 10
    with pytest.raises(ValueError, match=rf"more than one job takes \({MAX_INPUTS:,}\)") as err:
        grid_inputs(mech, [f"beta1=0:1:{n}", f"beta2=0:1:{n}"], ["beta3=0"])
    assert "MAX_" not in str(err.value)                  # the limit's value, not the constant's name


def write(tmp_path, text, name="in.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_a_csv_in_any_column_order_with_blank_lines(tmp_path, mech):
    p = write(tmp_path, "beta3, beta1,beta2\n0.5,0.1,-0.2\n\n3e-1,pi/2,-1\n\n")
    got = read_inputs_csv(mech, p)
    np.testing.assert_array_equal(got.values, [[0.1, -0.2, 0.5], [math.pi / 2, -1.0, 0.3]])
    assert list(got.lines) == [2, 4]
    assert got.where(1) == f"{p} line 4 (input 1)"
    deg = read_inputs_csv(mech, write(tmp_path, "beta1,beta2,beta3\n90,0,-45\n", "d.csv"), degrees=True)
    np.testing.assert_allclose(deg.values, [[math.pi / 2, 0.0, -math.pi / 4]])


@pytest.mark.parametrize("text, match", [
    ("", "empty; expected a header"),
    ("beta1,beta2,beta3\n", "no input rows"),
    ("beta1,beta2\n0,0\n", "line 1: missing column\\(s\\) beta3"),
    ("beta1,beta2,beta3,speed\n0,0,0,1\n", "line 1: unexpected column\\(s\\) 'speed'"),
    ("beta1,beta1,beta2,beta3\n0,0,0,0\n", "line 1: column beta1 appears more than once"),
    ("beta1,beta2,beta3\n0,0,0\n0,0\n", "line 3: expected 3 values"),
    ("beta1,beta2,beta3\n0,0,0\n0,nan,0\n", "line 3, column beta2: expected a finite number, got 'nan'"),
    ("beta1,beta2,beta3\n0,abc,0\n", "line 2, column beta2: expected a finite number, got 'abc'"),
    ("beta1,beta2,beta3\n0,0, \n", "line 2, column beta3: empty"),
    ("beta1,beta2,beta3\n0,inf,0\n", "line 2, column beta2"),
])
def test_a_malformed_csv_names_line_and_column(tmp_path, mech, text, match):
    with pytest.raises(ValueError, match=match):
        read_inputs_csv(mech, write(tmp_path, text))


def test_a_missing_csv_is_named(tmp_path, mech):
    with pytest.raises(ValueError, match="no such file"):
        read_inputs_csv(mech, tmp_path / "nope.csv")


def test_an_input_outside_a_joint_range_names_its_row(tmp_path):
    from spherekin.mechanism import three_rrr

    g = general_3rrr().geometry
    m = three_rrr(g.base_axes, g.elbow_axes_at_zero, g.platform_axes, g.distal_link_angles,
                  joint_ranges={"beta2": (-1.0, 1.0)})
    p = write(tmp_path, "beta1,beta2,beta3\n0,0.5,0\n0,1.5,0\n")
    with pytest.raises(ValueError, match=r"line 3 \(input 1\): beta2 = 1.5 is outside its joint range \[-1.0, 1.0\]"):
        read_inputs_csv(m, p)
    with pytest.raises(ValueError, match=r"grid point 2 \(beta2 = 1.2\): beta2 = 1.2 is outside"):
        grid_inputs(m, ["beta2=0:1.2:3"], {"beta1": 0.0, "beta3": 0.0})
    # the same rule as a single solve: a range end (modulo 2 pi) is in
    ok = array_inputs(m, [[0.0, 1.0, 0.0], [0.0, -1.0 + 2 * math.pi, 0.0]])
    assert len(ok) == 2


def test_array_and_dataframe_inputs(mech):
    import pandas as pd

    got = array_inputs(mech, pd.DataFrame({"beta3": [0.5], "beta1": [0.1], "beta2": [0.2]}))
    np.testing.assert_array_equal(got.values, [[0.1, 0.2, 0.5]])
    with pytest.raises(ValueError, match="shape \\(K, 3\\)"):
        array_inputs(mech, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="expected exactly the columns"):
        array_inputs(mech, pd.DataFrame({"beta1": [0.1], "beta2": [0.2]}))
    with pytest.raises(ValueError, match="inputs row 1: beta1 is nan"):
        array_inputs(mech, [[0, 0, 0], [np.nan, 0, 0]])

"""Tolerances in a mechanism file (spherekin/mechanism/tolerances.py): read, checked, written back."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import pytest

from spherekin.mechanism import (MechanismFileError, Tolerances, dumps_mechanism, load_mechanism, mechanism_from_dict,
                                 parse_tolerances_option)

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def with_table(tmp_path, table: str, example: str = "general_3rrr.toml") -> Path:
    path = tmp_path / "m.toml"
    path.write_text((EXAMPLES / example).read_text() + "\n" + table)
    return path


def test_a_tolerances_table_is_read_for_every_kind_and_written_back(tmp_path):
    table = "[tolerances]\naxes_deg = 0.1\ninputs_deg = 0.01\n\n[tolerances.joints]\nbeta1 = 0.05\n"
    for example, joint in (("general_3rrr.toml", "beta1"), ("four_bar_graph.toml", None), ("five_bar.toml", None)):
        text = table if joint else table.split("\n\n")[0] + "\n"
        mech = load_mechanism(with_table(tmp_path, text, example))
        assert mech.tolerances == Tolerances(0.1, 0.01, {"beta1": 0.05} if joint else {})
        assert mech.tolerances.axis_deg("beta1") == (0.05 if joint else 0.1)
        again = mechanism_from_dict(tomllib.loads(dumps_mechanism(mech)))
        assert again == mech and again.tolerances == mech.tolerances


@pytest.mark.parametrize("table, message", [
    ("[tolerances]\naxes_deg = -0.1\n", "tolerances.axes_deg: expected a number of degrees in [0, 10], got -0.1"),
    ("[tolerances]\naxes_deg = nan\n", "tolerances.axes_deg: expected a number of degrees in [0, 10], got nan"),
    ("[tolerances]\ninputs_deg = 10.5\n", "tolerances.inputs_deg: 10.5 degrees is over the 10 accepted"),
    ("[tolerances]\naxes_deg = true\n", "tolerances.axes_deg: expected a number of degrees"),
    ("[tolerances]\naxis_deg = 0.1\n", "tolerances.axis_deg: unknown key; valid keys here: axes_deg, inputs_deg, joints"),
    ("[tolerances.joints]\nleg1_base = 0.1\n", "tolerances.joints.leg1_base: no joint of that name"),
    ("tolerances = 0.1\n", "tolerances: expected a table"),
])
def test_bad_tolerances_in_a_file_are_one_error_naming_the_key(tmp_path, table, message):
    with pytest.raises(MechanismFileError) as exc:
        load_mechanism(with_table(tmp_path, table))
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_the_command_line_option_overrides_the_file():
    base = Tolerances(0.1, 0.01, {"beta1": 0.05})
    got = parse_tolerances_option("inputs_deg=0.02, gamma2=0.2", base)
    assert got == Tolerances(0.1, 0.02, {"beta1": 0.05, "gamma2": 0.2})
    assert Tolerances().zero and not got.zero
    with pytest.raises(ValueError, match="--tolerances: axes_deg: expected a number of degrees"):
        parse_tolerances_option("axes_deg=x")


def test_a_mechanism_refuses_tolerances_naming_a_joint_it_does_not_have():
    from spherekin.mechanism import general_3rrr

    with pytest.raises(ValueError, match="tolerances.joints.nope: no joint of that name"):
        dataclasses.replace(general_3rrr(), tolerances=Tolerances(joints={"nope": 0.1}))

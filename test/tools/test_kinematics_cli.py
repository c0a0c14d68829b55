"""srs_kinematics: the backbone for nine length changes or pressures, and a clear refusal of what is out of range."""

import pytest

from srs_ros.tools.kinematics_cli import main

ZEROS = ["0"] * 8


def test_one_muscle_extended_bends_module_1_away_from_it_and_prints_31_backbone_points(capsys):
    assert main(["--lengths-m", "0.03", *ZEROS]) == 0
    out = capsys.readouterr().out
    assert "module 1: bend 1.6000 rad toward  180.00 deg" in out and "module 2: bend 0.0000 rad (straight)" in out
    assert len([line for line in out.splitlines() if line.count(",") == 3]) == 1 + 31  # header and 31 points
    assert main(["--pressures-bar", "3", *ZEROS]) == 0  # P = 100 l: the same bend
    assert "module 1: bend 1.6000 rad" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [["--lengths-m", "-1", *ZEROS], ["--lengths-m", "1e30", *ZEROS],
                                  ["--lengths-m", "0.03", "0"], ["--pressures-bar", "9", *ZEROS],
                                  ["--lengths-m", "nan", *ZEROS]])
def test_a_length_or_pressure_out_of_range_or_the_wrong_count_is_refused(argv, capsys):
    """They were taken as given (1 m shorter drew a negative arc; 9 bar, above the limit: a helper's review)."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"srs_kinematics: {argv[0]} " in err and "expected 9 values in [0, " in err and "m1_pma1" in err


def test_a_straight_module_has_no_bending_direction(capsys):
    """Equal lengths bent by rounding noise (6e-16 rad) were printed "toward -42.26 deg" (a helper's review)."""
    assert main(["--lengths-m", "0.03", "0.03", "0.03", "0.01", "0.01", "0.01", "0", "0", "0"]) == 0
    out = capsys.readouterr().out
    assert "module 1: bend 0.0000 rad (straight), arc" in out and "module 2: bend 0.0000 rad (straight)" in out

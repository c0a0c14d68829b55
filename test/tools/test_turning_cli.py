"""srs_turning: how the simulated robot turns, as tables (those of docs/navigation.md and docs/studies/navigation.md
come from here)."""

import re

import pytest

from srs_ros.core.robot import config_dir
from srs_ros.tools import turning_cli


@pytest.mark.slow(seconds=6)
def test_the_serpentine_on_the_floor_asked_for_turns_the_body_in_place_both_ways(capsys):
    """On isotropic friction (the paper's rubber skin) the serpentine makes no progress but its c turns the body."""
    assert turning_cli.main(["--serpentine", "--friction", "isotropic", "--cycles", "3"]) == 0
    printed = capsys.readouterr().out
    assert "serpentine on isotropic friction 0.8:" in printed  # the floor asked for, not the anisotropic default
    rows = {float(m[0]): (float(m[1]), float(m[2])) for m in re.findall(
        r"\| serpentine \| 4 \| 1 \| ([-+.\d]+) \| ([-+.\d]+) \| [-+.\d]+ \| [-+.\d]+ \| ([-+.\d]+) \|", printed)}
    assert sorted(rows) == [-0.2, -0.1, 0.0, 0.1, 0.2], printed
    (left, _), (right, _) = rows[0.2], rows[-0.2]
    assert left > 3.0 and right < -3.0, printed  # deg per cycle, counter-clockwise positive
    assert all(travel < 1.0 for _, travel in rows.values()), printed  # cm per cycle: in place


@pytest.mark.slow(seconds=5)
def test_sidewinding_turns_the_calibrated_body_one_way_and_its_mirror_image_the_other(capsys):
    """The body whose rolling gaits turn 6 deg per cycle at best circles both ways by sidewinding's lateral_rad sign."""
    calibrated = str(config_dir() / "sim_calibrated_paper.yaml")
    assert turning_cli.main(["--sidewinding", "--sim-config", calibrated, "--friction", "isotropic",
                             "--cycles", "4"]) == 0
    printed = capsys.readouterr().out
    assert "sidewinding on isotropic friction 0.4729:" in printed
    rows = {float(m[0]): (float(m[1]), float(m[2])) for m in re.findall(
        r"\| sidewinding \| 4 \| 1 \| ([-+.\d]+) \| ([-+.\d]+) \| [-+.\d]+ \| [-+.\d]+ \| ([-+.\d]+) \|", printed)}
    assert sorted(rows) == [-0.6, -0.3, 0.3, 0.6], printed
    (ccw, ccw_travel), (cw, cw_travel) = rows[-0.6], rows[0.6]
    assert ccw > 12.0 and cw < -12.0, printed  # deg per cycle, counter-clockwise positive
    assert ccw_travel > 8.0 and cw_travel > 8.0, printed  # cm per cycle: a circle, not a turn in place


@pytest.mark.parametrize("cycles", ["-1", "0", "2"])
def test_too_few_cycles_to_measure_are_refused_before_any_run(cycles, capsys):
    """-1 ended in a traceback, 0-2 in rows of NaN and, with --write-map, a map refused after minutes of runs."""
    with pytest.raises(SystemExit) as refused:
        turning_cli.main(["--cycles", cycles])
    assert refused.value.code == 2
    assert f"--cycles {cycles}: expected more than the 2 cycles each run leaves out" in capsys.readouterr().err


def test_ctrl_c_exits_130_with_a_line_not_a_traceback(monkeypatch, capsys):
    """A traceback ending in mujoco.mj_step before (a helper's review)."""
    from srs_ros.experiments import turning

    def interrupted(*_args, **_kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(turning, "measure_sidewinding", interrupted)
    assert turning_cli.main(["--sidewinding"]) == 130
    assert "srs_turning: interrupted" in capsys.readouterr().err

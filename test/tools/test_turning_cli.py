"""srs_turning: how the simulated robot turns, as tables (docs/navigation.md's come from here)."""

import re

import pytest

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

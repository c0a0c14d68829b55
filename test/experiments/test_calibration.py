"""Calibration without the physics: parameters applied and validated, the error, the goals, the model's limits."""

import math

import pytest
import yaml

from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.experiments.calibration import (
    FAILED_RESIDUAL,
    apply_values,
    calibrate,
    cell_errors,
    default_fit,
    fit_parameters,
    model_limits,
    sim_yaml_text,
    table_error,
    target_report,
)
from srs_ros.experiments.table import RunRecord, paper_table
from srs_ros.sim.config import load_sim_config, sim_config_from_dict, with_friction


def test_fitted_values_land_in_their_sections_and_are_validated():
    config = load_sim_config()
    fitted = apply_values(config, {"skin_radius_m": 0.03, "pressure_time_constant_s": 0.2, "deadzone_bar": 1.3,
                                   "friction_coefficient": 0.6})
    assert fitted.body.skin_radius_m == 0.03 and fitted.contact.friction_coefficient == 0.6
    assert fitted.muscles.pressure_time_constant_s == 0.2 and fitted.muscles.deadzone_bar == 1.3
    assert fitted.muscles.transport_delay_s == config.muscles.transport_delay_s  # the rest unchanged
    assert fitted.servo == config.servo and fitted.camera == config.camera
    with pytest.raises(ConfigurationError, match="skin_radius_m"):
        apply_values(config, {"skin_radius_m": -1.0})
    assert default_fit(config)[0] == "friction_coefficient"
    assert default_fit(with_friction(config, "0.3,0.9"))[:2] == ("friction_along_body", "friction_across_body")
    with pytest.raises(InvalidInputError, match="unknown fit parameter 'grip'"):
        fit_parameters(["grip"])


def test_the_flow_limit_is_fitted_only_from_a_starting_estimate():
    from srs_ros.experiments.calibration import _search_space
    config = load_sim_config()
    limited = apply_values(config, {"max_pressure_rate_bar_per_s": 5.0})
    assert limited.muscles.max_pressure_rate_bar_per_s == 5.0
    space = _search_space(paper_table(), limited, ["max_pressure_rate_bar_per_s"], 8.0, 10)
    assert space.initial == {"max_pressure_rate_bar_per_s": 5.0} and (space.lows[0], space.highs[0]) == (1.0, 40.0)
    # 0 is "no limit", not a slow line: the search would jump from no limit to the slowest; a start is asked for.
    with pytest.raises(InvalidInputError, match="no flow limit .* starting estimate"):
        _search_space(paper_table(), config, ["max_pressure_rate_bar_per_s"], 8.0, 10)


def test_the_written_sim_yaml_reads_back_as_the_same_configuration():
    config = apply_values(load_sim_config(), {"skin_radius_m": 0.0271, "transport_delay_s": 0.05})
    text = sim_yaml_text(config, "fitted for a test\n\nsecond line")
    assert text.startswith("# fitted for a test\n#\n# second line\nsim:\n")
    back = sim_config_from_dict(yaml.safe_load(text))
    assert back == config


def test_the_error_compares_resultant_speeds_on_a_log_scale_and_punishes_failures():
    table = paper_table()
    exact = RunRecord("inward_rolling", 4.0, 1.0, 10.11, -5.61)  # signs and axes do not matter, the speed does
    double = RunRecord("inward_rolling", 4.0, 0.5, 2 * 10.02 + 1, 0.0)
    failed = RunRecord.failed(("outward_rolling", 2.0, 1.0), "diverged")
    errors = cell_errors([exact, double, failed], table)
    assert errors[0] == pytest.approx(0.0, abs=1e-3)
    assert errors[1] == pytest.approx(math.log(2.0), abs=1e-3)
    assert errors[2] == FAILED_RESIDUAL
    assert table_error([exact], table) < table_error([exact, double], table)


def _paper_like(scale_by_frequency):
    """Records whose speeds are the paper's times ``scale_by_frequency(f)``; serpentine 0.5 cm/s, 1 bar still."""
    table = paper_table()
    records = []
    for gait, amplitude, frequency in table.cells:
        if amplitude == 1.0:
            speed = 0.0
        elif gait == "serpentine":
            speed = 0.5
        else:
            speed = table.speed_cm_s((gait, amplitude, frequency)) * scale_by_frequency(frequency)
        records.append(RunRecord(gait, amplitude, frequency, speed, 0.0))
    return table, records


def test_the_goals_are_met_by_a_table_close_to_the_papers_and_missed_with_the_cells_named():
    table, records = _paper_like(lambda f: 1.5)
    assert [c.met for c in target_report(records, table)] == [True, True, True, True]
    table, records = _paper_like(lambda f: 2.5 if f >= 0.75 else 1.0)  # half the rolling cells too fast
    checks = {c.goal.split(" ")[0]: c for c in target_report(records, table)}
    assert not checks["rolling"].met and "12 of 24 (need 18)" in checks["rolling"].detail
    assert "inward_rolling 2 bar 0.75 Hz" in checks["rolling"].detail
    records[0] = RunRecord("serpentine", 1.0, 0.25, 0.3, 0.0)  # a 1 bar cell that moves
    records[5] = RunRecord("serpentine", 2.0, 0.5, 1.2, 0.0)
    checks = {c.goal.split(" ")[0]: c for c in target_report(records, table)}
    assert not checks["1"].met and "serpentine 1 bar 0.25 Hz" in checks["1"].detail
    assert not checks["serpentine"].met and "fastest 1.20 cm/s" in checks["serpentine"].detail


def test_model_limits_name_the_gaits_whose_distance_per_cycle_the_model_cannot_follow():
    table, records = _paper_like(lambda f: 1.0)  # the paper itself: nothing to say
    assert model_limits(records, table, load_sim_config()) == []
    table, records = _paper_like(lambda f: 1.0)
    rolled = []  # a body rolling 2 pi r per cycle: speed ~ f
    for r in records:
        if r.gait != "serpentine" and r.amplitude_bar > 1.0:
            r = RunRecord(r.gait, r.amplitude_bar, r.frequency_hz, 12.6 * r.frequency_hz, 0.0)
        rolled.append(r)
    notes = model_limits(rolled, table, load_sim_config())
    assert len(notes) == 6
    assert notes[0].startswith("inward_rolling 2 bar: distance per cycle 9.9 cm at 0.25 Hz -> 5.5 cm at 1 Hz")
    assert "12.6 -> 12.6 cm simulated (2 pi r = 12.6 cm)" in notes[0]


def test_a_fit_that_does_not_lower_the_error_is_not_taken_an_equal_one_neither():
    """A runner whose runs come out alike whatever the configuration: the fit's error equals the one before, and
    the configuration must stay (an equal error was taken, and "fitted: a -> b" printed; a helper's review)."""
    class AlikeRunner:
        def run(self, cells, duration_s, config, **_options):
            return [RunRecord(*cell, 2.0, 1.0, 0.3, 0.15) for cell in cells]

    config = load_sim_config()
    result = calibrate(paper_table(), config, max_evaluations=3, runner=AlikeRunner())
    assert result.error_after == result.error_before
    assert not result.accepted and result.config is config and result.fitted_values == result.initial_values


def test_the_search_keeps_the_body_thicker_than_its_muscles_and_refuses_a_coefficient_the_floor_ignores():
    """The skin radius was searched from 12 mm, inside the muscles' own centre line (12.5 mm); friction_coefficient
    was fitted on an anisotropic floor, which never reads it: a flat cost, the budget spent (a helper's review)."""
    from srs_ros.core.robot import default_robot
    from srs_ros.experiments.calibration import FIT_PARAMETERS, _search_space

    assert FIT_PARAMETERS["skin_radius_m"].low >= default_robot().actuator_radius_m + 0.005
    with pytest.raises(InvalidInputError, match="friction_coefficient is fitted but the floor friction is anisotropic"):
        _search_space(paper_table(), with_friction(load_sim_config(), "anisotropic"), ["friction_coefficient"], 8.0, 10)

"""One ``srs_sweep --ros`` run with the rig's services stood in by the test (no node answers; no DDS peer).

Found by a helper's review (stop 59): a disarm left unanswered after a good run escaped the run and ended the whole
sweep with exit 2 and no table; a run prepared only the gait, amplitude and frequency, so a navigator's turn and
reverse or an operator's amplitude_scale left on the nodes played a cell other than the one recorded.
"""

from types import SimpleNamespace

import pytest

from srs_ros.core.gait.library import list_gaits
from srs_ros.experiments.ros_sweep import RosSweep, RunAborted

CELL = ("inward_rolling", 4.0, 1.0)


@pytest.fixture
def sweep(ros_domain, monkeypatch):
    monkeypatch.setenv("ROS_DOMAIN_ID", str(ros_domain))
    made = RosSweep()
    yield made
    made.close()


def test_a_disarm_unanswered_after_a_good_run_fails_that_run_and_the_sweep_goes_on(sweep, monkeypatch, tmp_path):
    calls = []

    def call(node, name, *args, **kwargs):
        calls.append(f"{node}/{name}")
        if name == "disarm":
            raise RunAborted("service /hardware_node/disarm did not answer within 10 s")

    sweep.rig = SimpleNamespace(simulated=False, requires_arm=False)
    for name, value in (("_rig_now", lambda simulated: sweep.rig), ("_abort_on_hardware_problem", lambda: None),
                        ("prepare", lambda cell: None), ("trigger", lambda node, name, timeout_s=None: "ok"),
                        ("spin_until", lambda *args, **kwargs: True), ("spin_for", lambda seconds: None),
                        ("_wait_pose", lambda since_s, what: (0.0, 0.0, 0.0)), ("call", call),
                        ("vent", lambda: calls.append("vent") or True)):
        monkeypatch.setattr(sweep, name, value)
    record = sweep.run(CELL, 1.0, tmp_path / "bag")
    assert record.status == "failed: service /hardware_node/disarm did not answer within 10 s", record.status
    assert calls == ["gait_player/stop", "hardware_node/disarm", "vent"]  # vented after the abort, as any


def test_each_run_plays_the_gait_with_its_own_defaults_and_the_players_plain_playback(sweep, monkeypatch):
    set_to: dict[str, dict] = {}
    monkeypatch.setattr(sweep, "set_parameters", lambda node, values: set_to.setdefault(node, {}).update(values))
    monkeypatch.setattr(sweep, "regenerate", lambda: setattr(sweep, "_trajectories", sweep._trajectories + 1))
    sweep.prepare(CELL)
    server, player = set_to["trajectory_server"], set_to["gait_player"]
    assert server["gait"] == "inward_rolling" and server["amplitude_bar"] == 4.0 and server["frequency_hz"] == 1.0
    for parameter in list_gaits()["inward_rolling"].parameters:  # turn_phase_rad 0 among them: no turning left on
        assert server[f"inward_rolling.{parameter.name}"] == parameter.default
    assert player == {"frequency_hz": 1.0, "amplitude_scale": 1.0, "reverse": False, "cycles": 0,
                      "stop_at_phase": -1.0}

"""realtime_priority: the real-time nodes put every thread on SCHED_FIFO when allowed, and run on when not."""

import os
import shutil

import pytest
from srs_testing import ros_args

#: Runs the node without CAP_SYS_NICE (root's rtprio limit is 0): a lab user without an rtprio limit.
WITHOUT_CAP_SYS_NICE = ["capsh", "--drop=cap_sys_nice", "--", "-c", 'exec "$0" "$@"']


def policies(pid: int) -> set[int]:
    return {os.sched_getscheduler(int(task)) for task in os.listdir(f"/proc/{pid}/task")}


@pytest.mark.parametrize("script", ["gait_player", "hardware_node", "sim_world"])
def test_realtime_priority_puts_every_thread_on_sched_fifo_or_says_why_not(launch_node, ros_client, script):
    # Both outcomes need root (CAP_SYS_NICE) and capsh, as in CI; elsewhere this fails, it does not skip.
    assert os.geteuid() == 0 and shutil.which("capsh"), "run the suite as root with capsh (libcap2-bin) installed"
    allowed = launch_node(script, ros_args({"realtime_priority": 20}))
    refused = launch_node(script, ros_args({"realtime_priority": 20}, name=f"{script}_2"), prefix=WITHOUT_CAP_SYS_NICE)
    ros_client.spin_until(lambda: "every thread on SCHED_FIFO priority 20" in allowed.output(), 20.0,
                          "the real-time scheduling line")
    assert policies(allowed.process.pid) == {os.SCHED_FIFO}
    ros_client.spin_until(lambda: "SCHED_FIFO refused (Operation not permitted)" in refused.output(), 20.0,
                          "the refusal, with what to do")
    assert "rtprio" in refused.output() and policies(refused.process.pid) == {os.SCHED_OTHER}
    # both run on and answer
    for name in (script, f"{script}_2"):
        assert ros_client.get_parameters(f"/{name}", ["realtime_priority"]) == {"realtime_priority": 20}
    assert allowed.stop() == 0 and refused.stop() == 0

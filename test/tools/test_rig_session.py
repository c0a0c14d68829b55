"""What the tools that drive a rig directly share (srs_ros.tools.rig_session): the vent however they end."""

import os
import signal

import can
import cantools
import numpy as np

from srs_ros.backends import create_backend
from srs_ros.core.robot import config_dir
from srs_ros.tools.rig_session import EXIT_INTERRUPTED, interrupts_on_sigterm, run_vented


def test_a_sigterm_during_the_vent_after_ctrl_c_does_not_cut_the_can_vent_short():
    """Ctrl-C, then a supervisor's SIGTERM after the vent's first frame (of three): the vent went on with SIGINT
    ignored only, the SIGTERM ended it there and left modules 2 and 3 at 2 bar (a helper's review)."""
    backend = create_backend("can", options={"interface": "virtual", "channel": "rig_session_sigterm",
                                             "readback": False})
    board = can.Bus(interface="virtual", channel="rig_session_sigterm")
    dbc = cantools.database.load_file(str(config_dir() / "srs_dac.dbc"))

    def body():
        backend.write_pressures(np.full(9, 2.0))
        real_send = backend._bus.send

        def send(msg, timeout=None):  # the vent's first all-zero frame, then a SIGTERM lands
            real_send(msg, timeout)
            if not any(msg.data[:6]):
                backend._bus.send = real_send
                os.kill(os.getpid(), signal.SIGTERM)

        backend._bus.send = send
        raise KeyboardInterrupt  # the operator's Ctrl-C during the hold

    try:
        with interrupts_on_sigterm():
            code = run_vented(backend, "test", body, "done")
        last = {}
        while (msg := board.recv(timeout=0.05)) is not None:
            last[msg.arbitration_id] = dbc.decode_message(msg.arbitration_id, msg.data)
    finally:
        board.shutdown()
    assert code == EXIT_INTERRUPTED and not backend.is_open
    commands = {k: v for frame in last.values() for k, v in frame.items() if k.startswith("CMD_CH")}
    assert len(commands) == 9 and set(commands.values()) == {0.0}, commands

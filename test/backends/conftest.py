"""Fixtures of the backends' tests: a python-can virtual bus channel and the DAC board's side of it."""

import uuid

import can
import pytest


@pytest.fixture
def channel():
    return f"srs_test_{uuid.uuid4().hex[:8]}"


@pytest.fixture
def board(channel):
    """The DAC board's side of the virtual bus: receives every frame the backend sends."""
    bus = can.Bus(interface="virtual", channel=channel, receive_own_messages=False)
    yield bus
    bus.shutdown()

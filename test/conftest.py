"""Test-wide isolation: a private ROS_DOMAIN_ID, localhost-only discovery and a private log folder."""

from __future__ import annotations

import os
import tempfile

import pytest
from srs_testing import NodeProcess, RosClient, allocate_domain, fastdds_shm_clean, release_domain

_LOG_DIR = tempfile.mkdtemp(prefix="srs_ros_test_logs_")
os.environ["ROS_LOG_DIR"] = _LOG_DIR
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_STATIC_PEERS", None)
os.environ.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
os.environ["PYTHONUNBUFFERED"] = "1"
os.environ["MPLBACKEND"] = "Agg"


@pytest.fixture
def ros_domain():
    """A fresh DDS domain for one test; released (and Fast DDS shm cleaned) afterwards."""
    domain = allocate_domain()
    try:
        yield domain
    finally:
        release_domain(domain)
        fastdds_shm_clean()


@pytest.fixture
def ros_env(ros_domain):
    """Environment for node processes on the test's domain."""
    env = os.environ.copy()
    env["ROS_DOMAIN_ID"] = str(ros_domain)
    return env


@pytest.fixture
def ros_client(ros_domain):
    """An rclpy client node on the test's domain (closed in teardown)."""
    client = RosClient(ros_domain)
    try:
        yield client
    finally:
        client.close()


@pytest.fixture
def launch_node(ros_env, tmp_path):
    """Start console-script nodes on the test's domain; every one is stopped in teardown, pass or fail.

    Usage: ``proc = launch_node("gait_player", ros_args({"rate_hz": 200}))``; ``prefix`` runs it through a
    command that execs it (e.g. ``ip netns exec NS``).
    """
    started: list[NodeProcess] = []

    def _launch(script: str, args=(), env_overrides: dict[str, str] | None = None, prefix=()) -> NodeProcess:
        env = dict(ros_env, **(env_overrides or {}))
        proc = NodeProcess(script, args, env=env, log_dir=tmp_path, prefix=prefix)
        started.append(proc)
        return proc

    yield _launch
    for proc in started:
        proc.stop()

"""rosbag2 directories written by srs_ros.experiments.recording and read back with rosbags."""

import pytest
from rclpy.duration import Duration
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import serialize_message
from rosbags.interfaces import QosDurability, QosReliability, QosTime
from std_msgs.msg import String

from srs_ros.core.errors import ConfigurationError
from srs_ros.experiments.recording import (
    INFINITE_TIME,
    BagRecorder,
    bag_message_counts,
    bag_offered_qos,
    bag_qos,
)


def test_the_publishers_qos_is_recorded_as_rosbag2_does_once_per_topic(tmp_path):
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL, deadline=Duration(seconds=1.5))
    lossy = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT,
                       lifespan=Duration(nanoseconds=2**63 - 1))  # infinite, as Fast DDS reports it
    asked = []

    def offered():
        asked.append(1)
        return [bag_qos(latched), bag_qos(lossy)]

    data = serialize_message(String(data="x"))
    with BagRecorder(tmp_path / "bag") as bag:
        for stamp_ns in (1, 2, 3):
            bag.write("/latched", "std_msgs/msg/String", stamp_ns, data, offered_qos=offered)
        bag.write("/plain", "std_msgs/msg/String", 4, data)
    assert len(asked) == 1  # read at the topic's first message only
    assert bag_message_counts(tmp_path / "bag") == {"/latched": 3, "/plain": 1}
    recorded = bag_offered_qos(tmp_path / "bag")
    assert recorded["/plain"] == []
    first, second = recorded["/latched"]
    assert first.durability is QosDurability.TRANSIENT_LOCAL and first.depth == 1
    assert first.deadline == QosTime(1, 500_000_000)
    assert second.reliability is QosReliability.BEST_EFFORT and second.lifespan == INFINITE_TIME
    assert INFINITE_TIME == QosTime(9223372036, 854775807)  # as `ros2 bag record` of Jazzy writes it
    with pytest.raises(ConfigurationError, match="exists already"):
        BagRecorder(tmp_path / "bag")


def test_a_bag_where_no_folder_can_be_made_is_a_configuration_error_naming_it(tmp_path):
    """A bare FileNotFoundError before (a helper's review)."""
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    with pytest.raises(ConfigurationError, match=r"a_file/bag: cannot create the bag directory .*writable folder"):
        BagRecorder(blocker / "bag")

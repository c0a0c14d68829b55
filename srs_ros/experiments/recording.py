"""rosbag2 directories (``metadata.yaml`` + MCAP) written and read with ``rosbags``, no ROS install needed.

:class:`BagRecorder` takes messages already serialized as CDR (what rclpy's raw subscriptions and
``rclpy.serialization.serialize_message`` give) with their ROS type name, and writes them with the
message definitions of ROS 2 Jazzy's type store, so the bag opens in ``ros2 bag info`` / ``ros2 bag play``,
Foxglove and ``rosbags`` alike. A topic is added on its first message, so a bag holds exactly the topics
that carried data (e.g. ``/sim/ground_truth_pose`` only on the simulated rig). :meth:`BagRecorder.close`
(also on an exception, as a context manager) finishes the files: what was recorded is kept.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from srs_ros.core.errors import ConfigurationError

#: rosbag2 metadata version written (Jazzy's rosbag2 reads 9).
BAG_VERSION = 9
#: The type store whose message definitions go into the bag.
TYPESTORE = Stores.ROS2_JAZZY


class BagRecorder:
    """One rosbag2 directory being written; ``write(topic, type_name, stamp_ns, cdr)`` per message."""

    def __init__(self, path: str | Path):
        """Create the bag directory ``path`` (it must not exist yet)."""
        self.path = Path(path)
        if self.path.exists():
            raise ConfigurationError(f"{self.path}: exists already; a bag is written into a new directory.")
        self._typestore = get_typestore(TYPESTORE)
        self._writer = Writer(self.path, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._connections: dict[str, object] = {}
        self.counts: dict[str, int] = {}
        self.closed = False

    def __enter__(self) -> BagRecorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def write(self, topic: str, type_name: str, stamp_ns: int, data: bytes) -> None:
        """Add one CDR-serialized message of ``type_name`` (e.g. ``sensor_msgs/msg/JointState``) at ``stamp_ns``."""
        if self.closed:
            return
        connection = self._connections.get(topic)
        if connection is None:
            if type_name not in self._typestore.types:
                raise ConfigurationError(f"{topic}: message type {type_name!r} is not in the {TYPESTORE.name} "
                                         "type store; it cannot be recorded with its definition.")
            connection = self._writer.add_connection(topic, type_name, typestore=self._typestore)
            self._connections[topic] = connection
            self.counts[topic] = 0
        self._writer.write(connection, int(stamp_ns), bytes(data))
        self.counts[topic] += 1

    def close(self) -> None:
        """Finish the MCAP file and ``metadata.yaml`` (idempotent)."""
        if not self.closed:
            self.closed = True
            self._writer.close()


def bag_message_counts(path: str | Path) -> dict[str, int]:
    """Messages per topic of a rosbag2 directory (read with ``rosbags``)."""
    with Reader(Path(path)) as reader:
        return {connection.topic: connection.msgcount for connection in reader.connections}


def bag_topic_types(path: str | Path) -> Mapping[str, str]:
    """Topic -> message type of a rosbag2 directory."""
    with Reader(Path(path)) as reader:
        return {connection.topic: connection.msgtype for connection in reader.connections}

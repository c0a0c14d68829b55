"""Several hosts on one machine: network namespaces joined by a switch (root only)."""

from __future__ import annotations

import os
import subprocess
import time
from collections.abc import Iterable


class NetnsLab:
    """Lab hosts as network namespaces on one private subnet, joined by a bridge in a namespace of its own.

    Each host gets one veth link to the switch (``eth0``, address ``10.213.0.<n>/24``) and its loopback;
    nothing connects to this machine's own network, so no traffic leaves the namespaces. Processes run
    on a host through :meth:`prefix` (``ip netns exec``). :meth:`env` gives a node Fast DDS settings for
    hosts apart: UDP only (processes in different namespaces share /dev/shm, and shared-memory transport
    would bypass the link) and discovery through static peers, no multicast. :meth:`cut` / :meth:`restore`
    take a host's link down and up. Needs root (CAP_NET_ADMIN); raises RuntimeError with the reason
    when namespaces cannot be made. Used as a context manager: the namespaces go, pass or fail.
    """

    SUBNET = "10.213.0"

    def __init__(self, hosts: Iterable[str]):
        tag = f"srs{os.getpid() % 100000}x{time.monotonic_ns() % 1000}"
        self.hosts = list(hosts)
        self.namespaces = {host: f"{tag}_{host}" for host in self.hosts}
        self.switch = f"{tag}_switch"
        self.addresses = {host: f"{self.SUBNET}.{i + 1}" for i, host in enumerate(self.hosts)}
        self.ports = {host: f"port{i + 1}" for i, host in enumerate(self.hosts)}

    def _ip(self, *args: str) -> None:
        result = subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30, check=False)
        if result.returncode != 0:
            raise RuntimeError(f"`ip {' '.join(args)}` failed ({result.stderr.strip()}): network namespaces need "
                               "root (CAP_NET_ADMIN) and iproute2; see docs/multi_host.md.")

    def __enter__(self) -> NetnsLab:
        try:
            for namespace in (self.switch, *self.namespaces.values()):
                self._ip("netns", "add", namespace)
                self._ip("-n", namespace, "link", "set", "lo", "up")
            self._ip("-n", self.switch, "link", "add", "br0", "type", "bridge")
            self._ip("-n", self.switch, "link", "set", "br0", "up")
            for host, namespace in self.namespaces.items():
                port = self.ports[host]
                self._ip("link", "add", "eth0", "netns", namespace, "type", "veth", "peer", "name", port,
                         "netns", self.switch)
                self._ip("-n", self.switch, "link", "set", port, "master", "br0")
                self._ip("-n", self.switch, "link", "set", port, "up")
                self._ip("-n", namespace, "addr", "add", f"{self.addresses[host]}/24", "dev", "eth0")
                self._ip("-n", namespace, "link", "set", "eth0", "up")
        except BaseException:
            self.__exit__()
            raise
        return self

    def __exit__(self, *exc) -> None:
        for namespace in (*self.namespaces.values(), self.switch):
            subprocess.run(["ip", "netns", "del", namespace], capture_output=True, timeout=30, check=False)

    def prefix(self, host: str) -> list[str]:
        """Command prefix that runs a program on ``host``."""
        return ["ip", "netns", "exec", self.namespaces[host]]

    def env(self, host: str, base: dict[str, str]) -> dict[str, str]:
        """``base`` with Fast DDS over UDP only and discovery limited to the lab's hosts.

        ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` turns multicast off and finds the processes of the
        same host; ``ROS_STATIC_PEERS`` adds the other hosts (``OFF`` would ignore the static peers).
        """
        peers = [address for other, address in self.addresses.items() if other != host]
        return dict(base, FASTDDS_BUILTIN_TRANSPORTS="UDPv4", ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST",
                    ROS_STATIC_PEERS=";".join(peers))

    def cut(self, host: str) -> None:
        """Unplug ``host``'s cable (its switch port goes down)."""
        self._ip("-n", self.switch, "link", "set", self.ports[host], "down")

    def restore(self, host: str) -> None:
        """Plug ``host``'s cable back in."""
        self._ip("-n", self.switch, "link", "set", self.ports[host], "up")

"""Nodes over real DDS: isolated domains, node processes started by their console scripts, and an rclpy
client that talks to them as ``ros2 topic echo`` / ``ros2 service call`` / ``ros2 param set`` would.

Rules it enforces (measured traps of this rclpy build): clients spin with timed ``spin_once`` loops
only, every wait has a generous timeout, and every process is stopped in teardown, pass or fail.
A process that dies by a signal (SIGKILL, a crash) leaves its Fast DDS shared-memory files behind:
:meth:`NodeProcess.kill` and :meth:`NodeProcess.stop` note it (:func:`note_killed` for other
processes) and :func:`fastdds_shm_clean_if_killed` cleans only then (``fastdds shm clean`` costs a
subprocess, ~0.3 s).
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

DOMAIN_LOCK_DIR = Path(tempfile.gettempdir()) / "srs_ros_test_domains"
DOMAIN_RANGE = range(1, 102)
#: Margin after a service is ready before a client's first request that changes something (see RosClient.call).
FIRST_CALL_SETTLE_S = 0.1
#: Services a client may simply ask again when an answer is late.
READ_ONLY_SERVICES = ("GetState", "GetParameters", "ListParameters")


# ------------------------------------------------------------------------------------------
# DDS domains: one lock file per domain so parallel test runs on one machine never share one.
# ------------------------------------------------------------------------------------------
def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except OSError as exc:
        return exc.errno == errno.EPERM
    return True


def allocate_domain() -> int:
    """Reserve a free ROS_DOMAIN_ID in 1..101 for this process (released at exit or by :func:`release_domain`)."""
    DOMAIN_LOCK_DIR.mkdir(parents=True, exist_ok=True)
    start = (os.getpid() * 7919 + time.monotonic_ns()) % len(DOMAIN_RANGE)
    for offset in range(len(DOMAIN_RANGE)):
        domain = DOMAIN_RANGE[(start + offset) % len(DOMAIN_RANGE)]
        lock = DOMAIN_LOCK_DIR / f"{domain}.lock"
        with contextlib.suppress(FileNotFoundError, ValueError):
            owner = int(lock.read_text().strip() or 0)
            if owner and not _pid_alive(owner):
                lock.unlink()
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            continue
        with os.fdopen(fd, "w") as stream:
            stream.write(str(os.getpid()))
        return domain
    raise RuntimeError(f"no free ROS_DOMAIN_ID in {DOMAIN_RANGE}; remove stale locks in {DOMAIN_LOCK_DIR}")


def release_domain(domain: int) -> None:
    """Give a domain back."""
    with contextlib.suppress(FileNotFoundError):
        (DOMAIN_LOCK_DIR / f"{domain}.lock").unlink()


_killed = False  # a process died by a signal since the last clean: its shared-memory files may be left


def note_killed() -> None:
    """Say that a DDS process died without closing (SIGKILL, a crash): the next clean is needed."""
    global _killed
    _killed = True


def fastdds_shm_clean() -> None:
    """Remove Fast DDS shared-memory files left by killed processes (``fastdds shm clean``)."""
    global _killed
    tool = shutil.which("fastdds") or str(Path(sys.executable).with_name("fastdds"))
    if Path(tool).exists():
        subprocess.run([tool, "shm", "clean"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                       timeout=30, check=False)
    _killed = False


def fastdds_shm_clean_if_killed() -> bool:
    """:func:`fastdds_shm_clean` if a process died by a signal since the last clean; True if it ran."""
    if not _killed:
        return False
    fastdds_shm_clean()
    return True


def script_path(name: str) -> str:
    """Path of an installed console script (next to the test interpreter, or on PATH)."""
    local = Path(sys.executable).with_name(name)
    if local.exists():
        return str(local)
    found = shutil.which(name)
    if not found:
        raise FileNotFoundError(f"console script {name!r} is not installed; run `pip install -e '.[wheels,test]'`.")
    return found


# ------------------------------------------------------------------------------------------
# Node processes
# ------------------------------------------------------------------------------------------
def ros_args(params: dict[str, Any] | None = None, remaps: dict[str, str] | None = None,
             name: str | None = None) -> list[str]:
    """``--ros-args -p k:=v -r from:=to [-r __node:=name]`` for a console script."""
    args = ["--ros-args"]
    for key, value in (params or {}).items():
        if isinstance(value, bool):
            value = "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            value = "[" + ",".join(repr(v) if isinstance(v, str) else str(v) for v in value) + "]"
        args += ["-p", f"{key}:={value}"]
    for src, dst in (remaps or {}).items():
        args += ["-r", f"{src}:={dst}"]
    if name:
        args += ["-r", f"__node:={name}"]
    return args


#: Run before a node's command (it execs it, same pid): the node is killed when the test process that started it
#: dies. The hang watchdog ends a worker without any teardown, and its nodes lived on, answering as /hardware_node
#: in the domain the next test was given (a review of the harness). ``setpriv`` is util-linux's, in Debian's base.
DIE_WITH_PARENT = ["setpriv", "--pdeathsig", "KILL"] if shutil.which("setpriv") else []


class NodeProcess:
    """A node started from its console script in its own process; output goes to a log file.

    ``prefix`` runs it through another command that execs it (same pid), e.g. ``ip netns exec NS``. The node dies
    with the process that started it (:data:`DIE_WITH_PARENT`).
    """

    def __init__(self, script: str, args: Iterable[str] = (), env: dict[str, str] | None = None,
                 log_dir: Path | None = None, prefix: Iterable[str] = ()):
        self.script = script
        self.log_path = Path(log_dir or tempfile.mkdtemp(prefix="srs_node_")) / f"{script}.{time.monotonic_ns()}.log"
        self._log = self.log_path.open("w")
        self.process = subprocess.Popen(
            [*DIE_WITH_PARENT, *prefix, script_path(script), *args], env=env or os.environ.copy(), stdout=self._log,
            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True,
        )

    def output(self) -> str:
        """Everything the process printed so far (also after :meth:`stop`)."""
        if not self._log.closed:
            self._log.flush()
        return self.log_path.read_text(errors="replace")

    def alive(self) -> bool:
        return self.process.poll() is None

    def stop(self, timeout_s: float = 10.0) -> int | None:
        """Ctrl-C (SIGINT), then SIGTERM, then SIGKILL; return the exit code."""
        for sig, wait_s in ((signal.SIGINT, timeout_s), (signal.SIGTERM, 3.0), (signal.SIGKILL, 3.0)):
            if self.process.poll() is not None:
                break
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.process.pid, sig)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.process.wait(wait_s)
        self._log.close()
        code = self.process.poll()
        if code is None or code < 0:  # died by a signal (or outlived SIGKILL): shared memory left behind
            note_killed()
        return code

    def kill(self) -> None:
        """SIGKILL, as a crash would (use a fresh domain afterwards)."""
        note_killed()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.process.pid, signal.SIGKILL)
        self.process.wait(5.0)


# ------------------------------------------------------------------------------------------
# The rclpy client (what `ros2 topic echo` / `ros2 service call` / `ros2 param set` do)
# ------------------------------------------------------------------------------------------
class RosClient:
    """One rclpy context and node on a given domain, driven by timed ``spin_once`` loops."""

    def __init__(self, domain: int, name: str = "srs_test_client"):
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor

        self.rclpy = rclpy
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node(f"{name}_{os.getpid()}", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._clients: dict[tuple[str, Any], Any] = {}
        self._answered: set[tuple[str, Any]] = set()  # clients that got a reply: their discovery is complete

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.rclpy.shutdown(context=self.context)

    def __enter__(self) -> RosClient:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def spin_for(self, seconds: float) -> None:
        """Process callbacks for ``seconds`` (for collecting messages, not for waiting on events)."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=min(0.05, max(end - time.monotonic(), 0.0)))

    def spin_until(self, predicate: Callable[[], bool], timeout_s: float = 10.0, what: str = "condition") -> None:
        """Spin until ``predicate()`` is true; AssertionError naming ``what`` on timeout."""
        end = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > end:
                raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.05)

    def subscribe(self, msg_type, topic: str, qos=None) -> list:
        """Collect every message on ``topic`` into the returned list (default QoS: reliable, depth 100)."""
        received: list = []
        self.node.create_subscription(msg_type, topic, received.append, qos if qos is not None else 100)
        return received

    def client(self, srv_type, name: str, depth: int | None = None):
        """A service client (one per name and type); ``depth``: its response queue, for bursts of calls beyond
        rclpy's default of 10 (a busy client keeps only the newest 10 responses it has not taken yet)."""
        key = (name, srv_type)
        if key not in self._clients:
            from rclpy.qos import QoSProfile, ReliabilityPolicy

            qos = {} if depth is None else {"qos_profile": QoSProfile(depth=depth,
                                                                     reliability=ReliabilityPolicy.RELIABLE)}
            self._clients[key] = self.node.create_client(srv_type, name, **qos)
        return self._clients[key]

    def call(self, srv_type, name: str, request=None, timeout_s: float = 10.0, repeatable: bool = False):
        """Call a service and return its response (like ``ros2 service call``).

        ``service_is_ready`` says the server sees our requests; its reply writer may not have matched our
        reply reader yet (Fast DDS discovery is not symmetric). The server's rmw waits up to the reply
        writer's max_blocking_time (100 ms) for that match before it gives the reply up; measured here
        (420 first calls from fresh clients and fresh nodes, load 3-8 on 2 cores), no reply was lost. So a
        client's first call of a service that changes something waits :data:`FIRST_CALL_SETTLE_S` after
        ready as a margin, and read-only queries (get_state, get_parameters) go at once and are asked again
        if no answer came within a second (later: a third of the timeout). So is a call the test marks
        ``repeatable`` (asking again changes nothing, e.g. a start that is refused or repeated until it
        succeeds): once in a suite run on a loaded machine the first reply of a fresh server never came.
        """
        client = self.client(srv_type, name)
        self.spin_until(client.service_is_ready, timeout_s, f"service {name}")
        key = (name, srv_type)
        read_only = repeatable or srv_type.__name__ in READ_ONLY_SERVICES
        if key not in self._answered and not read_only:
            self.spin_for(FIRST_CALL_SETTLE_S)
        request = request if request is not None else srv_type.Request()
        end = time.monotonic() + timeout_s
        retry_s = 1.0 if key not in self._answered else timeout_s / 3
        while True:
            future = client.call_async(request)
            wait_s = end - time.monotonic()
            if read_only:
                wait_s, retry_s = min(wait_s, retry_s), timeout_s / 3
            try:
                self.spin_until(future.done, max(wait_s, 0.0), f"response of {name}")
            except AssertionError:
                if not read_only or time.monotonic() >= end:
                    raise
                client.remove_pending_request(future)
                continue
            self._answered.add(key)
            return future.result()

    def discover(self, services: Iterable[tuple[Any, str]], timeout_s: float = 30.0) -> None:
        """Wait for several services (``(srv_type, name)`` pairs) at once, with one settle time for all.

        Saves :meth:`call`'s wait after ready on each first call (:data:`FIRST_CALL_SETTLE_S` per service)
        where a test talks to many services of several nodes.
        """
        keys = [(name, srv_type) for srv_type, name in services]
        clients = [self.client(srv_type, name) for name, srv_type in keys]
        self.spin_until(lambda: all(c.service_is_ready() for c in clients), timeout_s, f"services {keys}")
        self.spin_for(FIRST_CALL_SETTLE_S)
        self._answered.update(keys)

    def trigger(self, name: str, timeout_s: float = 10.0, repeatable: bool = False):
        """Call a std_srvs/Trigger service (``repeatable``: asked again if no reply came, see :meth:`call`)."""
        from std_srvs.srv import Trigger

        return self.call(Trigger, name, timeout_s=timeout_s, repeatable=repeatable)

    def set_parameters(self, node: str, values: dict[str, Any], timeout_s: float = 10.0) -> list:
        """Set parameters of ``node`` (like ``ros2 param set``); returns the SetParametersResult list."""
        from rcl_interfaces.srv import SetParameters
        from rclpy.parameter import Parameter

        request = SetParameters.Request()
        request.parameters = [Parameter(k, value=v).to_parameter_msg() for k, v in values.items()]
        return self.call(SetParameters, f"{node}/set_parameters", request, timeout_s).results

    def get_parameters(self, node: str, names: list[str], timeout_s: float = 10.0) -> dict[str, Any]:
        """Read parameters of ``node`` (like ``ros2 param get``)."""
        from rcl_interfaces.srv import GetParameters
        from rclpy.parameter import parameter_value_to_python

        request = GetParameters.Request(names=names)
        values = self.call(GetParameters, f"{node}/get_parameters", request, timeout_s).values
        return {n: parameter_value_to_python(v) for n, v in zip(names, values)}

    def change_state(self, node: str, transition: str, timeout_s: float = 10.0) -> bool:
        """Trigger a lifecycle transition by label (``configure``, ``activate``, ``deactivate``, ...)."""
        from lifecycle_msgs.msg import Transition
        from lifecycle_msgs.srv import ChangeState

        ids = {"configure": Transition.TRANSITION_CONFIGURE, "activate": Transition.TRANSITION_ACTIVATE,
               "deactivate": Transition.TRANSITION_DEACTIVATE, "cleanup": Transition.TRANSITION_CLEANUP,
               "shutdown": Transition.TRANSITION_UNCONFIGURED_SHUTDOWN}
        request = ChangeState.Request()
        request.transition.id = ids[transition]
        return self.call(ChangeState, f"{node}/change_state", request, timeout_s).success

    def lifecycle_state(self, node: str, timeout_s: float = 10.0) -> str:
        """Current lifecycle state label (``unconfigured``, ``inactive``, ``active``, ...)."""
        from lifecycle_msgs.srv import GetState

        return self.call(GetState, f"{node}/get_state", timeout_s=timeout_s).current_state.label


# ------------------------------------------------------------------------------------------
# A session: one private domain, its client and the processes started on it (tests that share nodes)
# ------------------------------------------------------------------------------------------
class RosSession:
    """A private DDS domain, its environment, an rclpy client on it and the node processes started on it.

    What the function-scoped fixtures (``ros_domain``, ``ros_env``, ``ros_client``, ``launch_node``) give
    one test, for a longer life: a module-scoped fixture keeps a node process that several tests share.
    :meth:`close` stops every process, closes the client and gives the domain back.
    """

    def __init__(self, log_dir: Path, client_name: str = "srs_test_client"):
        self.log_dir = Path(log_dir)
        self.domain = allocate_domain()
        self.env = dict(os.environ, ROS_DOMAIN_ID=str(self.domain))
        self.started: list[NodeProcess] = []
        try:
            self.client = RosClient(self.domain, client_name)
        except BaseException:
            release_domain(self.domain)
            raise

    def launch(self, script: str, args: Iterable[str] = (), env_overrides: dict[str, str] | None = None,
               prefix: Iterable[str] = ()) -> NodeProcess:
        """Start a console-script node on this session's domain (stopped by :meth:`close`)."""
        proc = NodeProcess(script, args, env=dict(self.env, **(env_overrides or {})), log_dir=self.log_dir,
                           prefix=prefix)
        self.started.append(proc)
        return proc

    def __enter__(self) -> RosSession:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Stop every process started here (pass or fail), close the client and give the domain back."""
        try:
            for proc in self.started:
                proc.stop()
            self.client.close()
        finally:
            release_domain(self.domain)
            fastdds_shm_clean_if_killed()


def camera_profile_env() -> dict[str, str]:
    """The opt-in Fast DDS profile of config/ (camera images through shared memory) as a node's environment
    (``env_overrides`` of a launch); docs/navigation.md says when to use it."""
    from srs_ros.core.robot import config_dir
    from srs_ros.ros.interfaces import DDS_PROFILE_ENV, DDS_PROFILE_FILE

    return {DDS_PROFILE_ENV: str(config_dir() / DDS_PROFILE_FILE)}


def launch_sim_loop(launch: Callable[..., NodeProcess], overrides: dict[str, dict[str, Any]] | None = None,
                    dds_profile: bool = False) -> dict[str, NodeProcess]:
    """The simulated loop as separate processes, as the launch file's defaults start it; by node name.

    sim_world, hardware_node on the sim rig (autostart), trajectory_server, gait_player (autostart) and
    camera_tracker on the simulated camera's bands. ``launch`` starts one node (:meth:`RosSession.launch`, the
    ``launch_node`` fixture); ``overrides`` adds or replaces parameters by node (e.g. ``{"sim_world":
    {"camera_rate_hz": 15.0}}``). With a :class:`RosSession` as a context manager every process is stopped at
    its end, pass or fail. With ``dds_profile`` every process gets the opt-in camera profile
    (:func:`camera_profile_env`); without it Fast DDS's defaults, as the launch file starts them.
    """
    from srs_ros.core.rig import SIM_COLOR_PRESET, rig_path

    params = {"sim_world": {}, "hardware_node": {"autostart": True, "rig_file": str(rig_path("sim"))},
              "trajectory_server": {}, "gait_player": {"autostart": True},
              "camera_tracker": {"color_preset": SIM_COLOR_PRESET}}
    for node, values in (overrides or {}).items():
        params[node] = {**params[node], **values}
    env = camera_profile_env() if dds_profile else {}
    return {node: launch(node, ros_args(values), env_overrides=env) for node, values in params.items()}

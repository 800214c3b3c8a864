"""A real Ray cluster of two nodes on this machine, for the tests that join one.

:func:`ray_cluster` starts a head node and a worker node (``ray start --block``, each in a session
of its own, one CPU each), pinned to a loopback address and sharing one token, waits until the
cluster shows both nodes, and yields a :class:`RayCluster`: its address and the environment a
driver needs to join it. On leaving, each node's process group is ended by the ``ray start``
process's own id (SIGTERM, then SIGKILL), never by name as ``ray stop`` would; :meth:`RayCluster.left`
lists any process of the two sessions still alive.

Ray turns ``127.0.0.1`` and ``localhost`` given as a node's address into the machine's outward
address; another address of the loopback network (``127.0.0.2``) is kept as given, so the nodes
and the driver use that one.
"""

from __future__ import annotations

import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path

#: The loopback address every node and the driver are pinned to (see the module docstring).
NODE_IP = "127.0.0.2"
#: Seconds a node may take to join before the cluster counts as failed to start.
START_SECONDS = 180.0
#: Seconds a node's processes get to end on SIGTERM before they are killed.
STOP_SECONDS = 5.0

ROOT = Path(__file__).resolve().parents[1]


@dataclass
class RayCluster:
    """A running two-node cluster: where to join it and with what."""

    address: str
    env: dict[str, str]
    """The variables a driver joining it sets: the token, its mode and the node address."""
    sessions: list[int] = field(default_factory=list)
    """The session ids (the ``ray start`` processes' pids) of the nodes."""

    def left(self) -> list[str]:
        """``pid command`` of every process still alive in the nodes' sessions."""
        found = []
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit():
                continue
            try:
                fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
                if int(fields[3]) in self.sessions and fields[0] != "Z":  # field 6 of stat: the session id
                    command = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
                    found.append(f"{entry.name} {command}")
            except (OSError, IndexError, ValueError):
                continue  # ended while being read
        return found


def ray_executable() -> str | None:
    """The ``ray`` command beside this Python, if Ray is installed."""
    candidate = Path(sys.executable).parent / "ray"
    return str(candidate) if candidate.exists() else shutil.which("ray")


def free_port() -> int:
    with socket.socket() as s:
        s.bind((NODE_IP, 0))
        return int(s.getsockname()[1])


@contextmanager
def ray_cluster(log_dir: Path) -> Iterator[RayCluster]:
    """A head and a worker node of one CPU each (see the module docstring); their output goes to
    ``log_dir``, their session files to a short folder of their own under /tmp (Unix socket paths
    are limited to about 107 characters)."""
    ray = ray_executable()
    assert ray is not None, "Ray is not installed"
    port = free_port()
    env = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(16), "ARENA_LEAGUE_RAY_NODE_IP": NODE_IP}
    # the nodes' workers import arena_league and the tests' helpers from here
    path = os.pathsep.join([str(ROOT), str(ROOT / "tests"), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    node_env = {**os.environ, **env, "PYTHONPATH": path, "OMP_NUM_THREADS": "1", "RAY_USAGE_STATS_ENABLED": "0"}
    node_env.pop("RAY_ADDRESS", None)
    temp_dir = Path(f"/tmp/ray-{secrets.token_hex(3)}")
    cluster = RayCluster(f"{NODE_IP}:{port}", env)
    common = ["--block", "--num-cpus", "1", "--node-ip-address", NODE_IP, "--disable-usage-stats"]
    commands = [[ray, "start", "--head", "--port", str(port), "--include-dashboard=false", "--temp-dir",
                 str(temp_dir), *common],
                [ray, "start", "--address", cluster.address, *common]]
    nodes: list[subprocess.Popen] = []
    log_dir.mkdir(parents=True, exist_ok=True)
    try:
        for k, command in enumerate(commands):
            with (log_dir / f"node-{k}.log").open("w") as log:
                nodes.append(subprocess.Popen(command, env=node_env, stdout=log, stderr=subprocess.STDOUT,
                                              stdin=subprocess.DEVNULL, start_new_session=True))
            cluster.sessions.append(nodes[-1].pid)
        _wait_for_nodes(ray, cluster, node_env, nodes, log_dir)
        yield cluster
    finally:
        _end(nodes)
        shutil.rmtree(temp_dir, ignore_errors=True)


def _wait_for_nodes(ray: str, cluster: RayCluster, env: dict[str, str], nodes: list[subprocess.Popen],
                    log_dir: Path) -> None:
    """Return once ``ray list nodes`` shows both nodes alive; fail with the nodes' logs otherwise."""
    deadline = time.monotonic() + START_SECONDS
    while time.monotonic() < deadline:
        ended = [k for k, node in enumerate(nodes) if node.poll() is not None]
        if ended:
            raise RuntimeError(f"node {ended[0]} of the Ray cluster ended at start:\n"
                               + (log_dir / f"node-{ended[0]}.log").read_text()[-3000:])
        status = subprocess.run([ray, "status", "--address", cluster.address], env=env, capture_output=True, check=False,
                                text=True, timeout=60)
        active = status.stdout.split("Active:", 1)[-1].split("Pending:", 1)[0]
        if status.returncode == 0 and active.count(" node_") >= 2:
            return
        time.sleep(1.0)
    raise RuntimeError(f"the Ray cluster did not show 2 nodes within {START_SECONDS:.0f} s")


def _end(nodes: list[subprocess.Popen]) -> None:
    """End the nodes' process groups by their leaders' pids, all at once: SIGTERM, then SIGKILL to
    the groups still alive after :data:`STOP_SECONDS`."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        for node in nodes:
            with suppress(ProcessLookupError):
                os.killpg(node.pid, sig)
        deadline = time.monotonic() + STOP_SECONDS
        while time.monotonic() < deadline:
            for node in nodes:
                node.poll()  # reap the leader, so that its group counts as ended once the rest is
            if not any(_group_alive(node.pid) for node in nodes):
                return
            time.sleep(0.2)
    for node in nodes:
        node.wait(STOP_SECONDS)


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True


#: Times this process ran :func:`count_setup`, by its argument (the tasks of the executor's tests).
SETUPS: dict[str, int] = {}


def count_setup(label: str) -> None:
    """An executor's initializer: counts its runs in this worker process."""
    SETUPS[label] = SETUPS.get(label, 0) + 1


def where_and_setups(label: str, seconds: float) -> tuple[str, int, int]:
    """An executor's task: (its Ray node id, its pid, the runs of ``count_setup(label)`` here),
    after ``seconds`` of sleep (so that the tasks overlap and spread over the nodes)."""
    import ray

    time.sleep(seconds)
    return ray.get_runtime_context().get_node_id(), os.getpid(), SETUPS.get(label, 0)


def fail(message: str, seconds: float = 0.0) -> None:
    """An executor's task that fails after ``seconds``."""
    time.sleep(seconds)
    raise ValueError(message)


class NodeRecording:
    """A match recording that records only where the match was played: its result's
    ``replay_path`` is the Ray node id of the worker that played it."""

    def __call__(self, spec, env, env_kwargs) -> NodeRecording:
        return self

    def before_step(self, obs, actions, acting) -> None:
        pass

    def after_step(self, rewards) -> None:
        pass

    def close(self, result) -> str:
        import ray

        return ray.get_runtime_context().get_node_id()

    def abort(self) -> None:
        pass

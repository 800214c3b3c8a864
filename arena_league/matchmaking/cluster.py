"""Joining Ray: a cluster when an address is given, a local instance otherwise.

:func:`join_ray` is the one place the league starts Ray in this process; the Ray match backend
(:func:`arena_league.matchmaking.play_matches`) and the population build's task executor
(:mod:`arena_league.league.population.processes`) both call it. With an address (the argument, or
``RAY_ADDRESS``) it joins that cluster; without one it starts a local instance whose workers import
``arena_league`` from the same place as this process.

What it reads from the environment:

* ``RAY_ADDRESS``: the cluster to join when no address is given (Ray's own variable).
* ``ARENA_LEAGUE_RAY_NODE_IP``: the address of this machine's node, passed to Ray as
  ``_node_ip_address`` (default: Ray's own choice, the machine's outward address). It must be the
  address the machine's nodes were started with (``ray start --node-ip-address``), or the driver
  finds no node of its own. Ray replaces ``127.0.0.1`` and ``localhost`` by the outward address;
  to keep a single-machine cluster on the loopback network, start its nodes and the driver with
  another loopback address such as ``127.0.0.2``.
* ``RAY_AUTH_TOKEN`` or ``RAY_AUTH_TOKEN_PATH`` (a file holding the token), and ``RAY_AUTH_MODE``:
  Ray's token authentication, read by Ray itself. A cluster started with ``RAY_AUTH_MODE=token``
  refuses a node or a driver without its head's token. Ray turns token mode on by itself only
  for a local instance, so when a token is given and ``RAY_AUTH_MODE`` is not, joining a cluster
  sets ``RAY_AUTH_MODE=token``: the token given is the token used.

Every node of a cluster needs ``arena_league`` importable and the files the tasks read and write
(agents' artifacts, a build's work folder) at the same paths.

:func:`local_cluster` starts a real cluster of several nodes on this machine (``ray start --block``
per node, each in a session of its own, pinned to a loopback address and sharing one token), for
trying the Ray backends and for the tests and benchmarks that join one. Ray turns ``127.0.0.1``
and ``localhost`` given as a node's address into the machine's outward address; another address
of the loopback network (``127.0.0.2``) is kept as given, so the nodes and the driver use that one.
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
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["NODE_IP", "NODE_IP_VARIABLE", "LocalCluster", "UnreachableClusterError", "join_ray", "local_cluster"]

#: The variable naming this machine's node address (see the module docstring).
NODE_IP_VARIABLE = "ARENA_LEAGUE_RAY_NODE_IP"


def join_ray(address: str | None = None, num_cpus: int | None = None) -> Any:
    """The ``ray`` module, initialised in this process: joined to the cluster at ``address`` (or
    ``RAY_ADDRESS``), else a new local instance with ``num_cpus`` CPUs (default: every core).
    Already initialised: left as it is."""
    try:
        import ray
    except ImportError as error:
        raise RuntimeError("the ray backend needs Ray: pip install 'arena-league[ray]'") from error
    if ray.is_initialized():
        return ray
    address = address or os.environ.get("RAY_ADDRESS") or None
    node_ip = os.environ.get(NODE_IP_VARIABLE) or None
    if address:
        _check_reachable(address)
        _token_mode_for_a_given_token()
        try:
            ray.init(address=address, _node_ip_address=node_ip, log_to_driver=False)
        except ConnectionError as error:
            raise UnreachableClusterError(
                f"cannot join the Ray cluster at {address}: check that the address is the head's, that RAY_AUTH_TOKEN "
                f"(or RAY_AUTH_TOKEN_PATH) gives the head's token and that {NODE_IP_VARIABLE} is the address "
                f"this machine's node was started with ({error})") from error
        return ray
    # a local instance: its workers import arena_league from the same place as this process
    package_root = str(Path(__file__).resolve().parents[2])
    path = os.pathsep.join(p for p in (package_root, os.environ.get("PYTHONPATH", "")) if p)
    ray.init(num_cpus=num_cpus or os.cpu_count() or 1, include_dashboard=False, log_to_driver=False,
             _node_ip_address=node_ip, runtime_env={"env_vars": {"PYTHONPATH": path, "OMP_NUM_THREADS": "1"}})
    return ray


class UnreachableClusterError(ConnectionError, ValueError):
    """The Ray cluster named cannot be joined: a bad address given by the user, so also a ValueError,
    which the front ends turn into one line."""


#: Seconds a cluster's address gets to answer before joining it is given up.
REACH_SECONDS = 5.0


def _check_reachable(address: str) -> None:
    """Refuse at once an address where nothing answers, rather than let Ray retry it for minutes."""
    if address in ("auto", "local"):
        return
    target = address.split("://", 1)[-1].rstrip("/")
    host, sep, port = target.rpartition(":")
    if not sep or not port.isdigit():
        raise UnreachableClusterError(f"the Ray address {address!r} is not HOST:PORT (the head's address, e.g. "
                                      "10.0.0.10:6379) or ray://HOST:PORT")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=REACH_SECONDS):
            pass
    except OSError as error:
        raise UnreachableClusterError(
            f"nothing answers at the Ray address {address} ({error.strerror or error}); start the cluster's head "
            f"there (`ray start --head`), or give its address with --address or RAY_ADDRESS") from None


def _token_mode_for_a_given_token() -> None:
    """Token mode on when a token is given and no mode is (Ray leaves it off for a given address),
    and Ray's settings and token read afresh: Ray reads them once, at import (the mode) and at the
    first connection (the token), and keeps them for the process's life otherwise."""
    from ray._raylet import AuthenticationTokenLoader, Config

    if "RAY_AUTH_MODE" not in os.environ and (os.environ.get("RAY_AUTH_TOKEN") or
                                              os.environ.get("RAY_AUTH_TOKEN_PATH")):
        os.environ["RAY_AUTH_MODE"] = "token"
    Config.initialize("")
    AuthenticationTokenLoader.instance().reset_cache()


# --- a cluster on this machine -----------------------------------------------------------------

#: The loopback address every node and the driver are pinned to (see the module docstring).
NODE_IP = "127.0.0.2"
#: Seconds a node may take to join before the cluster counts as failed to start.
START_SECONDS = 180.0
#: Seconds a node's processes get to end on SIGTERM before they are killed.
STOP_SECONDS = 5.0

#: The folder holding the ``arena_league`` package, for the nodes' workers to import it from.
PACKAGE_ROOT = Path(__file__).resolve().parents[2]


@dataclass
class LocalCluster:
    """A running cluster on this machine: where to join it and with what."""

    address: str
    env: dict[str, str]
    """The variables a driver joining it sets: the token, its mode and the node address."""
    dashboard: str | None = None
    """The head's dashboard, where ``ray job submit --address`` sends jobs (``http://HOST:PORT``);
    None when the cluster was started without one."""
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
def local_cluster(log_dir: Path, nodes: int = 2, cpus_per_node: int = 1,
                  python_path: Sequence[str | Path] = (), dashboard: bool = False) -> Iterator[LocalCluster]:
    """A head and ``nodes - 1`` worker nodes of ``cpus_per_node`` CPUs each on this machine,
    pinned to :data:`NODE_IP` and sharing a fresh token; their output goes to ``log_dir``, their
    session files to a short folder of their own under /tmp (Unix socket paths are limited to about
    107 characters). ``python_path``: more folders the nodes' workers import from. ``dashboard``:
    start the head's dashboard too (it needs ``ray[default]``), for ``ray job submit``. On leaving,
    the nodes are ended by their own process ids, never by name."""
    if nodes < 1 or cpus_per_node < 1:
        raise ValueError("a local cluster needs at least one node of at least one CPU")
    ray = ray_executable()
    if ray is None:
        raise RuntimeError("Ray's `ray` command is not installed: pip install 'arena-league[ray]'")
    port = free_port()
    env = {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": secrets.token_hex(16), NODE_IP_VARIABLE: NODE_IP}
    # the nodes' workers import arena_league (and anything else asked) from here
    path = os.pathsep.join([str(PACKAGE_ROOT), *map(str, python_path),
                            os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    node_env = {**os.environ, **env, "PYTHONPATH": path, "OMP_NUM_THREADS": "1", "RAY_USAGE_STATS_ENABLED": "0"}
    node_env.pop("RAY_ADDRESS", None)
    # a folder per node, as separate machines have: a node cleans its own runtime resources (a job's
    # working folder) when its tasks end, which must not pull them from under another node
    temp_dirs = [Path(f"/tmp/ray-{secrets.token_hex(3)}-{k}") for k in range(nodes)]
    cluster = LocalCluster(f"{NODE_IP}:{port}", env)
    common = ["--block", "--num-cpus", str(cpus_per_node), "--node-ip-address", NODE_IP, "--disable-usage-stats"]
    head = ["--include-dashboard=false"]
    if dashboard:
        dashboard_port = free_port()
        cluster.dashboard = f"http://{NODE_IP}:{dashboard_port}"
        head = ["--include-dashboard=true", "--dashboard-host", NODE_IP, "--dashboard-port", str(dashboard_port)]
    commands = [[ray, "start", "--head", "--port", str(port), *head, "--temp-dir", str(temp_dirs[0]), *common],
                *([ray, "start", "--address", cluster.address, "--temp-dir", str(folder), *common]
                  for folder in temp_dirs[1:])]
    nodes: list[subprocess.Popen] = []
    log_dir.mkdir(parents=True, exist_ok=True)
    try:
        for k, command in enumerate(commands):
            with (log_dir / f"node-{k}.log").open("w") as log:
                nodes.append(subprocess.Popen(command, env=node_env, stdout=log, stderr=subprocess.STDOUT,
                                              stdin=subprocess.DEVNULL, start_new_session=True))
            cluster.sessions.append(nodes[-1].pid)
        _wait_for_nodes(ray, cluster, node_env, nodes, log_dir)
        if cluster.dashboard is not None:
            _wait_for_dashboard(cluster.dashboard, nodes[0], log_dir)
        yield cluster
    finally:
        _end(nodes)
        for folder in temp_dirs:
            shutil.rmtree(folder, ignore_errors=True)


def _wait_for_nodes(ray: str, cluster: LocalCluster, env: dict[str, str], nodes: list[subprocess.Popen],
                    log_dir: Path) -> None:
    """Return once ``ray status`` shows every node alive; fail with the nodes' logs otherwise."""
    deadline = time.monotonic() + START_SECONDS
    while time.monotonic() < deadline:
        ended = [k for k, node in enumerate(nodes) if node.poll() is not None]
        if ended:
            raise RuntimeError(f"node {ended[0]} of the Ray cluster ended at start:\n"
                               + (log_dir / f"node-{ended[0]}.log").read_text()[-3000:])
        status = subprocess.run([ray, "status", "--address", cluster.address], env=env, capture_output=True, check=False,
                                text=True, timeout=60)
        active = status.stdout.split("Active:", 1)[-1].split("Pending:", 1)[0]
        if status.returncode == 0 and active.count(" node_") >= len(nodes):
            return
        time.sleep(1.0)
    raise RuntimeError(f"the Ray cluster did not show {len(nodes)} nodes within {START_SECONDS:.0f} s")


def _wait_for_dashboard(url: str, head: subprocess.Popen, log_dir: Path) -> None:
    """Return once the head's dashboard answers HTTP, which it starts after the nodes join."""
    import urllib.error
    import urllib.request

    deadline = time.monotonic() + START_SECONDS
    while time.monotonic() < deadline:
        if head.poll() is not None:
            raise RuntimeError("the Ray cluster's head ended at start:\n" + (log_dir / "node-0.log").read_text()[-3000:])
        try:
            with urllib.request.urlopen(f"{url}/api/version", timeout=5):
                return
        except urllib.error.HTTPError:
            return  # it answers (refusing a request without the token is an answer)
        except OSError:
            time.sleep(1.0)
    raise RuntimeError(f"the Ray dashboard at {url} did not answer within {START_SECONDS:.0f} s")


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

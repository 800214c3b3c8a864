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
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

__all__ = ["NODE_IP_VARIABLE", "join_ray"]

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
        _token_mode_for_a_given_token()
        try:
            ray.init(address=address, _node_ip_address=node_ip, log_to_driver=False)
        except ConnectionError as error:
            raise ConnectionError(
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

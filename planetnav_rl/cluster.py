"""The Ray connection: an embedded local Ray on loopback, or a running cluster at ``--address``.

Without an address, :func:`init_ray` starts a fresh local Ray whose every process binds to 127.0.0.1
(no other interface is ever used, nothing to set up). With an address, it joins that cluster after
:func:`check_address` has checked the address's form and that something listens there (a short TCP
connect), so a typo fails in about a second with a message naming the address, not after Ray's
own minute of retries.
"""

from __future__ import annotations

import ipaddress
import os
import socket
from typing import Any

from planetnav_env.errors import ConfigError

LOOPBACK = "127.0.0.1"

#: Seconds :func:`check_address` waits for a TCP connection to the cluster's GCS port.
CONNECT_TIMEOUT_S = 3.0


def loopback_environment() -> None:
    """Keep Ray on 127.0.0.1: without this variable Ray on Linux replaces a loopback address by the
    machine's interface address (measured with ray 2.60), both for a node's own address and for the address
    a driver connects to. Set before Ray starts any process, so that the processes it spawns inherit it.

    Ray reads the variable once, when ``ray`` is first imported; if that already happened in this process
    (a test module importing ``ray`` first), its module-level flag is set to match as well.
    """
    import sys

    os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
    constants = sys.modules.get("ray._private.ray_constants")
    if constants is not None:
        constants.ENABLE_RAY_CLUSTER = False


def is_loopback(host: str) -> bool:
    """Whether ``host`` names this machine's loopback interface (no DNS lookup)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def parse_address(address: str) -> tuple[str, str, int]:
    """Split ``[ray://]host:port`` into ``(scheme, host, port)``; raise :class:`ConfigError` naming a bad one.

    ``scheme`` is ``""`` for a GCS address (``ray start --head`` prints ``host:6379``) and ``"ray://"`` for a
    Ray Client server (default port 10001). Dotted-number hosts must be valid IPv4 (``256.1.1.1`` is not),
    and the port must be in 1..65535.
    """
    text = str(address).strip()
    scheme = ""
    if text.startswith("ray://"):
        scheme, text = "ray://", text[len("ray://") :]
    host, sep, port_s = text.rpartition(":")
    if not sep or not host or not port_s:
        raise ConfigError(f"--address {address!r} is not of the form host:port (e.g. 127.0.0.1:6379)")
    host = host.strip("[]")  # [::1]:6379
    try:
        port = int(port_s)
    except ValueError:
        raise ConfigError(f"--address {address!r}: port {port_s!r} is not a number") from None
    if not 1 <= port <= 65535:
        raise ConfigError(f"--address {address!r}: port {port} is outside 1..65535")
    if all(part.isdigit() for part in host.split(".")):
        try:
            ipaddress.IPv4Address(host)
        except ValueError:
            raise ConfigError(f"--address {address!r}: {host!r} is not a valid IPv4 address") from None
    return scheme, host, port


def check_address(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> str:
    """Check ``address`` (see :func:`parse_address`) and that a TCP connection to it opens within
    ``timeout_s`` seconds; return it normalised. Raises :class:`ConfigError` naming the address."""
    scheme, host, port = parse_address(address)
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except OSError as exc:
        raise ConfigError(
            f"--address {address!r}: no Ray cluster reachable at {host}:{port} within {timeout_s:g} s "
            f"({type(exc).__name__}: {exc}); start one with `ray start --head` (docs/scaling.md)"
        ) from None
    return f"{scheme}{host}:{port}"


def init_ray(address: str | None = None, num_cpus: int | None = None, **kwargs: Any) -> dict[str, Any]:
    """Connect this process to Ray and return ``ray.init``'s context as a dict.

    ``address=None``: start a new local Ray (never attach to one that happens to run on the machine),
    ``num_cpus`` CPUs (default: all), every process on 127.0.0.1, no dashboard. ``address``: join the
    cluster there after :func:`check_address`. If Ray is already initialised in this process (a test's
    ``Cluster``, a notebook) it is left as it is.
    """
    from planetnav_rl import require_ray

    require_ray("Ray training and sweeps")
    checked = check_address(address) if address else None
    if checked is None or is_loopback(parse_address(checked)[1]):
        # A local Ray, or a cluster on this machine's loopback: every address stays 127.0.0.1. Not for a
        # remote cluster: its nodes must reach this driver at the machine's real address.
        loopback_environment()
    import ray

    if ray.is_initialized():
        return {"address": ray.get_runtime_context().gcs_address, "started": False}
    if address:
        ctx = ray.init(address=checked, log_to_driver=False, **kwargs)
    else:
        ctx = ray.init(
            address="local",
            num_cpus=num_cpus,
            include_dashboard=False,
            _node_ip_address=LOOPBACK,
            log_to_driver=False,
            **kwargs,
        )
    return {"address": getattr(ctx, "address_info", {}).get("gcs_address"), "started": True}


def shutdown_ray(info: dict[str, Any]) -> None:
    """Shut Ray down in this process if :func:`init_ray` started or joined it (``info["started"]``)."""
    if info.get("started"):
        import ray

        ray.shutdown()


def node_label() -> dict[str, str]:
    """This worker's node: Ray node id (unique even when all nodes share 127.0.0.1), IP and host name."""
    import ray

    return {
        "node_id": ray.get_runtime_context().get_node_id(),
        "node_ip": ray.util.get_node_ip_address(),
        "hostname": socket.gethostname(),
    }


def loopback_cluster(num_nodes: int = 2, cpus_per_node: int = 1, connect: bool = True) -> Any:
    """A ``ray.cluster_utils.Cluster`` of ``num_nodes`` nodes on 127.0.0.1 with ``cpus_per_node`` CPUs each,
    this process connected to it (``connect``). For tests and benchmarks of multi-node behaviour on one
    machine: end it with ``ray.shutdown()`` then ``cluster.shutdown()``, which ends exactly the processes
    it started (unlike ``ray stop``, which ends every Ray process on the machine by name)."""
    from planetnav_rl import require_ray

    require_ray("a loopback test cluster")
    loopback_environment()  # before any Ray process starts: they inherit it
    import ray
    from ray.cluster_utils import Cluster

    cluster = Cluster(
        initialize_head=True,
        head_node_args={"num_cpus": cpus_per_node, "node_ip_address": LOOPBACK, "include_dashboard": False},
    )
    try:
        for _ in range(num_nodes - 1):
            cluster.add_node(num_cpus=cpus_per_node, node_ip_address=LOOPBACK)
        if connect:
            ray.init(address=cluster.address, log_to_driver=False)
    except BaseException:
        cluster.shutdown()
        raise
    return cluster

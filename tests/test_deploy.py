"""The deployment files under deploy/ carry what a population build across machines needs: Ray's token
authentication, the league's database URL from a secret, one shared folder for the league home and the
build's work, Ray's object store in memory, and an `arena-league population build --backend ray`
entrypoint the command line accepts. Nothing here starts Kubernetes or a cluster; the `ray up` file is
checked against the installed Ray's own cluster schema and its start commands are run in bash with
`ray` replaced by a shell function that records its arguments."""

from __future__ import annotations

import argparse
import copy
import re
import shlex
import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parent.parent
RAYJOB = ROOT / "deploy" / "kuberay-rayjob.yaml"
RAY_UP = ROOT / "deploy" / "ray-cluster.yaml"
_UNITS = {"": 1, "k": 10**3, "M": 10**6, "G": 10**9, "Ki": 2**10, "Mi": 2**20, "Gi": 2**30, "Ti": 2**40}


def _quantity(text: str | int) -> float:
    """A Kubernetes quantity ("8Gi", "500m", "4") as a number of bytes or cores."""
    match = re.fullmatch(r"(\d+(?:\.\d+)?)(m|k|M|G|Ki|Mi|Gi|Ti)?", str(text))
    assert match, f"{text!r} is not a Kubernetes quantity"
    number, unit = float(match[1]), match[2] or ""
    return number / 1000 if unit == "m" else number * _UNITS[unit]


def _manifests() -> list[dict]:
    return [d for d in yaml.safe_load_all(RAYJOB.read_text()) if d]


def _rayjob() -> dict:
    jobs = [d for d in _manifests() if d.get("kind") == "RayJob"]
    assert len(jobs) == 1, f"{RAYJOB.name} must hold one RayJob, found {len(jobs)}"
    return jobs[0]


def _ray_pods() -> list[tuple[str, dict, dict]]:
    """(group name, pod spec, rayStartParams) of the head and of every worker group."""
    cluster = _rayjob()["spec"]["rayClusterSpec"]
    head = cluster["headGroupSpec"]
    pods = [("head", head["template"]["spec"], head.get("rayStartParams") or {})]
    pods += [(g["groupName"], g["template"]["spec"], g.get("rayStartParams") or {})
             for g in cluster["workerGroupSpecs"]]
    return pods


def _ray_container(pod: dict) -> dict:
    # KubeRay runs Ray in the pod's first container
    return pod["containers"][0]


def _env(container: dict) -> dict[str, dict]:
    return {e["name"]: e for e in container.get("env", [])}


def _entrypoint() -> list[str]:
    return shlex.split(_rayjob()["spec"]["entrypoint"])


def _option(argv: list[str], name: str) -> str:
    assert name in argv, f"the entrypoint has no {name}: {shlex.join(argv)}"
    return argv[argv.index(name) + 1]


def _shared_mount() -> tuple[str, str]:
    """(claim name, mount path) of the ReadWriteMany claim every Ray pod mounts."""
    claims = {d["metadata"]["name"]: d for d in _manifests() if d.get("kind") == "PersistentVolumeClaim"}
    assert claims, f"{RAYJOB.name} declares no PersistentVolumeClaim for the shared folder"
    paths = set()
    for group, pod, _ in _ray_pods():
        volumes = {v["name"]: v for v in pod.get("volumes", [])}
        mounted = [(volumes[m["name"]]["persistentVolumeClaim"]["claimName"], m["mountPath"])
                   for m in _ray_container(pod).get("volumeMounts", [])
                   if "persistentVolumeClaim" in volumes.get(m["name"], {})]
        assert len(mounted) == 1, f"the {group} pod must mount the shared claim once, mounts {mounted}"
        paths.add(mounted[0])
    assert len(paths) == 1, f"head and workers must mount the same claim at the same path, found {sorted(paths)}"
    claim, path = paths.pop()
    assert claim in claims, f"the pods mount claim {claim!r}, which {RAYJOB.name} does not declare"
    assert claims[claim]["spec"]["accessModes"] == ["ReadWriteMany"], \
        f"claim {claim!r} must be ReadWriteMany: every node writes the league home and the work folder"
    return claim, path


def test_the_rayjob_is_a_kuberay_job_that_deletes_its_cluster_when_done():
    job = _rayjob()
    assert job["apiVersion"] == "ray.io/v1", f"KubeRay's API is ray.io/v1, not {job['apiVersion']}"
    spec = job["spec"]
    assert spec.get("shutdownAfterJobFinishes") is True, "without shutdownAfterJobFinishes the cluster stays up"
    ttl = spec.get("ttlSecondsAfterFinished")
    assert isinstance(ttl, int) and ttl >= 0, "ttlSecondsAfterFinished says when the finished cluster goes"
    assert spec["rayClusterSpec"]["headGroupSpec"]["template"]["spec"]["containers"], "no head container"
    assert spec["rayClusterSpec"]["workerGroupSpecs"], "no worker group: the build would run on the head alone"


def test_the_rayjob_turns_on_token_authentication_from_a_secret():
    cluster = _rayjob()["spec"]["rayClusterSpec"]
    auth = cluster.get("authOptions") or {}
    assert auth.get("mode") == "token", "rayClusterSpec.authOptions.mode must be token: Ray's ports are open otherwise"
    assert auth.get("secretName"), "authOptions.secretName names the Secret whose auth_token every pod shares"
    version = tuple(int(p) for p in cluster.get("rayVersion", "0").split(".")[:2])
    assert version >= (2, 52), f"KubeRay refuses token mode below Ray 2.52, rayVersion is {cluster.get('rayVersion')}"
    for group, pod, _ in _ray_pods():
        token = _env(_ray_container(pod)).get("RAY_AUTH_TOKEN")
        assert token is None or "value" not in token, f"the {group} pod writes Ray's token into the manifest"


def test_every_ray_pod_reads_the_database_url_from_a_secret_and_the_league_home_from_the_shared_folder():
    _, mount = _shared_mount()
    homes = set()
    for group, pod, _ in _ray_pods():
        env = _env(_ray_container(pod))
        db = env.get("ARENA_LEAGUE_DB")
        assert db is not None, f"the {group} pod has no ARENA_LEAGUE_DB: it would make its own SQLite league"
        assert "value" not in db, f"the {group} pod writes the database URL into the manifest; use a Secret"
        ref = db.get("valueFrom", {}).get("secretKeyRef", {})
        assert ref.get("name") and ref.get("key"), f"the {group} pod's ARENA_LEAGUE_DB must come from a secretKeyRef"
        home = env.get("ARENA_LEAGUE_HOME", {}).get("value", "")
        assert home.startswith(mount.rstrip("/") + "/"), \
            f"the {group} pod's ARENA_LEAGUE_HOME {home!r} is not on the shared volume at {mount}"
        homes.add(home)
    assert len(homes) == 1, f"head and workers must share one league home, found {sorted(homes)}"


def test_the_build_writes_its_work_folder_and_population_to_the_shared_folder():
    _, mount = _shared_mount()
    argv = _entrypoint()
    for option in ("--work-dir", "--out-dir"):
        path = _option(argv, option)
        assert path.startswith(mount.rstrip("/") + "/"), \
            f"{option} {path} is not on the shared volume at {mount}: the job's own folder on the head is temporary"


def test_every_ray_pod_has_its_object_store_in_memory_sized_for_it():
    for group, pod, start in _ray_pods():
        container = _ray_container(pod)
        volumes = {v["name"]: v for v in pod.get("volumes", [])}
        shm = [m for m in container.get("volumeMounts", []) if m["mountPath"] == "/dev/shm"]
        assert shm, f"the {group} pod mounts nothing at /dev/shm: Ray's object store would fall back to disk"
        empty_dir = volumes[shm[0]["name"]].get("emptyDir") or {}
        assert empty_dir.get("medium") == "Memory", f"the {group} pod's /dev/shm must be an emptyDir in Memory"
        assert "sizeLimit" in empty_dir, f"the {group} pod's /dev/shm has no sizeLimit"
        size = _quantity(empty_dir["sizeLimit"])
        store = start.get("object-store-memory")
        if store is not None:
            assert int(store) <= size, f"the {group} group's object store ({store} B) exceeds its /dev/shm ({size:.0f} B)"
        memory = _quantity(container["resources"]["limits"]["memory"])
        assert size < memory, f"the {group} pod's /dev/shm counts in its memory limit and must leave room below it"


def test_every_container_asks_for_cpu_and_memory():
    job = _rayjob()
    pods = [(group, pod) for group, pod, _ in _ray_pods()]
    if "submitterPodTemplate" in job["spec"]:
        pods.append(("submitter", job["spec"]["submitterPodTemplate"]["spec"]))
    for group, pod in pods:
        for container in pod["containers"]:
            resources = container.get("resources", {})
            for kind in ("requests", "limits"):
                for what in ("cpu", "memory"):
                    assert what in resources.get(kind, {}), f"the {group} pod's {container['name']} has no {kind}.{what}"


def test_every_ray_pod_runs_the_same_image():
    images = {_ray_container(pod)["image"] for _, pod, _ in _ray_pods()}
    assert len(images) == 1, f"head and workers must run one image (one arena-league version), found {sorted(images)}"


def test_the_entrypoint_is_a_population_build_on_ray_sized_to_the_workers():
    argv = _entrypoint()
    assert argv[:3] == ["arena-league", "population", "build"], f"the entrypoint is not a build: {shlex.join(argv)}"
    assert _option(argv, "--backend") == "ray", "the build must run with --backend ray"
    cpus = sum(_quantity(g["template"]["spec"]["containers"][0]["resources"]["limits"]["cpu"]) * g["replicas"]
               for g in _rayjob()["spec"]["rayClusterSpec"]["workerGroupSpecs"])
    processes = int(_option(argv, "--processes"))
    assert processes <= cpus, f"--processes {processes} asks for more than the workers' {cpus:.0f} CPUs"


def test_the_command_line_accepts_the_entrypoint():
    from arena_league.cli import build_parser

    build = _subparser(build_parser(), ("population", "build"))
    known = {s for action in build._actions for s in action.option_strings}
    argv = _entrypoint()[1:]
    unknown = [a for a in argv if a.startswith("--") and a not in known]
    assert not unknown, f"population build has no {', '.join(unknown)}"
    args = build_parser().parse_args(argv)
    assert (args.command, args.action, args.game) == ("population", "build", "Crossroads-2T2P-v1")
    assert args.processes == int(_option(_entrypoint(), "--processes"))
    assert args.backend == "ray"


def _subparser(parser: argparse.ArgumentParser, path: tuple[str, ...]) -> argparse.ArgumentParser:
    for name in path:
        choices = next(a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        parser = choices[name]
    return parser


def _ray_up() -> dict:
    return yaml.safe_load(RAY_UP.read_text())


def test_ray_up_accepts_the_cluster_file():
    util = pytest.importorskip("ray.autoscaler._private.util", reason="ray is not installed: pip install -e '.[ray]'")
    config = _ray_up()
    assert config["provider"]["type"] == "local", "the cluster file is for machines you have (provider local)"
    assert config["provider"].get("head_ip") and config["provider"].get("worker_ips"), "head_ip and worker_ips"
    prepared = util.prepare_config(copy.deepcopy(config))  # what `ray up` does before it validates
    util.validate_config(prepared)
    assert prepared["available_node_types"]["local.cluster.node"]["min_workers"] == len(config["provider"]["worker_ips"])


def test_ray_up_installs_one_pinned_arena_league_with_ray_and_cpu_torch():
    setup = " ; ".join(_ray_up()["setup_commands"])
    assert re.search(r"arena-league\[ray\](==\d| @ \S)", setup), \
        "setup_commands must pin arena-league[ray]==VERSION (or arena-league[ray] @ a wheel or tag)"
    assert re.search(r"ray\[default\]==\d", setup), \
        "setup_commands must pin ray[default]==VERSION: other Ray versions refuse to join, jobs need the dashboard"
    assert "download.pytorch.org/whl/cpu" in setup, "setup_commands must install the CPU build of torch"
    assert "python3.11" in setup, "setup_commands must make the environment with Python 3.11"


def _run_start_command(command: str, home: Path, head_ip: str | None) -> dict[str, str]:
    """Runs a start command as `ray up` does (bash, RAY_HEAD_IP exported for workers) with `ray` and `ip`
    replaced by shell functions; returns what `ray start` got: its arguments and the variables it inherits."""
    recorders = (
        'ray() { [ "$1" = start ] && printf "%s\\n" "ARGS=$*" "RAY_AUTH_MODE=$RAY_AUTH_MODE" '
        '"RAY_AUTH_TOKEN_PATH=$RAY_AUTH_TOKEN_PATH" "ARENA_LEAGUE_HOME=$ARENA_LEAGUE_HOME" '
        '"ARENA_LEAGUE_DB=$ARENA_LEAGUE_DB"; }\n'
        'ip() { echo "$4 via 192.0.2.1 dev eth0 src 198.51.100.7 uid 1000"; }\n'
    )
    prefix = f"export RAY_HEAD_IP={head_ip}; " if head_ip else ""
    result = subprocess.run(["bash", "-c", recorders + prefix + command], capture_output=True, text=True, timeout=30,
                            env={"HOME": str(home), "PATH": "/usr/bin:/bin"}, check=False)
    assert result.returncode == 0, f"{command!r} failed in bash: {result.stderr}"
    return dict(line.split("=", 1) for line in result.stdout.splitlines())


@pytest.mark.skipif(shutil.which("bash") is None, reason="the start commands are bash")
def test_ray_up_starts_every_node_on_its_address_with_the_same_token_and_league(tmp_path):
    config = _ray_up()
    head_ip = config["provider"]["head_ip"]
    url = "postgresql+psycopg://league@db.internal/league"
    mounts = {str(Path(remote.replace("~", str(tmp_path), 1))) for remote in config["file_mounts"]}
    for remote in mounts:  # the files `ray up` copies in: the token, and a URL to read back
        Path(remote).parent.mkdir(parents=True, exist_ok=True)
        Path(remote).write_text(url if "arena-league" in remote else "a token")
    head = _run_start_command(config["head_start_ray_commands"][-1], tmp_path, None)
    worker = _run_start_command(config["worker_start_ray_commands"][-1], tmp_path, head_ip)
    assert f"--node-ip-address={head_ip}" in head["ARGS"].split(), "the head must start on provider.head_ip"
    assert "--head" in head["ARGS"].split()
    assert f"--address={head_ip}:6379" in worker["ARGS"].split(), "workers must join the head's address"
    assert "--node-ip-address=198.51.100.7" in worker["ARGS"].split(), \
        "a worker must start on the address it reaches the head from"
    for node, got in (("head", head), ("worker", worker)):
        assert got["RAY_AUTH_MODE"] == "token", f"the {node} starts Ray without token authentication"
        assert got["RAY_AUTH_TOKEN_PATH"] in mounts, f"the {node}'s token file is not one `ray up` copies in"
        assert got["ARENA_LEAGUE_DB"] == url, f"the {node} does not read ARENA_LEAGUE_DB from its copied file"
    assert head["RAY_AUTH_TOKEN_PATH"] == worker["RAY_AUTH_TOKEN_PATH"], "head and workers must share one token"
    assert head["ARENA_LEAGUE_HOME"] == worker["ARENA_LEAGUE_HOME"], "head and workers must share one league home"
    shared = " ; ".join(config["initialization_commands"])
    mount_point = re.search(r"mount -t nfs \S+ (\S+)", shared)
    assert mount_point, "initialization_commands (run on every node) must mount the shared NFS folder"
    assert head["ARENA_LEAGUE_HOME"].startswith(mount_point[1].rstrip("/") + "/"), \
        f"ARENA_LEAGUE_HOME {head['ARENA_LEAGUE_HOME']} is not on the NFS mount {mount_point[1]}"


# a password in a URL, a password= or token= setting, Ray's token written out, or a Secret with its values
_LITERAL_SECRETS = [
    (r"://[^\s/@:]+:[^\s/@]+@", "a URL with a password"),
    (r"(?i)\bpassword\s*[=:]\s*\S", "a password"),
    (r"(?i)\b(?:RAY_AUTH_TOKEN|auth_token|token)\s*=\s*['\"]?[A-Za-z0-9]", "a token value"),
    (r"(?m)^kind:\s*Secret\b", "a Secret with its values"),
]


@pytest.mark.parametrize("path", [RAYJOB, RAY_UP], ids=lambda p: p.name)
def test_no_deployment_file_holds_a_secret(path):
    text = path.read_text()
    for pattern, what in _LITERAL_SECRETS:
        match = re.search(pattern, text)
        assert match is None, f"{path.name} holds {what}: {match[0]!r}; take it from a Secret or a copied file"
    if path == RAYJOB:
        for group, pod, _ in _ray_pods():
            for name, entry in _env(_ray_container(pod)).items():
                if re.search(r"TOKEN|PASSWORD|SECRET|_DB$", name):
                    assert "value" not in entry, f"the {group} pod writes {name} into the manifest"

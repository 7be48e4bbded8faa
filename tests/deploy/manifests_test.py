#!/usr/bin/python3
"""The deployment files (deploy/) checked against each other and the real binaries.

    manifests_test.py --server PATH [--worker PATH] [unittest options]

Every flag a manifest passes must be in that binary's --help; every probe and
Service port must be one the process listens on; grace periods must cover
--drain-grace; Redis must keep an append-only file on a persistent volume; the
images named in compose and k8s must be the ones the Dockerfiles build (their
org.opencontainers.image.ref.name label, tagged with the CMake project version).
The checks are functions that return a list of problems, so CheckerSelfTest can
break a real manifest and see them fire.
"""
import argparse
import copy
import json
import re
import subprocess
import sys
import unittest
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
DEPLOY = ROOT / "deploy"
K8S = DEPLOY / "k8s"
COMPOSE = DEPLOY / "docker-compose.yml"
BINARIES = {}  # "vpremesh-server" -> path, from the command line

# After --drain-grace, vpremesh-server waits up to 10 s for cancelled jobs to
# reach a stage boundary and 5 s for open streams (server/main.cpp).
SERVER_SHUTDOWN_AFTER_GRACE_S = 15
COMPOSE_DEFAULT_STOP_GRACE_S = 10


# ---------------------------------------------------------------- loading

def load_yaml(path):
    return [d for d in yaml.safe_load_all(path.read_text()) if d is not None]


def k8s_objects():
    return [(f, o) for f in sorted(K8S.glob("*.yaml")) if f.name != "kustomization.yaml" for o in load_yaml(f)]


def compose_file():
    return load_yaml(COMPOSE)[0]


def dockerfile(path):
    """LABELs, ENV, ENTRYPOINT, EXPOSE and RUN/COPY arguments of a Dockerfile (all stages together)."""
    text = re.sub(r"\\\n", " ", path.read_text())
    info = {"labels": {}, "env": {}, "entrypoint": None, "expose": [], "run": [], "copy": [], "path": path}
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        word, _, rest = line.partition(" ")
        word = word.upper()
        if word in ("LABEL", "ENV"):
            for key, value in re.findall(r'([\w.\-]+)=("[^"]*"|\S+)', rest):
                info["labels" if word == "LABEL" else "env"][key] = value.strip('"')
        elif word == "ENTRYPOINT":
            info["entrypoint"] = json.loads(rest)
        elif word == "EXPOSE":
            info["expose"] = [int(p.split("/")[0]) for p in rest.split()]
        elif word == "RUN":
            info["run"].append(rest)
        elif word == "COPY":
            info["copy"].append(rest.split())
    return info


def dockerfiles():
    return {p.name: dockerfile(p) for p in sorted((DEPLOY / "docker").glob("*.Dockerfile"))}


def project_version():
    return re.search(r"project\(vpremesh VERSION (\S+)", (ROOT / "CMakeLists.txt").read_text()).group(1)


def install_targets():
    """{target: destination} from every install(TARGETS ... RUNTIME DESTINATION d) in the tree."""
    found = {}
    for cml in ROOT.rglob("CMakeLists.txt"):
        if any(part.startswith((".", "build")) for part in cml.relative_to(ROOT).parts[:-1]):
            continue
        for targets, dest in re.findall(r"install\(TARGETS\s+([^)]*?)\s+RUNTIME\s+DESTINATION\s+(\S+?)\s*\)",
                                        cml.read_text()):
            for t in targets.split():
                found[t] = dest
    return found


_help_cache = {}


def binary_help(name):
    """{--flag: {"default": str|None, "choices": [..]|None}} parsed from `BINARY --help` (CLI11)."""
    if name not in _help_cache:
        out = subprocess.run([BINARIES[name], "--help"], capture_output=True, text=True, timeout=60)
        if out.returncode != 0:
            raise AssertionError(f"{name} --help exited {out.returncode}: {out.stderr}")
        flags = {}
        for m in re.finditer(r"^\s+(?:-\w,)?(--[A-Za-z0-9][\w-]*)(.*)$", out.stdout, re.M):
            spec = m.group(2).strip()
            default = re.match(r"[A-Z]+(?::[^=]*?)?=(\S+)", spec)
            choices = re.match(r"[A-Z]+:\{([^}]*)\}", spec)
            flags[m.group(1)] = {"default": default.group(1) if default else None,
                                 "choices": choices.group(1).split(",") if choices else None}
        _help_cache[name] = flags
    return _help_cache[name]


# ---------------------------------------------------------------- helpers

def parse_flags(tokens):
    """[(--flag, value or None)] from an argument list; `--a=b` and `--a b` both work."""
    flags, i = [], 0
    while i < len(tokens):
        tok = str(tokens[i])
        if tok.startswith("--"):
            name, eq, value = tok.partition("=")
            if not eq and i + 1 < len(tokens) and not str(tokens[i + 1]).startswith("--"):
                value, i = str(tokens[i + 1]), i + 1
            flags.append((name, value if (eq or value) else None))
        i += 1
    return flags


def flag_value(tokens, flag, help_flags=None):
    """The flag's value in tokens, else the binary's default from --help."""
    for name, value in parse_flags(tokens):
        if name == flag:
            return value
    return help_flags[flag]["default"] if help_flags and flag in help_flags else None


def port_of(address):
    return int(address.rsplit(":", 1)[1])


def seconds(duration):
    """Compose durations: 630s, 1m30s, 10m, or a number of seconds."""
    if isinstance(duration, (int, float)):
        return float(duration)
    units = {"h": 3600, "m": 60, "s": 1, "ms": 0.001}
    parts = re.findall(r"(\d+(?:\.\d+)?)(ms|h|m|s)", duration)
    if not parts or "".join(n + u for n, u in parts) != duration:
        raise ValueError(f"bad duration {duration!r}")
    return sum(float(n) * units[u] for n, u in parts)


def images_to_dockerfiles():
    return {d["labels"].get("org.opencontainers.image.ref.name"): d for d in dockerfiles().values()}


def binary_of(image, command=None):
    """The vpremesh binary a container runs: its command, else its image's ENTRYPOINT."""
    if command:
        return Path(str(command[0])).name
    d = images_to_dockerfiles().get(image)
    return Path(d["entrypoint"][0]).name if d and d["entrypoint"] else None


def pod_templates(objects):
    """(workload name, pod spec, pod labels) of every Deployment and StatefulSet."""
    for _, o in objects:
        if o.get("kind") in ("Deployment", "StatefulSet"):
            t = o["spec"]["template"]
            yield o["metadata"]["name"], t["spec"], t["metadata"].get("labels", {})


def workload(objects, name):
    for wname, spec, labels in pod_templates(objects):
        if wname == name:
            return spec
    raise AssertionError(f"no Deployment or StatefulSet named {name}")


def vpremesh_container(pod_spec, binary):
    for c in pod_spec["containers"]:
        if binary_of(c.get("image"), c.get("command")) == binary:
            return c
    raise AssertionError(f"no container runs {binary}")


# ---------------------------------------------------------------- checks (each returns problems)

def check_flags(binary, tokens):
    """Every --flag exists in the binary's --help and, where it lists choices, the value is one."""
    known, problems = binary_help(binary), []
    for name, value in parse_flags(tokens):
        if name not in known:
            problems.append(f"{binary} has no flag {name}")
        elif known[name]["choices"] and value not in known[name]["choices"]:
            problems.append(f"{binary} {name} {value}: not one of {known[name]['choices']}")
    return problems


def listened_ports(binary, tokens):
    """Ports the process binds: --listen (or its default), --metrics-listen and --health-listen."""
    help_flags, ports = binary_help(binary), set()
    for flag in ("--listen", "--metrics-listen", "--health-listen"):
        value = flag_value(tokens, flag, help_flags) if flag in help_flags else None
        if value:
            ports.add(port_of(value))
    return ports


def check_container_ports(container, binary):
    """Probes reach declared ports; declared ports are the ones the binary listens on."""
    problems = []
    declared = {p.get("name"): p["containerPort"] for p in container.get("ports", [])}
    numbers = set(declared.values())
    for probe_kind in ("livenessProbe", "readinessProbe", "startupProbe"):
        probe = container.get(probe_kind)
        if not probe:
            continue
        for handler in ("grpc", "httpGet", "tcpSocket"):
            if handler not in probe:
                continue
            port = probe[handler]["port"]
            if handler == "grpc" and not isinstance(port, int):
                problems.append(f"{probe_kind}: a grpc probe's port must be a number, not {port!r}")
            elif isinstance(port, str) and port not in declared:
                problems.append(f"{probe_kind}: no container port named {port}")
            elif isinstance(port, int) and port not in numbers:
                problems.append(f"{probe_kind}: port {port} is not a container port")
    if binary:
        listened = listened_ports(binary, container.get("args", []))
        if numbers != listened:
            problems.append(f"container ports {sorted(numbers)} != ports {binary} listens on {sorted(listened)}")
    return problems


def check_service(service, objects):
    """The selector matches a pod template, and every targetPort is a port of its containers."""
    selector, problems = service["spec"].get("selector", {}), []
    pods = [spec for _, spec, labels in pod_templates(objects) if selector.items() <= labels.items()]
    if not pods:
        return [f"Service {service['metadata']['name']}: selector {selector} matches no pod template"]
    for port in service["spec"]["ports"]:
        target = port.get("targetPort", port["port"])
        for spec in pods:
            declared = [(p.get("name"), p["containerPort"]) for c in spec["containers"] for p in c.get("ports", [])]
            if not any(target in (name, number) for name, number in declared):
                problems.append(f"Service {service['metadata']['name']}: targetPort {target} is no container port")
    return problems


def check_scrape_annotations(annotations, binary, tokens):
    """prometheus.io/port, where given, is the --metrics-listen port."""
    port = annotations.get("prometheus.io/port")
    metrics = flag_value(tokens, "--metrics-listen")
    if port is not None and (not metrics or int(port) != port_of(metrics)):
        return [f"{binary}: prometheus.io/port {port} but --metrics-listen {metrics}"]
    return []


def prestop_sleep(container):
    command = container.get("lifecycle", {}).get("preStop", {}).get("exec", {}).get("command", [])
    return float(command[1]) if len(command) == 2 and command[0] == "sleep" else 0.0


def check_grace(grace_s, binary, tokens, extra_s=0.0):
    """The platform's grace period outlasts --drain-grace (plus what the process does after it)."""
    drain = float(flag_value(tokens, "--drain-grace", binary_help(binary)))
    if not grace_s > drain + extra_s:
        return [f"{binary}: grace period {grace_s:g} s does not cover --drain-grace {drain:g} s + {extra_s:g} s"]
    return []


def check_redis_args(tokens):
    """AOF on, fsynced at least every second."""
    opts = dict(parse_flags(tokens))
    problems = []
    if opts.get("--appendonly") != "yes":
        problems.append("redis runs without --appendonly yes")
    if opts.get("--appendfsync", "everysec") not in ("everysec", "always"):
        problems.append(f"redis --appendfsync {opts['--appendfsync']}: jobs could be lost beyond 1 s")
    if opts.get("--maxmemory-policy", "noeviction") != "noeviction":
        problems.append("redis may evict keys: queued jobs and uploads would vanish")
    return problems


def memory_bytes(text):
    """Redis (6gb, 512mb) and Kubernetes (8Gi, 512Mi) sizes, both read as powers of 1024."""
    m = re.fullmatch(r"(\d+)\s*([kmgt])?(i|b)?", str(text).lower())
    return int(m.group(1)) * 1024 ** " kmgt".index(m.group(2) or " ")


def check_redis_memory(container):
    """Under a memory limit, --maxmemory must be set below it, or noeviction never applies."""
    limit = container.get("resources", {}).get("limits", {}).get("memory")
    maxmemory = flag_value(container["args"], "--maxmemory")
    if limit and not maxmemory:
        return [f"redis has a {limit} memory limit but no --maxmemory: the OOM killer comes first"]
    if limit and memory_bytes(maxmemory) >= memory_bytes(limit):
        return [f"redis --maxmemory {maxmemory} is not below its memory limit {limit}"]
    return []


def check_queue_url(url, services):
    """redis://[USER]:PASSWORD@HOST:PORT[/DB] naming a Service (k8s) or service (compose) and its port.
    The password is required: Redis holds every tenant's uploads and results."""
    m = re.fullmatch(r"redis://(?:([\w.\-]*):([^@]+)@)?([\w.\-]+):(\d+)(?:/\d+)?", url or "")
    if not m:
        return [f"--queue {url!r} is not redis://[USER]:PASSWORD@HOST:PORT[/DB]"]
    if not m.group(2):
        return [f"--queue {url!r} has no password: Redis must not be open to anyone on the network"]
    host, port = m.group(3), int(m.group(4))
    if host not in services:
        return [f"--queue host {host} is not a service here ({sorted(services)})"]
    if port not in services[host]:
        return [f"--queue port {port} is not a port of {host} ({sorted(services[host])})"]
    return []


def check_server_security(tokens, mounted_dirs):
    """A server listening beyond loopback has tenants' tokens and TLS, from files that are mounted."""
    opts = dict(parse_flags(tokens))
    problems = []
    if "--insecure" in opts:
        problems.append("vpremesh-server runs with --insecure: anyone who reaches it may run jobs")
    for flag in ("--auth-tokens", "--tls-cert", "--tls-key"):
        path = opts.get(flag)
        if not path:
            problems.append(f"vpremesh-server has no {flag}")
        elif not any(path.startswith(d.rstrip("/") + "/") for d in mounted_dirs):
            problems.append(f"vpremesh-server {flag} {path} is in no mounted volume ({sorted(mounted_dirs)})")
    return problems


def check_redis_password(tokens):
    """Redis asks for a password (--requirepass, or ACL users from --aclfile)."""
    opts = dict(parse_flags(tokens))
    if not opts.get("--requirepass") and not opts.get("--aclfile"):
        return ["redis runs without --requirepass or --aclfile: anyone on the network reads every job"]
    return []


def k8s_services(objects):
    return {o["metadata"]["name"]: {p["port"] for p in o["spec"]["ports"]} for _, o in objects if o["kind"] == "Service"}


# ---------------------------------------------------------------- tests

class FilesTest(unittest.TestCase):
    def test_every_yaml_file_parses(self):
        files = sorted(DEPLOY.rglob("*.yaml")) + sorted(DEPLOY.rglob("*.yml"))
        self.assertGreaterEqual(len(files), 7)
        for f in files:
            with self.subTest(file=str(f.relative_to(ROOT))):
                self.assertTrue(load_yaml(f), "no documents")

    def test_k8s_objects_are_named_and_namespace_agnostic(self):
        objects = k8s_objects()
        kinds = sorted(o["kind"] for _, o in objects)
        for kind in ("Deployment", "StatefulSet", "Service", "ScaledObject", "PodDisruptionBudget"):
            self.assertIn(kind, kinds)
        for f, o in objects:
            with self.subTest(file=f.name, kind=o.get("kind")):
                self.assertTrue(o.get("apiVersion") and o.get("kind") and o.get("metadata", {}).get("name"))
                self.assertNotIn("namespace", o["metadata"], "kustomize/-n sets the namespace")

    def test_kustomization_lists_every_manifest(self):
        listed = set(load_yaml(K8S / "kustomization.yaml")[0]["resources"])
        present = {f.name for f in K8S.glob("*.yaml")} - {"kustomization.yaml"}
        self.assertEqual(listed, present)


class ImagesTest(unittest.TestCase):
    def test_dockerfiles_label_their_image_with_the_project_version(self):
        version = project_version()
        refs = images_to_dockerfiles()
        self.assertEqual(len(refs), 2, refs.keys())
        for ref, d in refs.items():
            with self.subTest(dockerfile=d["path"].name):
                self.assertRegex(ref or "", r"^[\w.\-/]+/vpremesh-(server|worker):" + re.escape(version) + "$")
                self.assertEqual(d["labels"].get("org.opencontainers.image.version"), version)
                self.assertEqual(Path(d["entrypoint"][0]).name, ref.rsplit("/", 1)[1].split(":")[0])

    def test_entrypoints_are_installed_and_copied(self):
        targets = install_targets()
        for name, d in dockerfiles().items():
            with self.subTest(dockerfile=name):
                entry = d["entrypoint"][0]
                binary = Path(entry).name
                self.assertIn(binary, targets, "not an install(TARGETS ...) of the CMake tree")
                prefix = re.search(r"cmake --install \S+ --prefix (\S+)", " ".join(d["run"])).group(1)
                self.assertEqual(entry, f"{prefix}/{targets[binary]}/{binary}")
                self.assertTrue(any(c[0] == "--from=build" and entry in c[1:-1] and
                                    c[-1].rstrip("/") == str(Path(entry).parent) for c in d["copy"]),
                                f"the runtime stage does not COPY {entry} from the build stage")

    def test_k8s_and_compose_use_the_built_images(self):
        refs = images_to_dockerfiles()
        k8s = {c["image"] for _, spec, _ in pod_templates(k8s_objects()) for c in spec["containers"]}
        services = compose_file()["services"]
        compose = {s["image"] for s in services.values()}
        for used in (k8s, compose):
            ours = {i for i in used if "vpremesh" in i}
            self.assertEqual(ours, set(refs), "every vpremesh image is a Dockerfile's, and each is used")
        for name, s in services.items():
            if "build" in s:
                with self.subTest(service=name):
                    self.assertEqual(refs[s["image"]]["path"], (COMPOSE.parent / s["build"]["context"] /
                                                                s["build"]["dockerfile"]).resolve())

    def test_worker_image_asks_for_the_graphics_driver(self):
        env = images_to_dockerfiles()[next(r for r in images_to_dockerfiles() if "worker" in r)]["env"]
        self.assertTrue({"compute", "graphics"} <= set(env.get("NVIDIA_DRIVER_CAPABILITIES", "").split(",")))


class K8sTest(unittest.TestCase):
    def setUp(self):
        self.objects = k8s_objects()

    def _container(self, deployment, binary):
        if binary not in BINARIES:
            self.skipTest(f"no {binary} binary given")
        spec = workload(self.objects, deployment)
        return spec, vpremesh_container(spec, binary)

    def test_server_flags_ports_and_grace(self):
        spec, c = self._container("vpremesh-server", "vpremesh-server")
        args = c.get("args", [])
        self.assertEqual(check_flags("vpremesh-server", args), [])
        self.assertEqual(check_container_ports(c, "vpremesh-server"), [])
        grpc_ports = {c[p]["grpc"]["port"] for p in ("livenessProbe", "readinessProbe") if "grpc" in c.get(p, {})}
        # Probes speak no TLS: with --tls-cert they ask the plaintext --health-listen port.
        probed = "--health-listen" if flag_value(args, "--tls-cert") else "--listen"
        self.assertEqual(grpc_ports, {port_of(flag_value(args, probed, binary_help("vpremesh-server")))})
        secret_volumes = {v["name"] for v in spec.get("volumes", []) if "secret" in v}
        mounted = {m["mountPath"] for m in c.get("volumeMounts", []) if m["name"] in secret_volumes}
        self.assertEqual(check_server_security(args, mounted), [])
        self.assertEqual(check_grace(spec["terminationGracePeriodSeconds"], "vpremesh-server", args,
                                     prestop_sleep(c) + SERVER_SHUTDOWN_AFTER_GRACE_S), [])
        self.assertEqual(check_queue_url(flag_value(args, "--queue"), k8s_services(self.objects)), [])

    def test_worker_flags_ports_grace_and_gpu(self):
        spec, c = self._container("vpremesh-worker", "vpremesh-worker")
        args = c.get("args", [])
        self.assertEqual(check_flags("vpremesh-worker", args), [])
        self.assertEqual(check_container_ports(c, "vpremesh-worker"), [])
        self.assertEqual(c["livenessProbe"]["httpGet"]["path"], "/metrics")
        self.assertEqual(check_grace(spec["terminationGracePeriodSeconds"], "vpremesh-worker", args), [])
        self.assertEqual(check_queue_url(flag_value(args, "--queue"), k8s_services(self.objects)), [])
        self.assertGreaterEqual(int(c["resources"]["limits"]["nvidia.com/gpu"]), 1)

    def test_images_expose_the_container_ports(self):
        refs = images_to_dockerfiles()
        for _, spec, _ in pod_templates(self.objects):
            for c in spec["containers"]:
                if c["image"] in refs:
                    with self.subTest(container=c["name"]):
                        ports = {p["containerPort"] for p in c.get("ports", [])}
                        self.assertLessEqual(ports, set(refs[c["image"]]["expose"]))

    def test_scrape_annotations_name_the_metrics_port(self):
        for _, o in self.objects:
            if o["kind"] == "Deployment":
                with self.subTest(deployment=o["metadata"]["name"]):
                    t = o["spec"]["template"]
                    (c,) = t["spec"]["containers"]
                    self.assertEqual(check_scrape_annotations(t["metadata"].get("annotations", {}),
                                                              binary_of(c["image"]), c.get("args", [])), [])

    def test_services_reach_container_ports(self):
        for _, o in self.objects:
            if o["kind"] == "Service":
                with self.subTest(service=o["metadata"]["name"]):
                    self.assertEqual(check_service(o, self.objects), [])

    def test_redis_keeps_an_aof_on_a_persistent_volume(self):
        (sts,) = [o for _, o in self.objects if o["kind"] == "StatefulSet"]
        (c,) = sts["spec"]["template"]["spec"]["containers"]
        self.assertEqual(check_redis_args(c["args"]), [])
        self.assertEqual(check_redis_password(c["args"]), [])
        self.assertEqual(check_container_ports(c, None), [])
        self.assertEqual(check_redis_memory(c), [])
        data_dir = flag_value(c["args"], "--dir") or "/data"
        claims = {t["metadata"]["name"] for t in sts["spec"]["volumeClaimTemplates"]}
        self.assertTrue(any(m["mountPath"] == data_dir and m["name"] in claims for m in c["volumeMounts"]))

    def test_scaler_targets_the_worker_on_a_real_metric(self):
        (so,) = [o for _, o in self.objects if o["kind"] == "ScaledObject"]
        workload(self.objects, so["spec"]["scaleTargetRef"]["name"])
        (trigger,) = so["spec"]["triggers"]
        query = trigger["metadata"]["query"]
        metric = re.search(r"(vpremesh_\w+)\{", query).group(1)
        # Every pod reports the shared queue: a bare sum counts it once per pod.
        self.assertRegex(query, r"max(\s+by\s*\([^)]*\))?\s*\(\s*" + metric)
        sources = "".join(p.read_text() for p in (ROOT / "server").glob("*.h"))
        self.assertIn(f'"{metric}"', sources, "the query's metric is not exported by the server")
        (deployment,) = [o for _, o in self.objects if o["kind"] == "Deployment" and
                         o["metadata"]["name"] == so["spec"]["scaleTargetRef"]["name"]]
        self.assertNotIn("replicas", deployment["spec"], "KEDA owns the worker's replica count")
        if "vpremesh-worker" in BINARIES:
            vpremesh_container(deployment["spec"]["template"]["spec"], "vpremesh-worker")


class ComposeTest(unittest.TestCase):
    def setUp(self):
        self.services = compose_file()["services"]
        self.by_binary = {binary_of(s["image"]): s for s in self.services.values()}
        # Compose services answer on their containers' ports under their own names.
        self.reachable = {name: {6379} if s["image"].startswith("redis") else set() for name, s in self.services.items()}

    def _service(self, binary):
        if binary not in BINARIES:
            self.skipTest(f"no {binary} binary given")
        return self.by_binary[binary]

    def test_server(self):
        s = self._service("vpremesh-server")
        args = s["command"]
        self.assertEqual(check_flags("vpremesh-server", args), [])
        published = {int(str(p).rsplit(":", 1)[1]) for p in s["ports"]}
        self.assertEqual(published, listened_ports("vpremesh-server", args))
        self.assertEqual(check_grace(seconds(s.get("stop_grace_period", COMPOSE_DEFAULT_STOP_GRACE_S)),
                                     "vpremesh-server", args, SERVER_SHUTDOWN_AFTER_GRACE_S), [])
        self.assertEqual(check_queue_url(flag_value(args, "--queue"), self.reachable), [])
        self.assertEqual(s["depends_on"]["redis"]["condition"], "service_healthy")
        mounted = {v.split(":")[1] for v in s.get("volumes", [])}
        self.assertEqual(check_server_security(args, mounted), [])

    def test_worker(self):
        s = self._service("vpremesh-worker")
        args = s["command"]
        self.assertEqual(check_flags("vpremesh-worker", args), [])
        self.assertEqual(check_grace(seconds(s.get("stop_grace_period", COMPOSE_DEFAULT_STOP_GRACE_S)),
                                     "vpremesh-worker", args), [])
        self.assertEqual(check_queue_url(flag_value(args, "--queue"), self.reachable), [])
        healthcheck = " ".join(s["healthcheck"]["test"])
        self.assertIn(f"/dev/tcp/127.0.0.1/{port_of(flag_value(args, '--metrics-listen'))}", healthcheck)
        (device,) = s["deploy"]["resources"]["reservations"]["devices"]
        self.assertEqual(device["driver"], "nvidia")
        self.assertTrue({"gpu", "graphics"} <= set(device["capabilities"]))

    def test_redis(self):
        (redis,) = [s for s in self.services.values() if s["image"].startswith("redis:")]
        self.assertEqual(redis["command"][0], "redis-server")
        self.assertEqual(check_redis_args(redis["command"][1:]), [])
        self.assertEqual(check_redis_password(redis["command"][1:]), [])
        volume = next(v.split(":")[0] for v in redis["volumes"] if v.endswith(":/data"))
        self.assertIn(volume, compose_file()["volumes"], "/data must be a named volume")
        self.assertIn("redis-cli ping", " ".join(redis["healthcheck"]["test"]))


class CheckerSelfTest(unittest.TestCase):
    """A real manifest, broken on purpose, must be reported."""

    def setUp(self):
        if "vpremesh-server" not in BINARIES:
            self.skipTest("no vpremesh-server binary given")
        self.objects = copy.deepcopy(k8s_objects())
        self.server = vpremesh_container(workload(self.objects, "vpremesh-server"), "vpremesh-server")

    def test_unknown_flag_and_bad_choice(self):
        self.assertIn("vpremesh-server has no flag --no-such-flag",
                      check_flags("vpremesh-server", self.server["args"] + ["--no-such-flag", "1"]))
        self.assertTrue(check_flags("vpremesh-server", ["--device=tpu"]))
        self.assertEqual(check_flags("vpremesh-server", ["--device=cpu", "--listen", "0.0.0.0:1"]), [])

    def test_probe_and_listen_mismatch(self):
        self.server["readinessProbe"]["grpc"]["port"] = 50053
        self.assertTrue(any("50053" in p for p in check_container_ports(self.server, "vpremesh-server")))
        self.server["readinessProbe"]["grpc"]["port"] = "grpc"
        self.assertTrue(check_container_ports(self.server, "vpremesh-server"))
        self.server["readinessProbe"]["grpc"]["port"] = 50052
        self.server["args"] = [a.replace("0.0.0.0:9090", "0.0.0.0:9191") for a in self.server["args"]]
        self.assertTrue(check_container_ports(self.server, "vpremesh-server"))

    def test_service_target_port(self):
        (svc,) = [o for _, o in self.objects if o["kind"] == "Service" and o["metadata"]["name"] == "vpremesh-server"]
        svc["spec"]["ports"][0]["targetPort"] = "grcp"
        self.assertTrue(check_service(svc, self.objects))
        svc["spec"]["selector"] = {"app.kubernetes.io/name": "nothing"}
        self.assertTrue(check_service(svc, self.objects))

    def test_grace_redis_and_queue(self):
        self.assertTrue(check_grace(30, "vpremesh-server", ["--drain-grace", "30"]))
        self.assertTrue(check_grace(30, "vpremesh-server", []))  # --drain-grace defaults to 30
        self.assertEqual(check_grace(46, "vpremesh-server", [], SERVER_SHUTDOWN_AFTER_GRACE_S), [])
        self.assertTrue(check_grace(45, "vpremesh-server", [], SERVER_SHUTDOWN_AFTER_GRACE_S))
        self.assertTrue(check_scrape_annotations({"prometheus.io/port": "9091"}, "vpremesh-server",
                                                 ["--metrics-listen", "0.0.0.0:9090"]))
        redis = {"args": ["--maxmemory", "8gb"], "resources": {"limits": {"memory": "8Gi"}}}
        self.assertTrue(check_redis_memory(redis))
        redis["args"] = ["--maxmemory", "7gb"]
        self.assertEqual(check_redis_memory(redis), [])
        self.assertTrue(check_redis_memory({"args": [], "resources": {"limits": {"memory": "8Gi"}}}))
        self.assertTrue(check_redis_args(["--appendonly", "no"]))
        self.assertTrue(check_redis_args(["--appendonly", "yes", "--appendfsync", "no"]))
        self.assertTrue(check_redis_args(["--appendonly", "yes", "--maxmemory-policy", "allkeys-lru"]))
        services = k8s_services(self.objects)
        self.assertTrue(check_queue_url("redis://redis:6379", services))
        self.assertTrue(check_queue_url("redis://:pw@vpremesh-redis:6380", services))
        self.assertTrue(check_queue_url("redis://vpremesh-redis:6379", services))  # no password
        self.assertEqual(check_queue_url("redis://:secret@vpremesh-redis:6379/2", services), [])
        self.assertEqual(check_queue_url("redis://vpremesh:secret@vpremesh-redis:6379", services), [])
        self.assertTrue(check_redis_password(["--appendonly", "yes"]))
        self.assertEqual(check_redis_password(["--requirepass", "$(REDIS_PASSWORD)"]), [])

    def test_server_security(self):
        args = self.server["args"]
        self.assertEqual(check_server_security(args, {"/etc/vpremesh/tokens", "/etc/vpremesh/tls"}), [])
        self.assertTrue(check_server_security(args, {"/etc/vpremesh/tokens"}))  # TLS files not mounted
        self.assertTrue(check_server_security(args + ["--insecure"], {"/etc/vpremesh/tokens", "/etc/vpremesh/tls"}))
        without_tokens = [a for a in args if a not in ("--auth-tokens", "/etc/vpremesh/tokens/tokens")]
        self.assertTrue(any("--auth-tokens" in p for p in check_server_security(without_tokens, {"/etc/vpremesh"})))

    def test_parsers(self):
        self.assertEqual(parse_flags(["--a=1", "--b", "2", "--c", "--d", "x"]),
                         [("--a", "1"), ("--b", "2"), ("--c", None), ("--d", "x")])
        self.assertEqual(seconds("1m30s"), 90)
        self.assertEqual(seconds("630s"), 630)
        help_flags = binary_help("vpremesh-server")
        self.assertEqual(help_flags["--device"]["choices"], ["auto", "cpu", "cuda"])
        self.assertEqual(help_flags["--listen"]["default"], "0.0.0.0:50051")
        self.assertIsNone(help_flags["--metrics-listen"]["default"])


def main():
    parser = argparse.ArgumentParser(add_help=False)
    parser.add_argument("--server")
    parser.add_argument("--worker")
    args, rest = parser.parse_known_args()
    for name, path in (("vpremesh-server", args.server), ("vpremesh-worker", args.worker)):
        if path:
            BINARIES[name] = path
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()

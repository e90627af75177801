"""Checks the Kubernetes manifests of deploy/k8s (docs/scaling.md) without a cluster.

Every file parses as YAML; the kustomization lists every manifest; the planner Deployment has
3 replicas, gRPC health probes on its container port, resources, and a non-root, read-only
security context; the headless Service (clusterIP: None) selects the Deployment's pod labels
and targets its port; the ConfigMap's server configuration is accepted by planner_server's own
strict reader (--check-config), selects the redis backend, names the Redis Service and its port,
and listens on the container port; the Redis Deployment and Service agree on labels and ports.
"""
import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import yaml


def load(directory):
    docs = {}
    for path in sorted(directory.glob("*.yaml")):
        for doc in yaml.safe_load_all(path.read_text()):
            if doc is None:
                continue
            key = (doc.get("kind"), doc.get("metadata", {}).get("name"))
            if key in docs:
                raise SystemExit(f"{path.name}: duplicate {key}")
            docs[key] = (path.name, doc)
    return docs


def selects(selector, labels):
    return bool(selector) and all(labels.get(k) == v for k, v in selector.items())


def port_of(container, name_or_number):
    for p in container.get("ports", []):
        if name_or_number in (p.get("name"), p.get("containerPort")):
            return p["containerPort"]
    return None


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--server", required=True, help="planner_server binary")
    args = parser.parse_args()
    k8s = Path(args.source_dir) / "deploy/k8s"
    docs = load(k8s)
    errors = []

    def need(cond, what):
        if not cond:
            errors.append(what)
        return cond

    kustomization = yaml.safe_load((k8s / "kustomization.yaml").read_text())
    manifests = {p.name for p in k8s.glob("*.yaml")} - {"kustomization.yaml"}
    need(set(kustomization.get("resources", [])) == manifests,
         f"kustomization resources {kustomization.get('resources')} != files {sorted(manifests)}")
    namespaces = {d.get("metadata", {}).get("namespace") for k, (_, d) in docs.items()
                  if k[0] not in ("Namespace", "Kustomization")}
    need(namespaces == {"wheeljump"}, f"every object in namespace wheeljump (got {namespaces})")

    _, dep = docs.get(("Deployment", "planner-server"), (None, None))
    _, svc = docs.get(("Service", "planner-headless"), (None, None))
    _, cm = docs.get(("ConfigMap", "planner-server-config"), (None, None))
    _, rdep = docs.get(("Deployment", "redis"), (None, None))
    _, rsvc = docs.get(("Service", "redis"), (None, None))
    for name, d in [("Deployment planner-server", dep), ("Service planner-headless", svc),
                    ("ConfigMap planner-server-config", cm), ("Deployment redis", rdep),
                    ("Service redis", rsvc)]:
        need(d is not None, f"missing {name}")
    if errors:
        print("\n".join(errors))
        return 1

    spec = dep["spec"]
    pod = spec["template"]
    labels = pod["metadata"]["labels"]
    need(spec.get("replicas") == 3, "planner-server replicas must be 3")
    need(selects(spec["selector"]["matchLabels"], labels), "Deployment selector vs pod labels")
    (container,) = pod["spec"]["containers"]
    grpc_port = port_of(container, "grpc")
    need(grpc_port is not None, "planner-server container port 'grpc'")
    for probe in ("readinessProbe", "livenessProbe"):
        p = container.get(probe, {})
        need(p.get("grpc", {}).get("port") == grpc_port,
             f"{probe} must be a gRPC health probe on port {grpc_port}")
    res = container.get("resources", {})
    for kind in ("requests", "limits"):
        need({"cpu", "memory"} <= set(res.get(kind, {})), f"resources.{kind} cpu and memory")
    psc, csc = pod["spec"].get("securityContext", {}), container.get("securityContext", {})
    need(psc.get("runAsNonRoot") is True and psc.get("runAsUser", 0) != 0, "pod runs as non-root")
    need(csc.get("readOnlyRootFilesystem") is True, "read-only root filesystem")
    need(csc.get("allowPrivilegeEscalation") is False, "no privilege escalation")
    need("ALL" in csc.get("capabilities", {}).get("drop", []), "capabilities dropped")

    # The config the container reads is the ConfigMap's, mounted where --config points.
    cfg_arg = container["args"][container["args"].index("--config") + 1]
    mount = next((m for m in container.get("volumeMounts", [])
                  if cfg_arg.startswith(m["mountPath"].rstrip("/") + "/")), None)
    need(mount is not None and mount.get("readOnly") is True, f"{cfg_arg} on a read-only mount")
    if mount:
        vol = next(v for v in pod["spec"]["volumes"] if v["name"] == mount["name"])
        need(vol.get("configMap", {}).get("name") == cm["metadata"]["name"],
             "the config volume is the ConfigMap")
        need(Path(cfg_arg).name in cm["data"], f"ConfigMap key {Path(cfg_arg).name}")

    need(svc["spec"].get("clusterIP") == "None", "planner-headless must be headless (clusterIP: None)")
    need(selects(svc["spec"]["selector"], labels), "headless Service selects the Deployment's pods")
    (sport,) = svc["spec"]["ports"]
    need(port_of(container, sport.get("targetPort", sport["port"])) == grpc_port,
         "Service targetPort is the container's gRPC port")
    need(sport["port"] == grpc_port, "Service port is the gRPC port (robots use host:50051)")

    # The server's own strict reader accepts the configuration.
    text = cm["data"][Path(cfg_arg).name]
    with tempfile.TemporaryDirectory() as tmp:
        # Every key of the ConfigMap, as the pod sees the mount (the planner settings file the
        # config names is beside it).
        for name, content in cm["data"].items():
            (Path(tmp) / name).write_text(content)
        path = Path(tmp) / Path(cfg_arg).name
        run = subprocess.run([args.server, "--check-config", str(path)],
                             capture_output=True, text=True, timeout=60)
        need(run.returncode == 0, f"planner_server refuses the ConfigMap's config: {run.stderr}")
    config = yaml.safe_load(text)
    # The planner settings are the shipped ones (config/planner_settings.yaml), not a copy that
    # drifted.
    settings = config["planner"]["settings_file"]
    need(settings == "planner_settings.yaml" and settings in cm["data"],
         f"planner.settings_file {settings!r} is the ConfigMap's planner_settings.yaml")
    shipped = yaml.safe_load((Path(args.source_dir) / "config/planner_settings.yaml").read_text())
    need(yaml.safe_load(cm["data"].get("planner_settings.yaml", "")) == shipped,
         "the ConfigMap's planner_settings.yaml equals config/planner_settings.yaml")
    # So is the verifier's executor (config/jump_executor.yaml, the robot client's gains).
    executor = config["verification"].get("jump_executor_file")
    need(executor == "jump_executor.yaml" and executor in cm["data"],
         f"verification.jump_executor_file {executor!r} is the ConfigMap's jump_executor.yaml")
    shipped = yaml.safe_load((Path(args.source_dir) / "config/jump_executor.yaml").read_text())
    need(yaml.safe_load(cm["data"].get("jump_executor.yaml", "")) == shipped,
         "the ConfigMap's jump_executor.yaml equals config/jump_executor.yaml")
    need(config["listen"].rsplit(":", 1)[1] == str(grpc_port), "config listen port = gRPC port")
    need(config["listen"].startswith("0.0.0.0:"), "config listens on the pod address")
    cache = config["cache"]
    need(cache.get("backend") == "redis", "config selects cache.backend redis")
    rspec = rdep["spec"]["template"]
    (rcontainer,) = rspec["spec"]["containers"]
    rlabels = rspec["metadata"]["labels"]
    need(selects(rsvc["spec"]["selector"], rlabels), "redis Service selects the redis pods")
    need(selects(rdep["spec"]["selector"]["matchLabels"], rlabels), "redis selector vs labels")
    (rport,) = rsvc["spec"]["ports"]
    need(port_of(rcontainer, rport.get("targetPort", rport["port"])) is not None,
         "redis Service targetPort is a redis container port")
    redis = cache.get("redis", {})
    need(redis.get("host", "").split(".")[0] == rsvc["metadata"]["name"],
         f"cache.redis.host {redis.get('host')} is the redis Service")
    need(redis.get("port") == rport["port"], "cache.redis.port is the redis Service port")
    rsc = rspec["spec"].get("securityContext", {})
    need(rsc.get("runAsNonRoot") is True, "redis runs as non-root")

    for e in errors:
        print("deploy/k8s:", e)
    if not errors:
        print(f"deploy/k8s: ok ({len(docs)} objects)")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())

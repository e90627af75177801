"""Structural lint of deploy/container/Containerfile (no container engine runs on this machine,
so the image is not built here; docs/scaling.md).

Checks what a build would trip over first, and the properties the image promises: every COPY
source from the build context exists; the stages are Debian 12 ("bookworm"); the last stage
runs planner_server as a non-root user; COPY --from names an earlier stage; the build stage
installs the dependencies with deploy/install-deps.sh and builds the release preset; every
runtime package is a Debian 12 package name this machine's dpkg or apt knows (when apt lists
are present); every file the image's configuration names beside itself (the planner settings,
the verifier's files) is copied beside it.
"""
import argparse
import posixpath
import shlex
import subprocess
import sys
from pathlib import Path


def instructions(text):
    """(keyword, argument) per instruction, continuation lines joined, comments dropped."""
    out, current = [], ""
    for raw in text.splitlines():
        line = raw.strip()
        if not current and (not line or line.startswith("#")):
            continue
        if line.endswith("\\"):
            current += line[:-1] + " "
            continue
        current += line
        keyword, _, arg = current.partition(" ")
        out.append((keyword.upper(), arg.strip()))
        current = ""
    if current:
        raise SystemExit("unterminated continuation at the end")
    return out


def missing_config_files(root, copies):
    """The image's configuration (the copy of config/planner_server.yaml) names its planner
    settings and the verifier's files relative to itself: each must be copied beside it."""
    import yaml
    installed = {}  # path in the image -> source
    for sources, dest in copies:
        for s in sources:
            target = dest + posixpath.basename(s) if dest.endswith("/") else dest
            installed[target] = s
    configs = [t for t, s in installed.items() if s.endswith("config/planner_server.yaml")]
    if not configs:
        return ["the runtime stage does not copy config/planner_server.yaml"]
    config = yaml.safe_load((root / "config/planner_server.yaml").read_text())
    named = [config["planner"].get("settings_file", ""),
             config["verification"].get("sim_settings_file", ""),
             config["verification"].get("jump_executor_file", "")]
    errors = []
    for name in (n for n in named if n and not posixpath.isabs(n)):
        beside = posixpath.join(posixpath.dirname(configs[0]), name)
        if beside not in installed:
            errors.append(f"{configs[0]} names {name}, which is not copied to {beside}")
    return errors


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--source-dir", required=True)
    args = parser.parse_args()
    root = Path(args.source_dir)
    path = root / "deploy/container/Containerfile"
    errors = []
    stages, stage_users, final_entry = [], {}, None
    runtime_packages = []
    final_copies = []  # (sources, destination) of the runtime stage's COPY --from
    text = path.read_text()
    for keyword, arg in instructions(text):
        if keyword == "FROM":
            words = arg.split()
            image = words[0]
            name = words[2] if len(words) >= 3 and words[1].upper() == "AS" else str(len(stages))
            if not (image.split("/")[-1].startswith("debian:12")):
                errors.append(f"FROM {image}: the stages must be Debian 12 (debian:12, debian:12-slim)")
            stages.append(name)
            stage_users[name] = None
        elif keyword == "COPY":
            words = shlex.split(arg)
            flags = [w for w in words if w.startswith("--")]
            paths = [w for w in words if not w.startswith("--")]
            sources = paths[:-1]
            from_stage = next((f.split("=", 1)[1] for f in flags if f.startswith("--from=")), None)
            if from_stage is not None:
                if from_stage not in stages[:-1]:
                    errors.append(f"COPY --from={from_stage}: no earlier stage of that name")
                final_copies.append((sources, paths[-1]))
                continue
            for s in sources:
                if not (root / s).exists():
                    errors.append(f"COPY {s}: not in the build context ({root / s})")
        elif keyword == "USER":
            stage_users[stages[-1]] = arg
        elif keyword == "ENTRYPOINT":
            final_entry = (stages[-1], arg)
        elif keyword == "RUN" and "apt-get install" in arg and len(stages) > 1:
            after = arg.split("apt-get install", 1)[1].split("&&")[0]
            runtime_packages += [w for w in after.split() if not w.startswith("-")]
    if len(stages) < 2:
        errors.append("expected a multi-stage build (build, then runtime)")
    else:
        user = stage_users[stages[-1]]
        if user is None or user.split(":")[0] in ("root", "0"):
            errors.append(f"the runtime stage must set a non-root USER (got {user})")
        if final_entry is None or final_entry[0] != stages[-1] or "planner_server" not in final_entry[1]:
            errors.append("the runtime stage must have ENTRYPOINT planner_server")
    if "deploy/install-deps.sh" not in text:
        errors.append("the build stage must install dependencies with deploy/install-deps.sh")
    if "--preset release" not in text:
        errors.append("the build stage must build the release preset")
    if not runtime_packages:
        errors.append("the runtime stage installs no packages")
    if Path("/var/lib/apt/lists").exists() and any(Path("/var/lib/apt/lists").glob("*Packages*")):
        # One apt-cache call; a name it does not know has no "Package:" stanza in the output.
        shown = subprocess.run(["apt-cache", "show", "--no-all-versions", *runtime_packages],
                               capture_output=True, text=True).stdout
        found = {line.split(":", 1)[1].strip() for line in shown.splitlines()
                 if line.startswith("Package:")}
        for p in runtime_packages:
            if p not in found:
                errors.append(f"runtime package {p}: unknown to apt on this Debian machine")
    errors += missing_config_files(root, final_copies)
    for e in errors:
        print("Containerfile:", e)
    if not errors:
        print(f"Containerfile: ok ({len(stages)} stages, {len(runtime_packages)} runtime packages)")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())

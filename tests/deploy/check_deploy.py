#!/usr/bin/env python3
"""Keeps deploy/ honest without Docker or Kubernetes (neither runs on these machines).

Checks: every YAML file parses; every flag and MDR_* variable the Dockerfile, compose file and
manifests use exists in `mdrd --help`; the Dockerfile's build stage uses the install script and a
preset that exist; the runtime package list covers mdrd's shared libraries; the health probe the
container uses answers SERVING against a real mdrd. What it cannot run (docker build, kubectl,
envoy) is listed in docs/operations.md.

Usage: check_deploy.py REPO_ROOT MDRD_BINARY
"""
import glob
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time

import yaml

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)


def mdrd_options(mdrd):
    help_text = subprocess.run([mdrd, "--help"], capture_output=True, text=True).stdout
    flags = set(re.findall(r"(--[a-z][a-z0-9-]*)", help_text))
    env = set(re.findall(r"Env:(MDR_[A-Z0-9_]+)", help_text))
    return flags, env


def used_options(root):
    """Flags and MDR_* variables of mdrd's invocations: the Dockerfile's ENV and CMD, the compose
    service's command and environment, the Kubernetes containers' args and env."""
    flags, env = set(), set()
    dockerfile = open(os.path.join(root, "deploy", "Dockerfile")).read()
    env |= set(re.findall(r"\b(MDR_[A-Z0-9_]+)=", dockerfile))
    for line in re.findall(r"^(?:CMD|ENTRYPOINT) (.*)$", dockerfile, re.M):
        flags |= set(re.findall(r"(--[a-z][a-z0-9-]*)", line))
    compose = yaml.safe_load(open(os.path.join(root, "deploy", "compose.yaml")))
    for service in compose["services"].values():
        flags |= {a for a in service.get("command", []) if a.startswith("--")}
        env |= set(service.get("environment", {}))
    for path in glob.glob(os.path.join(root, "deploy", "k8s", "*.yaml")):
        for doc in yaml.safe_load_all(open(path)):
            spec = (doc or {}).get("spec", {}).get("template", {}).get("spec", {})
            for container in spec.get("containers", []):
                flags |= {a for a in container.get("args", []) if a.startswith("--")}
                env |= {e["name"] for e in container.get("env", [])}
    return flags, env


def check_yaml(root):
    for path in glob.glob(os.path.join(root, "deploy", "**", "*.yaml"), recursive=True):
        try:
            documents = [d for d in yaml.safe_load_all(open(path)) if d is not None]
        except yaml.YAMLError as error:
            check(False, f"{path}: invalid YAML: {error}")
            continue
        check(documents, f"{path}: empty")
        if "/k8s/" in path:
            for d in documents:
                check("apiVersion" in d and "kind" in d and "metadata" in d,
                      f"{path}: a Kubernetes object needs apiVersion, kind and metadata")


def check_dockerfile(root):
    text = open(os.path.join(root, "deploy", "Dockerfile")).read()
    check("bash deploy/install-deps.sh" in text, "Dockerfile: build stage must use install-deps.sh")
    check("install-deps.sh --runtime" in text, "Dockerfile: runtime stage must use --runtime")
    presets = {p["name"] for p in json.load(open(os.path.join(root, "CMakePresets.json")))
               ["configurePresets"]}
    for preset in re.findall(r"cmake --preset (\S+)", text):
        check(preset in presets, f"Dockerfile: unknown preset {preset}")
    check(re.search(r"^USER (?!root)\S+", text, re.M), "Dockerfile: must run as a non-root user")


def check_runtime_packages(root, mdrd):
    script = open(os.path.join(root, "deploy", "install-deps.sh")).read()
    runtime = set(re.search(r"RUNTIME_PACKAGES=\((.*?)\)", script, re.S).group(1).split())
    base = {"libc6", "libgcc-s1", "libstdc++6", "zlib1g"}  # in debian:12-slim
    libraries = re.findall(r"=> (\S+)", subprocess.run(["ldd", mdrd], capture_output=True,
                                                         text=True).stdout)
    for library in libraries:
        owner = ""
        for candidate in (library, os.path.realpath(library)):  # usrmerge: either may be listed
            found = subprocess.run(["dpkg", "-S", candidate], capture_output=True, text=True)
            if found.returncode == 0:
                owner = found.stdout.split(":")[0]
                break
        check(owner in runtime | base, f"install-deps.sh --runtime lacks {owner!r} ({library})")


def check_health_probe(root, mdrd):
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"127.0.0.1:{port}"
    server = subprocess.Popen([mdrd, "--listen", address, "--no-journal", "--log-level", "warn"])
    try:
        probe = [sys.executable, os.path.join(root, "deploy", "health_probe.py"), address]
        for _ in range(50):
            if subprocess.run(probe + ["readiness"], capture_output=True).returncode == 0:
                break
            time.sleep(0.1)
        for service in ("readiness", "", "mdr.v1.ContactService"):
            result = subprocess.run(probe + [service], capture_output=True, text=True)
            check(result.returncode == 0, f"health probe {service!r}: {result.stderr.strip()}")
    finally:
        server.send_signal(signal.SIGTERM)
        check(server.wait(timeout=30) == 0, "mdrd must exit 0 on SIGTERM")


def main():
    root, mdrd = sys.argv[1], sys.argv[2]
    known_flags, known_env = mdrd_options(mdrd)
    flags, env = used_options(root)
    for flag in sorted(flags - known_flags):
        check(False, f"deploy/ uses {flag}, which mdrd does not have")
    for name in sorted(env - known_env):
        check(False, f"deploy/ uses {name}, which mdrd does not read")
    check(flags and env, "no flags or variables found in deploy/: the scan is broken")
    check_yaml(root)
    check_dockerfile(root)
    check_runtime_packages(root, mdrd)
    check_health_probe(root, mdrd)
    for failure in failures:
        print("FAIL:", failure)
    print(f"check_deploy: {len(flags)} flags and {len(env)} variables checked; "
          f"{len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

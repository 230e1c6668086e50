#!/usr/bin/env python3
"""Keeps what tests/deploy/run.sh cannot run (Kubernetes, compose) consistent with mdrd: every
YAML file under deploy/ parses, and every flag and MDR_* variable the Dockerfile, compose file and
manifests use exists in `mdrd --help`. The image itself, its runtime packages, the health probe,
the journal volume, the drain and the router are proven by running them (tests/deploy/run.sh).

Usage: check_deploy.py REPO_ROOT MDRD_BINARY
"""
import glob
import os
import re
import subprocess
import sys

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
                if container.get("name") != "mdrd":
                    continue  # the router's containers (router.yaml) run HAProxy
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
    for failure in failures:
        print("FAIL:", failure)
    print(f"check_deploy: {len(flags)} flags and {len(env)} variables checked; "
          f"{len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

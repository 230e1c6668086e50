#!/usr/bin/python3
"""pip install of the Python package from the repository into a clean virtual environment, then
a session in process (through the bundled libmdr_c, no server) beside the same session on the
bundled mdrd (Client.embedded()), bit for bit, with snapshots moving both ways, and the analysis
in process against the server's. As the README says:

    python3 -m venv --system-site-packages venv
    venv/bin/pip install --no-index --no-build-isolation client/python

Usage: pip_install_test.py --source-dir REPO --work-dir DIR --build-dir BUILD

The sources (client/python and proto/) are copied to DIR first, so that the build leaves nothing
in the repository; the venv is made anew in DIR. The install bundles libmdr_c and mdrd from the
CMake build BUILD (MDR_CMAKE_BUILD_DIR: built already, nothing is recompiled). The check runs
from DIR with no PYTHONPATH, no MDR_C_LIBRARY and no MDR_MDRD, so `import mdr` can only find the
installed package and it can only use what it bundled. A missing library is an ImportError that
names the fix.
"""
import argparse
import os
import shutil
import subprocess
import sys

CHECK = r'''
import os, sys
import numpy as np
import mdr

assert mdr.__file__.startswith(sys.prefix), f"mdr imported from {mdr.__file__}, not the venv"
import mdr.embedded, mdr.inprocess
assert mdr.inprocess._library_path().startswith(sys.prefix), mdr.inprocess._library_path()
assert mdr.embedded.find_mdrd().startswith(sys.prefix), mdr.embedded.find_mdrd()
H1 = {"sphere": {"radius": 0.01}, "friction": 0.3,
      "elastic_pair": {"youngs_modulus_1": 210e9, "poisson_ratio_1": 0.3,
                       "youngs_modulus_2": 210e9, "poisson_ratio_2": 0.3}}
LOAD = [{"normal_force": 100}]
CYCLE = ([{"tangential_force": f} for f in (5, 10, 15, 0, -15)]
         + [{"displacement": u} for u in np.linspace(-4e-7, 4e-7, 9)]
         + [{"normal_force": 120, "tangential_force": 10}, {"depth_increment": 1e-8}])
QUERY = dict(outputs=["state", "tangential_stiffness", "jager_weights", "slip_intervals",
                      "tractions", "pressure"], radii=np.linspace(0, 1.5e-4, 7))


def bits(values):
    return np.asarray(values, dtype=np.float64).view(np.uint64)


def same(a, b, what):
    for name in ("depth", "tangential_displacement", "contact_radius", "normal_force",
                 "tangential_force", "dissipated_energy"):
        assert np.array_equal(bits(getattr(a, name)), bits(getattr(b, name))), (what, name)


def run(client):
    with client.session(H1) as s:
        s.apply(LOAD)
        first = s.apply(CYCLE, outputs=["state", "substeps"])
        query = s.query(**QUERY)
        return first, query, s.export()


local = mdr.Client.embedded(in_process=True)
with local, mdr.Client.embedded() as server:
    a, qa, snap_a = run(local)
    b, qb, snap_b = run(server)
    same(a, b, "apply")
    assert len(a.tangential_force) == len(CYCLE)
    assert a.response.step_results[-2].substeps > 1  # the curved force path
    assert qa.response.tangential_stiffness == qb.response.tangential_stiffness
    weights = lambda q: [(w.r_begin, w.r_end, w.weight) for w in q.response.jager_weights.intervals]
    assert weights(qa) == weights(qb) and len(weights(qa)) > 1  # (libmdr_c has no depths)
    assert qa.response.slip_intervals == qb.response.slip_intervals
    for name in ("tractions", "pressure"):
        for key in ("value", "error_estimate"):
            assert np.array_equal(bits(getattr(qa, name)[key]), bits(getattr(qb, name)[key])), name
    assert snap_a.contact == snap_b.contact and snap_a.applied_steps == snap_b.applied_steps
    # Snapshots both ways: the library's state continues on the server and the server's here.
    with server.import_session(snap_a) as on_server, local.import_session(snap_b) as here:
        same(on_server.apply(CYCLE), here.apply(CYCLE), "after import")
    # state_fields: the final state holds the asked fields, in process as on the server.
    with local.session(H1) as here, server.session(H1) as there:
        masked = [s.apply(LOAD, state_fields=["tangential_force", "normal_force"]).state
                  for s in (here, there)]
        assert masked[0] == masked[1] and masked[0].depth == 0 and masked[0].normal_force > 0
        for s in (here, there):
            try:
                s.apply(CYCLE, state_fields=["tangential_force", "forces"])
                raise AssertionError("an unknown state field was accepted")
            except mdr.MdrError as error:
                assert error.field == "state_mask.paths[1]", error.field
            assert s.export().applied_steps == 1
    # Errors name the Step's field, as the server does, and change nothing.
    with local.session(H1) as s:
        s.apply(LOAD)
        before = s.export()
        try:
            s.apply([{"tangential_force": 1}, {"depth": float("nan")}])
            raise AssertionError("a NaN depth was accepted")
        except mdr.MdrError as error:
            assert error.field == "steps[1].depth", error.field
        assert s.export() == before
    # The analysis in process: the service's own operations, the same answers but for the time.
    with local.session(H1) as s:
        s.apply(LOAD)
        ux = 1e-6 * np.sin(2 * np.pi * np.arange(301) / 100)
        loop = s.apply([{"displacement": u} for u in ux])
    u, fx = loop.tangential_displacement, loop.tangential_force
    rng = np.random.default_rng(47)
    u_noisy, fx_noisy = u + 5e-9 * rng.standard_normal(u.size), fx + 0.05 * rng.standard_normal(u.size)

    def untimed(message):
        message.compute_seconds = 0
        return message.SerializeToString(deterministic=True)

    answers = {}
    for where, client in (("local", local), ("server", server)):
        progress = []
        answers[where] = {
            "loops": client.analyze_loops(u_noisy, fx_noisy, 100, scene=H1).raw,
            "fit": client.fit_loops(H1, [(u_noisy, fx_noisy, 100)],
                                    {"friction": {"lower": 0.05, "upper": 0.9, "initial": 0.25}},
                                    progress=lambda *p: progress.append(p)).raw,
            "map": client.fretting_map(H1, [50, 100], [0.3, 1, 3]).raw,
            "backbone": client.backbone(H1, 100, [5, 15, 25]).raw}
        assert progress, f"{where}: no progress reported"
    for name, answer in answers["local"].items():
        assert answer.compute_seconds > 0, name
        assert untimed(answer) == untimed(answers["server"][name]), name
    assert len(answers["local"]["loops"].cycles) >= 2
    assert answers["local"]["fit"].estimates[0].value > 0
    try:
        local.analyze_loops([0, 1e-6, 0], [0.0], None)
        raise AssertionError("mismatched samples were accepted")
    except mdr.MdrError as error:
        assert error.field == "samples.tangential_force", error.field
# Without its library the package says what to do.
os.environ["MDR_C_LIBRARY"] = "/nonexistent/libmdr_c.so.1"
try:
    mdr.Client.embedded(in_process=True)
    raise AssertionError("a missing libmdr_c was not reported")
except ImportError as error:
    assert "pip install client/python" in str(error) and "MDR_C_LIBRARY" in str(error), error
print("in-process session and analysis identical to mdrd's")
'''


def main():
    parser = argparse.ArgumentParser()
    for name in ("--source-dir", "--work-dir", "--build-dir"):
        parser.add_argument(name, required=True)
    args = parser.parse_args()
    work = os.path.abspath(args.work_dir)
    shutil.rmtree(work, ignore_errors=True)
    ignore = shutil.ignore_patterns("build", "*.egg-info", "__pycache__", "CMakeLists.txt")
    shutil.copytree(os.path.join(args.source_dir, "client", "python"),
                    os.path.join(work, "src", "client", "python"), ignore=ignore)
    shutil.copytree(os.path.join(args.source_dir, "proto"), os.path.join(work, "src", "proto"))
    venv = os.path.join(work, "venv")
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", venv], check=True)
    python = os.path.join(venv, "bin", "python")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "MDR_C_LIBRARY", "MDR_MDRD")}
    install_env = dict(env, MDR_CMAKE_BUILD_DIR=os.path.abspath(args.build_dir))
    subprocess.run([python, "-m", "pip", "install", "--no-index", "--no-build-isolation",
                    "--quiet", os.path.join(work, "src", "client", "python")], check=True,
                   cwd=work, env=install_env)
    check = subprocess.run([python, "-c", CHECK], cwd=work, env=env)
    if check.returncode != 0:
        sys.exit("the in-process check failed (its traceback above)")


if __name__ == "__main__":
    main()

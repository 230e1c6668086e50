#!/usr/bin/env python3
"""mdrctl loops, fit and synthesize on torsional records (a ball twisted on a flat: the twist in
rad and the twisting moment in N m; docs/analysis.md, "Torsional records"), one case per CTest
test. The records are made by the engine through `mdrctl synthesize` (a truth with torsion):

  torsion_loops   mdrctl loops on a noise-free run of H1 twisted to c = a/2 behind a shaft of
                  0.5 rad/(N m): M*, the contact's twist amplitude and the loss per cycle against
                  docs/reference-values.md, the full-slip moment against 3 pi mu P a / 16, the
                  regime; the same figures in mrad and mN m, from a MAT file, with the shaft given
                  by --rig-compliance or by the scene; the table's and report's labels in rad and
                  N m, and the plots
  torsion_fit     mdrctl fit on a noise-free torsional campaign (three loads, one set in mrad and
                  mN m) recovers mu, G_t and the shaft's compliance to 1e-6, replays the model
                  through sessions, reports the fitted scene's torsion and skips the fretting map
  torsion_example examples/torsional_rig/run.sh re-run reproduces the committed data/ byte for
                  byte and report.json's numbers, and its estimates hold the truth
  torsion_errors  the options' and campaign keys' errors named (a tangential and a torsional
                  option together, unknown units, the other channel's keys), bad cells and the
                  service's sample errors at their line and column, a torsional record with a
                  tangential scene and the reverse (the service's error at the scene's line)

Usage: rig_torsion_test.py --mdrctl PATH --source-dir DIR CASE
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

from rig_analysis_test import (Failure, check, check_pngs, close, csv_rows, expect_failure,
                               expect_success, numbers, write, write_mat5)

# H1 (docs/reference-values.md): a steel sphere R = 10 mm on a steel flat, mu = 0.3, at 100 N;
# twisted to the stick radius c = a/2 on the virgin curve: phi* and M there, and the Hertz loss per
# cycle of the steady loop between +-phi* ("Torsion").
H1 = """  sphere: {radius: 0.01}
  elastic_pair: {youngs_modulus_1: 210e9, poisson_ratio_1: 0.3, youngs_modulus_2: 210e9,
                 poisson_ratio_2: 0.3}
  friction: 0.3
"""
PHI_HALF = 4.8141258757e-3  # rad
M_HALF = 2.9593735330e-3  # N m
LOSS_HALF = 1.8173196119e-5  # J per cycle
SHAFT = 0.5  # rad/(N m)
E_STAR = 210e9 / (2 * (1 - 0.3**2))
G_T = 210e9 / (2 * 1.3) / 2  # 1/G_t = 1/G_1 + 1/G_2


def torsional_scene(compliance):
    return H1 + f"  torsion: {{rig_compliance: {compliance!r}}}\n"


def full_slip_moment(normal_force, mu=0.3):
    a = (3 * normal_force * 0.01 / (4 * E_STAR)) ** (1 / 3)
    return 3 * math.pi * mu * normal_force * a / 16


SPEC = """truth:
{truth}normal_forces: [{loads}]
amplitudes: [{amplitudes}]
cycles: {cycles}
samples_per_cycle: {samples}
sampling_rate: 1000
fit:
  free:
    - {{parameter: friction, initial: 0.4, lower: 0.05, upper: 2}}
    - {{parameter: torsional_modulus, initial: 3e10, lower: 1e9, upper: 1e12}}
    - {{parameter: rig_compliance, initial: 0.3, lower: 0, upper: 10}}
"""


def synthesize(mdrctl, tmp, loads, amplitudes, cycles, samples):
    spec = write(os.path.join(tmp, "spec.yaml"),
                 SPEC.format(truth=torsional_scene(SHAFT), loads=loads, amplitudes=amplitudes,
                             cycles=cycles, samples=samples))
    out = os.path.join(tmp, "data")
    expect_success(mdrctl, ["synthesize", spec, "--out", out], "synthesize torsional runs")
    return out


def samples_of(path):
    """time, twist, moment of a synthesized torsional file."""
    rows = [line.split(",") for line in open(path).read().splitlines()
            if not line.startswith(("#", "time"))]
    return [[float(cell) for cell in row] for row in rows]


TORSIONAL = ["--twist-column", "twist", "--moment-column", "twisting_moment"]


# ---- torsion_loops ----

def case_torsion_loops(args, tmp):
    m = args.mdrctl
    data = synthesize(m, tmp, "100", repr(PHI_HALF), 3, 400)
    (name,) = [f for f in os.listdir(data) if f.endswith(".csv")]
    check(name == "p100N_phi4.81413mrad.csv", f"the run's file is {name}")
    run = os.path.join(data, name)
    check("# SYNTHETIC" in open(run).read(), "the run is not marked synthetic")
    scene = write(os.path.join(tmp, "scene.yaml"), "scene:\n" + torsional_scene(SHAFT))
    common = [*TORSIONAL, "--time-column", "time", "--normal-force", "100", "--format", "csv"]
    rows = csv_rows(expect_success(m, ["loops", run, "--scene", scene, *common],
                                   "loops of a torsional run").stdout)
    check(len(rows) == 2, f"expected 2 complete cycles, got {len(rows)}")
    slip = full_slip_moment(100)
    for row in rows:
        close(float(row["force_amplitude"]), M_HALF, 1e-9, "M*")
        close(float(row["contact_displacement_amplitude"]), PHI_HALF, 1e-9, "phi*_c")
        close(float(row["displacement_amplitude"]), PHI_HALF + SHAFT * M_HALF, 1e-9, "phi*")
        close(float(row["dissipated_energy"]), LOSS_HALF, 2e-4, "Ed (400 samples per cycle)")
        close(float(row["energy_ratio"]), float(row["dissipated_energy"]) /
              (4 * float(row["displacement_amplitude"]) * float(row["force_amplitude"])), 1e-9,
              "A")
        close(float(row["full_slip_moment"]), slip, 1e-9, "M_slip")
        check(row["regime"] == "partial|slip", f"regime {row['regime']!r}, expected partial slip")
        check(row["flags"] == "-", f"flags {row['flags']!r}")
    check("friction_coefficient" not in rows[0] and "onset_system_free_ratio" not in rows[0],
          f"a torsional table has no mu and no onset C: {list(rows[0])}")
    print(f"ok M* {rows[0]['force_amplitude']} N m, Ed {rows[0]['dissipated_energy']} J "
          f"(reference {LOSS_HALF}), M_slip {rows[0]['full_slip_moment']} N m")

    # The shaft given on the command line instead of by the scene: the same figures.
    given = csv_rows(expect_success(m, ["loops", run, "--rig-compliance", repr(SHAFT), *common],
                                    "--rig-compliance").stdout)
    for a, b in zip(rows, given):
        check(a["contact_displacement_amplitude"] == b["contact_displacement_amplitude"],
              "--rig-compliance gives another contact amplitude than the scene's shaft")

    # mrad and mN m, ';' separators and other headers: the same figures; a MAT file too.
    samples = samples_of(run)
    converted = write(os.path.join(tmp, "converted.csv"), "t;phi_mrad;m_mNm\n" + "".join(
        f"{t!r};{phi * 1e3!r};{moment * 1e3!r}\n" for t, phi, moment in samples))
    same = csv_rows(expect_success(
        m, ["loops", converted, "--twist-column", "phi_mrad", "--moment-column", "m_mNm",
            "--twist-unit", "mrad", "--moment-unit", "mN m", "--time-column", "t",
            "--normal-force", "100", "--scene", scene, "--format", "csv"], "mrad and mN m").stdout)
    for a, b in zip(rows, same):
        for key in ("force_amplitude", "dissipated_energy", "displacement_amplitude",
                    "half_opening"):
            close(float(b[key]), float(a[key]), 1e-12, f"{key} in mrad and mN m")
    mat = os.path.join(tmp, "run.mat")
    write_mat5(mat, {"time": [s[0] for s in samples], "twist": [s[1] for s in samples],
                     "twisting_moment": [s[2] for s in samples]})
    plain = expect_success(m, ["loops", run, *common], "plain CSV").stdout
    check(expect_success(m, ["loops", mat, *common], "MAT file").stdout == plain,
          "the MAT file gives other figures than the CSV file")
    print("ok mrad and mN m, a MAT file, and --rig-compliance give the same figures")

    table = expect_success(m, ["loops", run, "--scene", scene, *TORSIONAL, "--normal-force",
                               "100"], "table").stdout
    for needle in ("M* [N m]", "phi_0 [rad]", "phi* [rad]", "k_sec [N m/rad]", "phi*_c [rad]",
                   "M_slip [N m]", "partial slip", "reversal threshold", " rad, friction drift"):
        check(needle in table, f"the table lacks {needle!r}:\n{table}")
    report = os.path.join(tmp, "report")
    expect_success(m, ["loops", run, "--scene", scene, *TORSIONAL, "--normal-force", "100",
                       "--report", report], "report")
    document = json.load(open(os.path.join(report, "report.json")))
    layout = document["set"]["layout"]
    check(layout["channel"] == "torsional" and layout["twist_unit_rad"] == 1 and
          layout["moment_column"] == "twisting_moment", f"report.json layout {layout}")
    check(document["options"]["rig_compliance"] == SHAFT, "the scene's shaft not in the options")
    cycles = document["set"]["analysis"]["cycles"]
    check(len(cycles) == 2 and math.isnan(float(cycles[0]["friction_coefficient"])),
          "report.json: a torsional cycle's friction coefficient is NaN")
    text = open(os.path.join(report, "report.md")).read()
    for needle in ("twist `twist` (x1 rad), twisting moment `twisting_moment` (x1 N m)",
                   "rad/(N m): the contact figures (phi*_c, A_c, B_c) are phi - C M's",
                   "Regimes against the full-slip moment", "M* [N m] (contact)",
                   "phi* [rad] (contact+rig)", "(moments, dissipated energy"):
        check(needle in text, f"report.md lacks {needle!r}")
    check_pngs(report, ["loop.png", "cycles.png"], document)


# ---- torsion_fit ----

def case_torsion_fit(args, tmp):
    m = args.mdrctl
    data = synthesize(m, tmp, "30, 100, 300", "6e-3", 2, 120)
    campaign = os.path.join(data, "campaign.yaml")
    text = open(campaign).read()
    for needle in ("torsion:", "columns: {twist: twist, twisting_moment: twisting_moment",
                   "units: {twist: rad, moment: N m", "torsional_modulus:"):
        check(needle in text, f"campaign.yaml lacks {needle!r}")
    # One set in mrad and mN m under other headers, read by its own columns and units.
    original = os.path.join(data, "p100N_phi6mrad.csv")
    write(os.path.join(data, "p100N_mrad.csv"), "t,phi,moment\n" + "".join(
        f"{t!r},{phi * 1e3!r},{moment * 1e3!r}\n" for t, phi, moment in samples_of(original)))
    text = text.replace("{file: p100N_phi6mrad.csv, normal_force: 100}",
                        "{file: p100N_mrad.csv, normal_force: 100, columns: {twist: phi, "
                        "twisting_moment: moment, time: t}, units: {twist: mrad, moment: mN m}}")
    check("p100N_mrad.csv" in text, "the set was not replaced")
    campaign = write(os.path.join(data, "mixed.yaml"), text)
    report = os.path.join(tmp, "report")
    result = expect_success(m, ["fit", campaign, "--report", report, "--format", "json"],
                            "torsional fit")
    check(" N m (friction " in result.stderr, f"progress not in N m: {result.stderr}")
    fit = json.loads(result.stdout)
    truth = {"FIT_PARAMETER_FRICTION": 0.3, "FIT_PARAMETER_TORSIONAL_MODULUS": G_T,
             "FIT_PARAMETER_RIG_COMPLIANCE": SHAFT}
    check([e["parameter"] for e in fit["estimates"]] == list(truth), "the estimates' order")
    for e in fit["estimates"]:
        close(e["value"], truth[e["parameter"]], 1e-6, e["parameter"])
        check(e["identified"], f"{e['parameter']} not identified")
    check(fit["converged"] and fit["identified"], "not converged / identified")
    torsion = fit["fitted_scene"]["torsion"]
    close(torsion["torsional_modulus"], G_T, 1e-6, "fitted_scene.torsion.torsional_modulus")
    close(torsion["rig_compliance"], SHAFT, 1e-6, "fitted_scene.torsion.rig_compliance")
    print("ok recovered: " + ", ".join(f"{e['parameter']} {e['value']!r}"
                                       for e in fit["estimates"]))
    document = json.load(open(os.path.join(report, "report.json")))
    check(document["fitted_torsion"]["rig_compliance"] == torsion["rig_compliance"],
          "report.json: fitted_torsion")
    close(document["fitted_torsion"]["torsional_modulus"], G_T, 1e-6, "report.json G_t")
    check("fretting_map" not in document and "FrettingMap refuses scene.torsion" in
          document["fretting_map_skipped"], "report.json: the map is not skipped")
    replay = document["replay"]
    check(replay["largest_contact_force_difference"] <= 1e-12 * M_HALF,
          f"the sessions' moments differ from the fit's model: {replay}")
    check(abs(replay["residual_rms"] - replay["fit_residual_rms"]) <=
          1e-6 * replay["fit_residual_rms"] + 1e-15, f"replay {replay}")
    units = {s["file"]: s["layout"]["twist_unit_rad"] for s in document["sets"]}
    check(units["p100N_mrad.csv"] == 1e-3 and units["p30N_phi6mrad.csv"] == 1,
          f"per-set units {units}")
    for s in document["sets"]:
        for cycle in s["analysis"]["cycles"]:
            close(cycle["full_slip_moment"], full_slip_moment(s["normal_force"]), 1e-6,
                  "the fitted scene's M_slip")
    text = open(os.path.join(report, "report.md")).read()
    for needle in ("| torsional_modulus | Pa |", "| rig_compliance | rad/(N m) |",
                   "The fitted scene's torsion: torsional_modulus G_t = 4.038461", "phi noise [rad]",
                   "No fretting map", "M* / M_slip", "Not computed for a torsional campaign",
                   "residuals (M measured - fitted)", "twist `phi` (x0.001 rad)"):
        check(needle in text, f"report.md lacks {needle!r}")
    check_pngs(report, ["loops.png", "residuals.png"], document)


# ---- torsion_example ----

def case_torsion_example(args, tmp):
    example = os.path.join(args.source_dir, "examples", "torsional_rig")
    out = os.path.join(tmp, "torsional_rig")
    result = subprocess.run(["bash", os.path.join(example, "run.sh"), out], capture_output=True,
                            text=True, env={**os.environ, "MDRCTL": args.mdrctl}, timeout=300)
    check(result.returncode == 0, f"run.sh failed:\n{result.stdout}\n{result.stderr}")
    for name in sorted(os.listdir(os.path.join(example, "data"))):
        same = open(os.path.join(example, "data", name)).read() == \
            open(os.path.join(out, "data", name)).read()
        check(same, f"data/{name} differs from the committed file")
    print("ok data/ reproduced byte for byte")
    committed = dict(numbers(json.load(open(os.path.join(example, "report", "report.json")))))
    rerun_document = json.load(open(os.path.join(out, "report", "report.json")))
    rerun = dict(numbers(rerun_document))
    check(committed.keys() == rerun.keys(),
          f"report.json keys differ: {set(committed) ^ set(rerun)}")
    # The fit is deterministic; the tolerance covers other libm versions.
    worst = max(abs(value - rerun[key]) / max(abs(value), abs(rerun[key]), 1e-300)
                for key, value in committed.items())
    check(worst <= 1e-6, f"report.json differs by {worst:.3g} (relative)")
    print(f"ok {len(committed)} numbers of report.json reproduced (largest relative difference "
          f"{worst:.3g})")
    check("FrettingMap refuses" in rerun_document["fretting_map_skipped"], "the map's note")
    for e in rerun_document["estimates"]:
        check(e["identified"] and e["truth_inside_95"],
              f"{e['parameter']}: {e['value']} (truth {e['truth']}) not identified or missed")
        print(f"  {e['parameter']}: {e['value']:.8g} +- {e['standard_error']:.3g} "
              f"(truth {e['truth']})")


# ---- torsion_errors ----

def case_torsion_errors(args, tmp):
    m = args.mdrctl
    data = synthesize(m, tmp, "100", "3e-3", 2, 40)
    run = os.path.join(data, "p100N_phi3mrad.csv")
    for option, value in (("--displacement-column", "u"), ("--force-column", "f"),
                          ("--displacement-unit", "mm")):
        expect_failure(m, ["loops", run, "--moment-column", "twisting_moment", option, value],
                       rf"^mdrctl: {option}: cannot be combined with --moment-column: a record is "
                       r"tangential \(--displacement-column, --force-column, --displacement-unit\) "
                       r"or torsional \(", f"{option} with a torsional option")
    expect_failure(m, ["loops", run, "--moment-unit", "Nm"],
                   r'^mdrctl: --moment-unit: must be one of N m, N mm, mN m, got "Nm"\n$',
                   "an unknown moment unit")
    expect_failure(m, ["loops", run, "--twist-unit", "grad"],
                   r'^mdrctl: --twist-unit: must be one of rad, mrad, urad, µrad, deg, got "grad"',
                   "an unknown twist unit")
    lines = open(run).read().splitlines()
    bad = list(lines)
    bad[9] = bad[9].rsplit(",", 1)[0] + ",oops"
    expect_failure(m, ["loops", write(os.path.join(tmp, "cell.csv"), "\n".join(bad) + "\n"),
                       *TORSIONAL],
                   r'^mdrctl: \S*cell\.csv:10: column "twisting_moment": "oops" is not a finite '
                   r'number\n$', "a bad moment cell")
    bad = list(lines)
    t, _, moment = bad[12].split(",")
    bad[12] = f"{t},150,{moment}"
    expect_failure(m, ["loops", write(os.path.join(tmp, "far.csv"), "\n".join(bad) + "\n"),
                       *TORSIONAL],
                   r'^mdrctl: \S*far\.csv:13: column "twist": must be in \[-100, 100\]',
                   "a twist beyond 100 rad: the service's error at its line and column")
    # The record decides the channel; the scene must match it (the service's error, at the line
    # of the scene file's scene).
    tangential_scene = write(os.path.join(tmp, "tangential.yaml"), "scene:\n" + H1)
    expect_failure(m, ["loops", run, *TORSIONAL, "--normal-force", "100", "--scene",
                       tangential_scene],
                   r"^mdrctl: scene\.torsion: is required to classify a torsional record "
                   r"[^\n]*\(\S*tangential\.yaml:\d+\)\n$", "a torsional record, tangential scene")
    tangential_run = write(os.path.join(tmp, "tangential.csv"), "displacement,tangential_force\n"
                           + "".join(f"{1e-6 * math.sin(k / 8)!r},{math.sin(k / 8 - 0.2)!r}\n"
                                     for k in range(200)))
    torsional_scene_file = write(os.path.join(tmp, "twisted.yaml"),
                                 "scene:\n" + torsional_scene(SHAFT))
    expect_failure(m, ["loops", tangential_run, "--normal-force", "100", "--scene",
                       torsional_scene_file],
                   r"^mdrctl: scene\.torsion: must be unset to classify a tangential record "
                   r"[^\n]*\(\S*twisted\.yaml:\d+\)\n$", "a tangential record, torsional scene")
    # Campaigns: the other channel's columns and units are refused by name and line.
    campaign = os.path.join(data, "campaign.yaml")
    original = open(campaign).read()

    def variant(name, old, new):
        check(old in original, f"{old!r} not in the campaign")
        return write(os.path.join(data, name), original.replace(old, new, 1))

    expect_failure(m, ["fit", variant("columns.yaml", "columns: {twist: twist",
                                      "columns: {displacement: u, twist: twist")],
                   r"^mdrctl: columns\.displacement: is a tangential record's; the campaign's "
                   r"scene has torsion[^\n]*\(\S*columns\.yaml:\d+\)\n$",
                   "a displacement column in a torsional campaign")
    expect_failure(m, ["fit", variant("units.yaml", "units: {twist: rad",
                                      "units: {displacement: mm, twist: rad")],
                   r"^mdrctl: units\.displacement: is a tangential record's", "a displacement unit")
    expect_failure(m, ["fit", variant("moment_unit.yaml", "{twist: rad, moment: N m,",
                                      "{twist: rad, moment: N cm,")],
                   r'^mdrctl: units\.moment: must be one of N m, N mm, mN m, got "N cm" '
                   r'\(\S*moment_unit\.yaml:\d+\)', "an unknown moment unit in a campaign")
    untwisted = original.replace("  torsion:\n", "  rig: {tangential_compliance: 0}\n  x_torsion:\n")
    check("x_torsion" in untwisted, "the campaign's scene has no torsion block")
    untwisted = "\n".join(line for line in untwisted.splitlines()
                          if "x_torsion" not in line and not line.startswith("    rig_compliance")
                          and not line.startswith("    torsional_modulus"))
    expect_failure(m, ["fit", write(os.path.join(data, "tangential.yaml"), untwisted + "\n")],
                   r"^mdrctl: columns\.twist: is a torsional record's; it needs a scene with "
                   r"torsion \(scene\.torsion\)", "twist columns in a tangential campaign")
    spec = open(os.path.join(tmp, "spec.yaml")).read()
    expect_failure(m, ["synthesize", write(os.path.join(tmp, "noise.yaml"),
                                           spec + "noise: {seed: 1, force: 0.1}\n"),
                       "--out", os.path.join(tmp, "noise")],
                   r"^mdrctl: noise\.force: is a tangential record's; a torsional truth",
                   "a force noise for a torsional truth")


CASES = {
    "torsion_loops": case_torsion_loops,
    "torsion_fit": case_torsion_fit,
    "torsion_example": case_torsion_example,
    "torsion_errors": case_torsion_errors,
}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrctl", required=True)
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("case", choices=sorted(CASES))
    args = parser.parse_args()
    args.mdrctl = os.path.abspath(args.mdrctl)
    with tempfile.TemporaryDirectory(prefix="mdrctl-torsion-") as tmp:
        try:
            CASES[args.case](args, tmp)
        except Failure as failure:
            print(f"FAILED {args.case}: {failure}")
            return 1
    print(f"passed {args.case}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""mdrctl loops, fit and synthesize end to end (docs/analysis.md, "From a rig's CSV files to a
report"), one case per CTest test:

  csv_errors          the rig CSV reader's errors: file, line and column named, text from the
                      file bounded and escaped; separators, decimal commas and units
  loops_figures       mdrctl loops on a noise-free synthetic run against the closed forms; the
                      same file in other units, separators, decimal commas and quoting
  fit_recovers        mdrctl fit on a noise-free synthetic campaign recovers mu, E* and C_t to
                      1e-6; the report files and report.json
  fit_without_gnuplot --report without gnuplot writes report.md/json and says plots were skipped
  campaign_errors     campaign and synthesis files: unknown keys (escaped), bad values, service
                      errors at their line, a bad cell in a set's CSV
  example_reproduces  examples/rig_campaign/run.sh re-run reproduces the committed report.json
  runs                a file of several runs split by a run column (CSV and MAT): each run's
                      figures those of its own file, --run, and the refusals (a missing run,
                      an interleaved run, an empty run cell, --run without --run-column);
                      a campaign taking its sets as runs of one file fits as the separate files
  cut_last_line       a file whose last line has no line end (cut short) is refused at it
  json_fields         --format json and report.json carry every field, zeros and false
                      included, and sample indices as JSON numbers
  long_run            a file of 10^6 samples: analysed on mdrctl's own server (past mdrd's
                      default message limit), and through --server to an mdrd with that default
                      refused naming the file, the request's size and --max-message-bytes

Usage: rig_analysis_test.py --mdrctl PATH --mdrd PATH --source-dir DIR CASE
"""
import argparse
import csv
import json
import math
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile

H1_SCENE = """  sphere: {radius: 0.01}
  elastic_pair: {youngs_modulus_1: 210e9, poisson_ratio_1: 0.3, youngs_modulus_2: 210e9,
                 poisson_ratio_2: 0.3}
  friction: 0.3
  rig: {tangential_compliance: 2e-8}
"""
H1_DEPTH = 3.4829098839e-6  # m at 100 N (docs/reference-values.md, H1)
KAPPA = (2 - 0.3) / (2 * (1 - 0.3))  # E*/G* of two steel bodies


class Failure(Exception):
    pass


def check(condition, message):
    if not condition:
        raise Failure(message)


def close(actual, expected, relative, what):
    check(abs(actual - expected) <= relative * abs(expected),
          f"{what}: {actual!r} is not within {relative} of {expected!r}")


def run(mdrctl, *args, env=None, cwd=None):
    return subprocess.run([mdrctl, *args], capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=120)


def expect_failure(mdrctl, args, regex, what):
    result = run(mdrctl, *args)
    check(result.returncode != 0, f"{what}: exit code 0\nstdout: {result.stdout}")
    check(re.search(regex, result.stderr),
          f"{what}: stderr does not match {regex!r}:\n{result.stderr}")
    print(f"ok {what}: {result.stderr.strip()}")
    return result.stderr


def expect_success(mdrctl, args, what, **kwargs):
    result = run(mdrctl, *args, **kwargs)
    check(result.returncode == 0,
          f"{what}: exit code {result.returncode}\nstdout: {result.stdout}\n"
          f"stderr: {result.stderr}")
    return result


def write(path, data):
    with open(path, "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())
    return path


def write_mat5(path, columns):
    """A MATLAB level-5 MAT file of column vectors of doubles, uncompressed (the format's
    published layout: a 128-byte header, then one miMATRIX element per variable)."""
    def element(data_type, payload):
        padding = (-len(payload)) % 8
        return struct.pack("<II", data_type, len(payload)) + payload + b"\0" * padding

    mi_int8, mi_int32, mi_uint32, mi_double, mi_matrix, mx_double = 1, 5, 6, 9, 14, 6
    body = b""
    for name, values in columns.items():
        matrix = (element(mi_uint32, struct.pack("<II", mx_double, 0))
                  + element(mi_int32, struct.pack("<ii", len(values), 1))
                  + element(mi_int8, name.encode("latin-1"))
                  + element(mi_double, struct.pack(f"<{len(values)}d", *values)))
        body += struct.pack("<II", mi_matrix, len(matrix)) + matrix
    text = b"MATLAB 5.0 MAT-file, written by rig_analysis_test.py".ljust(116, b" ")
    with open(path, "wb") as f:
        f.write(text + b"\0" * 8 + struct.pack("<H", 0x0100) + b"IM" + body)


def csv_rows(text):
    return list(csv.DictReader(line for line in text.splitlines() if line))


# ---- csv_errors ----

def case_csv_errors(args, tmp):
    m = args.mdrctl
    good = "displacement,tangential_force,time\n0,0,0\n1e-6,1,0.1\n"
    cases = [
        ("missing.csv", b"# rig 7\ndisplacement,force\n0,0\n", [],
         r'^mdrctl: \S*missing\.csv:2: no column "tangential_force" in the header; its columns '
         r'are "displacement", "force"\n$', "a missing column"),
        ("nan.csv", b"displacement,tangential_force\n0,0\n1e-6,1\n\n1e-6,nan\n", [],
         r'^mdrctl: \S*nan\.csv:5: column "tangential_force": "nan" is not a finite number\n$',
         "a NaN cell"),
        ("inf.csv", b"displacement,tangential_force\n0,0\n-inf,1\n", [],
         r'inf\.csv:3: column "displacement": "-inf" is not a finite number', "an infinite cell"),
        ("text.csv", b"# header next\ndisplacement,tangential_force\n0,0\nabc,1\n", [],
         r'^mdrctl: \S*text\.csv:4: column "displacement": "abc" is not a finite number\n$',
         "a text cell"),
        ("blank.csv", b"displacement,tangential_force\n0,0\n1e-6,\n", [],
         r'blank\.csv:3: column "tangential_force": the cell is empty', "an empty cell"),
        ("ragged.csv", b"# rig\n\ndisplacement,tangential_force,time\n0,0,0\n1e-6,1,0.1\n2e-6,2\n",
         ["--time-column", "time"],
         r'^mdrctl: \S*ragged\.csv:6: the row has 2 cells, the header \(line 3\) has 3; column '
         r'"time" has no cell\n$', "a short row"),
        ("long_row.csv", b"displacement,tangential_force,time\n0,0,0,7\n", [],
         r'long_row\.csv:2: the row has 4 cells, the header \(line 1\) has 3\n$', "a long row"),
        ("empty.csv", b"", [], r'^mdrctl: \S*empty\.csv: the file is empty', "an empty file"),
        ("comments.csv", b"# only\n\n   \n# comments\n", [], r'comments\.csv: the file is empty',
         "only comments"),
        ("header_only.csv", b"# x\ndisplacement,tangential_force\n# no data\n", [],
         r'^mdrctl: \S*header_only\.csv: no data rows after the header \(line 2\)\n$',
         "no data rows"),
        ("mixed.csv", b"displacement,tangential_force;time\n0,0;0\n", [],
         r'mixed\.csv:1: the header mixes the separators ",;"', "mixed separators"),
        ("time.csv", b"displacement,tangential_force,time\n0,0,0\n1e-6,1,0.1\n2e-6,2,0.1\n",
         ["--time-column", "time"], r'^mdrctl: \S*time\.csv:4: column "time": ',
         "a service error restated at the CSV line"),
        ("thousands.csv", b"displacement;tangential_force\n0;0\n1.000,5;1\n", [],
         r'^mdrctl: \S*thousands\.csv:3: column "displacement": "1\.000,5" is not a finite '
         r"number \(a decimal comma is read only in a cell with one ',' and no '\.'\)\n$",
         "a cell with both a point and a comma"),
        ("comma_in_comma_file.csv", b'displacement,tangential_force\n0,0\n"1,5",1\n', [],
         r'comma_in_comma_file\.csv:3: the row has 3 cells, the header \(line 1\) has 2\n$',
         "a decimal comma where ',' separates the cells"),
        ("good.csv", good.encode(), ["--force-unit", "lb"],
         r'^mdrctl: --force-unit: must be one of N, kN, mN, got "lb"\n$', "an unknown unit"),
    ]
    for name, data, extra, regex, what in cases:
        expect_failure(m, ["loops", write(os.path.join(tmp, name), data), *extra], regex, what)
    expect_failure(m, ["loops", os.path.join(tmp, "none.csv")],
                   r'none\.csv: cannot open the CSV file', "a missing file")
    # Text from the file is cut after 64 bytes and escaped.
    cell = b"\x01" + b"x" * 300 + b'"'
    err = expect_failure(m, ["loops", write(os.path.join(tmp, "long.csv"),
                                            b"displacement,tangential_force\n" + cell + b",1\n")],
                         r'long\.csv:2: column "displacement": "\\x01x+\.\.\." is not a finite',
                         "a long cell with a control byte")
    quoted = re.search(r'"(\\x01x+\.\.\.)"', err).group(1)
    check(len(quoted) == 64 + 3 + 3 and "\x01" not in err,
          f"the cell is not bounded to 64 bytes and escaped: {err!r}")
    err = expect_failure(m, ["loops", write(os.path.join(tmp, "names.csv"),
                                            b"displacement,tang\x1bential\xff\n0,0\n")],
                         r'its columns are "displacement", "tang\\x1Bential\\xFF"',
                         "header names escaped")
    check("\x1b" not in err, "an escape byte reached the terminal")
    # MATLAB files: a missing variable (the file's names escaped), a service error restated at
    # the variable's element, a file that is not one.
    mat = os.path.join(tmp, "names.mat")
    write_mat5(mat, {"displacement": [0.0, 1e-6], "tang\x1bential": [0.0, 1.0]})
    err = expect_failure(m, ["loops", mat],
                         r'^mdrctl: \S*names\.mat: no variable "tangential_force" in the file; '
                         r'its variables are "displacement", "tang\\x1Bential"\n$',
                         "a missing MAT variable")
    check("\x1b" not in err, "an escape byte of a MAT name reached the terminal")
    mat = os.path.join(tmp, "time.mat")
    write_mat5(mat, {"displacement": [0.0, 1e-6, 2e-6], "tangential_force": [0.0, 1.0, 2.0],
                     "time": [0.0, 0.1, 0.1]})
    expect_failure(m, ["loops", mat, "--time-column", "time"],
                   r'^mdrctl: \S*time\.mat: variable "time", element 3: ',
                   "a service error restated at the MAT element")
    expect_failure(m, ["loops", write(os.path.join(tmp, "text.MAT"), good.encode())],
                   r'^mdrctl: \S*text\.MAT: cannot open as a MATLAB file \(version 4, 5 or 7\.3\)',
                   "a CSV named .MAT")


# ---- loops_figures ----

SPEC = """truth:
{scene}normal_forces: [{loads}]
amplitudes: [{amplitudes}]
cycles: {cycles}
samples_per_cycle: {samples}
sampling_rate: 1000
fit:
  free:
    - {{parameter: friction, initial: 0.45, lower: 0.05, upper: 1.5}}
    - {{parameter: effective_modulus, initial: 9e10, lower: 1e10, upper: 1e12}}
    - {{parameter: rig_compliance, initial: 3e-8, lower: 1e-10, upper: 1e-6}}
"""


def synthesize(mdrctl, tmp, scene, loads, amplitudes, cycles, samples):
    spec = write(os.path.join(tmp, "spec.yaml"),
                 SPEC.format(scene=scene, loads=loads, amplitudes=amplitudes, cycles=cycles,
                             samples=samples))
    out = os.path.join(tmp, "data")
    expect_success(mdrctl, ["synthesize", spec, "--out", out], "synthesize")
    return out


def case_loops_figures(args, tmp):
    m = args.mdrctl
    data = synthesize(m, tmp, H1_SCENE, "100", "3e-6, 1e-6", 3, 400)
    scene = write(os.path.join(tmp, "scene.yaml"), "scene:\n" + H1_SCENE)
    gross = os.path.join(data, "p100N_u3um.csv")
    out = expect_success(m, ["loops", gross, "--normal-force", "100", "--scene", scene,
                             "--time-column", "time", "--format", "csv"], "loops").stdout
    rows = csv_rows(out)
    check(len(rows) == 2, f"expected 2 complete cycles, got {len(rows)}:\n{out}")
    # Gross slip through the rig (2e-8 m/N, taken from the scene): Q* = mu P, the actuator's
    # amplitude U, the contact's U - C_t Q*, Ed = 4 mu P (U_c - 0.8 U_t) (a Hertz loop's onset
    # dissipates 4 mu P U_t / 5 and the sliding adds 4 mu P (U_c - U_t)).
    mu, p, u, ct = 0.3, 100.0, 3e-6, 2e-8
    onset = mu * KAPPA * H1_DEPTH
    contact = u - ct * mu * p
    energy = 4 * mu * p * (contact - 0.8 * onset)
    for row in rows:
        close(float(row["force_amplitude"]), mu * p, 1e-9, "Q*")
        close(float(row["friction_coefficient"]), mu, 1e-9, "mu")
        close(float(row["normal_force"]), p, 1e-12, "P")
        close(float(row["displacement_amplitude"]), u, 1e-9, "delta*")
        close(float(row["contact_displacement_amplitude"]), contact, 1e-9, "delta*_c")
        close(float(row["dissipated_energy"]), energy, 2e-4, "Ed (400 samples per cycle)")
        close(float(row["energy_ratio"]), float(row["dissipated_energy"]) / (4 * u * mu * p),
              1e-9, "A")
        check(row["regime"] == "gross|slip", f"regime {row['regime']!r}, expected gross slip")
        check(row["flags"] == "-", f"flags {row['flags']!r}")
    print(f"ok gross slip: Q* {rows[0]['force_amplitude']}, Ed {rows[0]['dissipated_energy']} "
          f"(closed form {energy:.10g})")
    partial = csv_rows(expect_success(
        m, ["loops", os.path.join(data, "p100N_u1um.csv"), "--normal-force", "100", "--scene",
            scene, "--format", "csv"], "loops, partial slip").stdout)
    for row in partial:
        check(row["regime"] == "partial|slip", f"regime {row['regime']!r}, expected partial slip")
        check(float(row["force_amplitude"]) < mu * p, "partial slip reached mu P")
    print("ok partial slip classified")
    # The same file with ';', in mm and kN, gives the same figures.
    with open(gross) as f:
        lines = f.read().splitlines()
    converted = ["# converted to mm and kN", "t;u_mm;q_kn"]
    for line in lines:
        if line.startswith("#") or line.startswith("time"):
            continue
        t, u_m, f_n = (float(x) for x in line.split(","))
        converted.append(f"{t!r};{u_m * 1e3!r};{f_n * 1e-3!r}")
    other = write(os.path.join(tmp, "converted.csv"), "\n".join(converted) + "\n")
    same = csv_rows(expect_success(
        m, ["loops", other, "--displacement-column", "u_mm", "--force-column", "q_kn",
            "--time-column", "t", "--displacement-unit", "mm", "--force-unit", "kN",
            "--normal-force", "100", "--scene", scene, "--format", "csv"], "loops, mm kN").stdout)
    for a, b in zip(rows, same):
        for key in ("force_amplitude", "dissipated_energy", "displacement_amplitude"):
            close(float(b[key]), float(a[key]), 1e-9, f"{key} in mm and kN")
    print("ok ';' separators, mm and kN")
    # A spreadsheet's export where the comma is the decimal separator (';' or tab between cells,
    # "1,5e-06" in them), and one that quotes every cell, give the same bits as the plain file.
    samples = [line.split(",") for line in lines if not line.startswith(("#", "time"))]
    variants = {
        "decimal_comma.csv": "time;displacement;tangential_force\n" + "".join(
            ";".join(cell.replace(".", ",") for cell in row) + "\n" for row in samples),
        "decimal_comma_tab.csv": "time\tdisplacement\ttangential_force\n" + "".join(
            "\t".join(cell.replace(".", ",") for cell in row) + "\n" for row in samples),
        "quoted.csv": '"time","displacement","tangential_force"\n' + "".join(
            ",".join(f' "{cell}" ' for cell in row) + "\n" for row in samples),
    }
    plain = expect_success(m, ["loops", gross, "--normal-force", "100", "--time-column", "time",
                               "--format", "csv"], "loops, plain").stdout
    for name, text in variants.items():
        check(text.count(",") >= len(samples), f"{name}: no decimal commas or quotes")
        out = expect_success(m, ["loops", write(os.path.join(tmp, name), text), "--normal-force",
                                 "100", "--time-column", "time", "--format", "csv"], name).stdout
        check(out == plain, f"{name} gives other figures than the plain file:\n{out}\n{plain}")
    print("ok decimal commas (';' and tab) and quoted cells read as the plain file")
    # The same samples in a MATLAB file (written here, not by matio): the same figures.
    columns = {name: [float(row[i]) for row in samples]
               for i, name in enumerate(("time", "displacement", "tangential_force"))}
    mat = os.path.join(tmp, "samples.mat")
    write_mat5(mat, columns)
    out = expect_success(m, ["loops", mat, "--normal-force", "100", "--time-column", "time",
                             "--format", "csv"], "loops, MAT file").stdout
    check(out == plain, f"the MAT file gives other figures than the CSV file:\n{out}\n{plain}")
    print("ok a MATLAB (v5) file of the samples reads as the CSV file")
    report = os.path.join(tmp, "report")
    expect_success(m, ["loops", gross, "--normal-force", "100", "--report", report], "report")
    document = json.load(open(os.path.join(report, "report.json")))
    check(len(document["set"]["analysis"]["cycles"]) == 2, "report.json has no cycles")
    check(document["set"]["synthetic"].startswith('"SYNTHETIC'), "report.json: not synthetic")
    text = open(os.path.join(report, "report.md")).read()
    check("Synthetic input" in text and "(contact+rig)" in text, "report.md lacks labels")
    check_pngs(report, ["loop.png", "cycles.png"], document)


def check_pngs(directory, names, document):
    if shutil.which("gnuplot") is None:
        check(document["plots_skipped"], "no plots and no reason")
        print("skipped the PNG checks: gnuplot is not installed")
        return
    check(document["plots"] == names, f"plots {document['plots']}, expected {names}")
    for name in names:
        with open(os.path.join(directory, name), "rb") as f:
            check(f.read(8) == b"\x89PNG\r\n\x1a\n", f"{name} is not a PNG")
    print(f"ok {', '.join(names)}")


# ---- fit ----

def small_campaign(mdrctl, tmp):
    data = synthesize(mdrctl, tmp, H1_SCENE.replace("friction: 0.3", "friction: 0.6"),
                      "50, 200", "1.5e-6, 8e-6", 3, 80)
    return os.path.join(data, "campaign.yaml")


def case_fit_recovers(args, tmp):
    m = args.mdrctl
    campaign = small_campaign(m, tmp)
    report = os.path.join(tmp, "report")
    result = expect_success(m, ["fit", campaign, "--report", report, "--format", "json"], "fit")
    check("fit iteration 1: residual RMS" in result.stderr, "no progress on stderr")
    fit = json.loads(result.stdout)
    truth = {"FIT_PARAMETER_FRICTION": 0.6, "FIT_PARAMETER_RIG_COMPLIANCE": 2e-8,
             "FIT_PARAMETER_EFFECTIVE_MODULUS": 210e9 / (2 * (1 - 0.3**2))}
    check(len(fit["estimates"]) == 3, "three estimates")
    for e in fit["estimates"]:
        close(e["value"], truth[e["parameter"]], 1e-6, e["parameter"])
        check(e["identified"], f"{e['parameter']} not identified")
    check(fit["converged"] and fit["identified"], "not converged / identified")
    print("ok recovered: " + ", ".join(f"{e['parameter']} {e['value']!r}"
                                       for e in fit["estimates"]))
    document = json.load(open(os.path.join(report, "report.json")))
    names = [e["parameter"] for e in document["estimates"]]
    check(names == ["friction", "effective_modulus", "rig_compliance"], f"estimates {names}")
    for e in document["estimates"]:
        check(e["truth_inside_95"] is not None and "truth" in e, "no truth check")
        close(e["value"], truth["FIT_PARAMETER_" + e["parameter"].upper()], 1e-6, e["parameter"])
    replay = document["replay"]
    check(abs(replay["residual_rms"] - replay["fit_residual_rms"]) <=
          1e-6 * replay["fit_residual_rms"] + 1e-12,
          f"the replay does not reproduce the fit's residuals: {replay}")
    check(len(document["sets"]) == 4 and all(s["synthetic"] for s in document["sets"]),
          "sets / synthetic")
    check(len(document["fretting_map"]["response"]["loads"]) == 2, "fretting map loads")
    text = open(os.path.join(report, "report.md")).read()
    for needle in ("Synthetic inputs", "| friction | 0.6", "identified", "Correlations",
                   "Condition number", "Rig compliance from the reversal slopes",
                   "(contact+rig)", "gross slip", "partial slip", "Fretting map"):
        check(needle in text, f"report.md lacks {needle!r}")
    check_pngs(report, ["loops.png", "residuals.png", "fretting_map.png",
                        "fretting_regimes.png"], document)


def case_fit_without_gnuplot(args, tmp):
    m = args.mdrctl
    campaign = small_campaign(m, tmp)
    report = os.path.join(tmp, "report")
    result = expect_success(m, ["fit", campaign, "--report", report], "fit without gnuplot",
                            env={"PATH": "/nonexistent"})
    check("plots skipped: gnuplot is not installed" in result.stderr, result.stderr)
    text = open(os.path.join(report, "report.md")).read()
    check("Plots were skipped: gnuplot is not installed" in text, "report.md does not say so")
    document = json.load(open(os.path.join(report, "report.json")))
    check(document["plots"] == [] and "gnuplot" in document["plots_skipped"], "report.json")
    check(not [f for f in os.listdir(report) if f.endswith(".png")], "PNGs without gnuplot")
    print("ok report.md and report.json without plots")


def case_campaign_errors(args, tmp):
    m = args.mdrctl
    campaign = small_campaign(m, tmp)
    original = open(campaign).read()

    def variant(name, old, new):
        check(old in original, f"{old!r} not in the campaign")
        return write(os.path.join(os.path.dirname(campaign), name), original.replace(old, new, 1))

    expect_failure(m, ["fit", variant("typo.yaml", "{parameter: friction", "{paramter: friction")],
                   r'^mdrctl: free\[0\]\.paramter: unknown key; the keys here are parameter, '
                   r'initial, lower, upper \(\S*typo\.yaml:\d+\)\n$', "an unknown key")
    expect_failure(m, ["fit", variant("name.yaml", "parameter: friction", "parameter: mu")],
                   r'^mdrctl: free\[0\]\.parameter: must be one of friction, effective_modulus, '
                   r'profile_scale, rig_compliance, displacement_offset, torsional_modulus, '
                   r'got "mu" '
                   r'\(\S*name\.yaml:\d+\)', "an unknown parameter")
    expect_failure(m, ["fit", variant("load.yaml", "normal_force: 50}", "normal_force: -5}")],
                   r'^mdrctl: sets\[0\]\.normal_force: must be > 0, got -5 \(\S*load\.yaml:\d+\)',
                   "a negative load")
    # The service's error names free[0].initial; mdrctl points at the campaign's line.
    expect_failure(m, ["fit", variant("initial.yaml", "initial: 0.45", "initial: 2")],
                   r'^mdrctl: free\[0\]\.initial: [^\n]*\(\S*initial\.yaml:\d+\)\n$',
                   "an initial value outside its bounds")
    escaped = write(os.path.join(os.path.dirname(campaign), "key.yaml"),
                    original + '"x\\x07y": 1\n')
    expect_failure(m, ["fit", escaped],
                   r'^mdrctl: unknown key "x\\x07y"; the keys here are title, [^\n]*\(\S*key\.yaml:\d+\)\n$',
                   "an unknown key with a control byte, escaped")
    spec = open(os.path.join(tmp, "spec.yaml")).read()
    expect_failure(m, ["synthesize", write(os.path.join(tmp, "s1.yaml"),
                                           spec.replace("samples_per_cycle: 80",
                                                        "samples_per_cycle: 81")),
                       "--out", os.path.join(tmp, "s1")],
                   r'^mdrctl: samples_per_cycle: must be a multiple of 4 [^\n]*\(\S*s1\.yaml:\d+\)',
                   "samples per cycle not a multiple of 4")
    expect_failure(m, ["synthesize", write(os.path.join(tmp, "s2.yaml"),
                                           spec.replace("initial: 0.45, ", "")),
                       "--out", os.path.join(tmp, "s2")],
                   r'^mdrctl: fit\.free\[0\]: needs an initial value in a synthesis spec',
                   "a synthesis spec's free parameter without an initial value")
    data = os.path.dirname(campaign)
    bad = os.path.join(data, "p50N_u1.5um.csv")
    lines = open(bad).read().splitlines()
    lines[10] = lines[10].rsplit(",", 1)[0] + ",oops"
    write(bad, "\n".join(lines) + "\n")
    expect_failure(m, ["fit", campaign],
                   r'^mdrctl: \S*p50N_u1\.5um\.csv:11: column "tangential_force": "oops" is not a '
                   r'finite number\n$', "a bad cell in a set's file")


# ---- example_reproduces ----

def numbers(value, path=""):
    """Every number in a JSON value by its path."""
    if isinstance(value, dict):
        for key, item in value.items():
            yield from numbers(item, f"{path}.{key}")
    elif isinstance(value, list):
        for i, item in enumerate(value):
            yield from numbers(item, f"{path}[{i}]")
    elif isinstance(value, (int, float)) and not isinstance(value, bool):
        yield path, float(value)


def case_example_reproduces(args, tmp):
    example = os.path.join(args.source_dir, "examples", "rig_campaign")
    out = os.path.join(tmp, "rig_campaign")
    result = subprocess.run(["bash", os.path.join(example, "run.sh"), out], capture_output=True,
                            text=True, env={**os.environ, "MDRCTL": args.mdrctl}, timeout=300)
    check(result.returncode == 0, f"run.sh failed:\n{result.stdout}\n{result.stderr}")
    committed = json.load(open(os.path.join(example, "report", "report.json")))
    rerun = json.load(open(os.path.join(out, "report", "report.json")))
    a, b = dict(numbers(committed)), dict(numbers(rerun))
    check(a.keys() == b.keys(), f"report.json keys differ: {set(a) ^ set(b)}")
    worst, where = 0.0, ""
    for key, value in a.items():
        scale = max(abs(value), abs(b[key]), 1e-300)
        difference = abs(value - b[key]) / scale
        if difference > worst:
            worst, where = difference, key
    # The fit is deterministic (each set's residuals and each Jacobian column are computed
    # independently of the thread that runs them); a tolerance covers other libm versions.
    check(worst <= 1e-6, f"report.json differs by {worst:.3g} (relative) at {where}")
    print(f"ok {len(a)} numbers of report.json reproduced; largest relative difference {worst:.3g}"
          + (f" at {where}" if worst else " (identical)"))
    for name in sorted(os.listdir(os.path.join(example, "data"))):
        same = open(os.path.join(example, "data", name)).read() == \
            open(os.path.join(out, "data", name)).read()
        check(same, f"data/{name} differs from the committed file")
    print("ok data/ reproduced byte for byte")
    for e in rerun["estimates"]:
        print(f"  {e['parameter']}: {e['value']:.8g} +- {e['standard_error']:.3g} "
              f"(truth {e.get('truth')}, inside the 95 % interval: {e.get('truth_inside_95')})")


def case_long_run(args, tmp):
    per_cycle, cycles = 500, 2000
    path = os.path.join(tmp, "long.csv")
    with open(path, "w") as f:
        f.write("displacement,tangential_force\n")
        for k in range(per_cycle * cycles + 1):
            phase = 2 * math.pi * k / per_cycle
            f.write(f"{1e-6 * math.sin(phase)!r},{15 * math.tanh(math.sin(phase - 0.3))!r}\n")
    rows = csv_rows(expect_success(args.mdrctl, ["loops", path, "--normal-force", "100",
                                                 "--format", "csv"], "loops, 10^6 samples").stdout)
    check(len(rows) == cycles - 1, f"expected {cycles - 1} cycles, got {len(rows)}")
    print(f"ok {per_cycle * cycles + 1} samples analysed on mdrctl's own server")
    server = subprocess.Popen([args.mdrd, "--listen", "127.0.0.1:0", "--no-journal"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        port = None
        for line in server.stdout:
            found = re.search(r"event=serving .*port=(\d+)", line)
            if found:
                port = found.group(1)
                break
        check(port is not None, "mdrd did not say where it listens")
        expect_failure(args.mdrctl, ["loops", "--server", f"127.0.0.1:{port}", path,
                                     "--normal-force", "100"],
                       r"^mdrctl: \S*long\.csv: the request of 160000\d\d bytes is larger than "
                       r"the server takes \(Received message larger than max \(160000\d\d vs\. "
                       r"4194304\)\): start mdrd with --max-message-bytes above it, or run mdrctl "
                       r"without --server\n$", "a request past mdrd's message limit")
    finally:
        server.terminate()
        server.wait(timeout=30)
    print("ok past mdrd's message limit: the file, its size and --max-message-bytes named")


# ---- runs ----

def data_rows(path):
    """The header and data lines of a CSV file (comments left out)."""
    lines = [line for line in open(path).read().splitlines() if not line.startswith("#")]
    return lines[0], lines[1:]


def multi_run_csv(path, runs):
    """One CSV file of several runs' files, a run column first: {id: file}."""
    out = []
    for run_id, file in runs.items():
        header, rows = data_rows(file)
        if not out:
            out.append("run," + header)
        out += [f"{run_id},{row}" for row in rows]
    return write(path, "\n".join(out) + "\n")


def without_run(rows):
    return [{k: v for k, v in r.items() if k != "run"} for r in rows]


def case_runs(args, tmp):
    m = args.mdrctl
    data = synthesize(m, tmp, H1_SCENE, "100", "3e-6, 1e-6", 3, 400)
    gross, partial = (os.path.join(data, f"p100N_u{a}um.csv") for a in ("3", "1"))
    common = ["--normal-force", "100", "--time-column", "time"]

    def loops(path, *extra, fmt="csv"):
        return expect_success(m, ["loops", path, *common, *extra, "--format", fmt],
                              f"loops {os.path.basename(path)} {' '.join(extra)}").stdout

    alone = {"gross": csv_rows(loops(gross)), "partial": csv_rows(loops(partial))}
    both = multi_run_csv(os.path.join(tmp, "both.csv"), {'"gross"': gross, " partial ": partial})
    rows = csv_rows(loops(both, "--run-column", "run"))
    check([r["run"] for r in rows] == ["gross"] * len(alone["gross"]) +
          ["partial"] * len(alone["partial"]), f"runs {[r['run'] for r in rows]}")
    for run_id, expected in alone.items():
        got = without_run(r for r in rows if r["run"] == run_id)
        check(got == expected, f"run {run_id}: other figures than its own file:\n{got}\n{expected}")
    print(f"ok a CSV file of two runs: each run's {len(alone['gross'])} cycles as its own file's")
    selected = csv_rows(loops(both, "--run-column", "run", "--run", "partial"))
    check(without_run(selected) == alone["partial"], "--run partial")
    document = json.loads(loops(both, "--run-column", "run", fmt="json"))
    check([r["run"] for r in document["runs"]] == ["gross", "partial"], "JSON runs")
    header, gross_rows = data_rows(gross)
    first = document["runs"][0]
    check(first["first_line"] == 2 and first["last_line"] == 1 + len(gross_rows) and
          first["samples"] == len(gross_rows), f"JSON run: {first}")
    single = json.loads(loops(gross, fmt="json"))
    check(first["analysis"]["cycles"] == single["cycles"], "JSON cycles of a run")
    table = loops(both, "--run-column", "run", fmt="table")
    check(f'run "gross": {len(gross_rows)} samples, lines 2 to {1 + len(gross_rows)}' in table
          and 'run "partial"' in table, table)
    print("ok --run, the JSON and the table say each result's run")
    # The same runs in a MATLAB file, the run variable numbered.
    columns = {"run": [], "time": [], "displacement": [], "tangential_force": []}
    for number, file in ((1, gross), (2, partial)):
        for row in data_rows(file)[1]:
            values = [number] + [float(x) for x in row.split(",")]
            for name, value in zip(columns, values):
                columns[name].append(value)
    mat = os.path.join(tmp, "both.mat")
    write_mat5(mat, columns)
    mat_rows = csv_rows(loops(mat, "--run-column", "run"))
    check([{**r, "run": {"1": "gross", "2": "partial"}[r["run"]]} for r in mat_rows] == rows,
          "the MAT file's runs give other figures than the CSV file's")
    print("ok a MAT file of two runs, numbered, reads as the CSV file")
    report = os.path.join(tmp, "report")
    expect_success(m, ["loops", both, *common, "--run-column", "run", "--report", report],
                   "loops --report of two runs")
    document = json.load(open(os.path.join(report, "report.json")))
    check(document["run_column"] == "run" and
          [r["run"] for r in document["runs"]] == ["gross", "partial"], "report.json runs")
    text = open(os.path.join(report, "report.md")).read()
    check('## Run `"gross"`' in text and '## Run `"partial"`' in text, "report.md runs")
    check_pngs(report, ["run1_loop.png", "run1_cycles.png", "run2_loop.png", "run2_cycles.png"],
               document)

    # The refusals.
    expect_failure(m, ["loops", both, "--run-column", "run", "--run", "slip\x1b"],
                   r'^mdrctl: \S*both\.csv: no run "slip\\x1B" in column "run"; its runs are '
                   r'"gross", "partial"\n$', "a missing run")
    expect_failure(m, ["loops", mat, "--run-column", "run", "--run", "3"],
                   r'^mdrctl: \S*both\.mat: no run "3" in variable "run"; its runs are "1", "2"\n$',
                   "a missing run of a MAT file")
    lines = [f"{r},{row}\n" for r, row in zip("aba", gross_rows)]
    interleaved = write(os.path.join(tmp, "interleaved.csv"), f"run,{header}\n" + "".join(lines))
    expect_failure(m, ["loops", interleaved, "--run-column", "run"],
                   r'^mdrctl: \S*interleaved\.csv:4: column "run": run "a" appears again after '
                   r'run "b" \(its rows ended at line 2\): the rows of a run must be contiguous',
                   "an interleaved run")
    empty = write(os.path.join(tmp, "empty_run.csv"),
                  f"run,{header}\na,{gross_rows[0]}\n ,{gross_rows[1]}\n")
    expect_failure(m, ["loops", empty, "--run-column", "run"],
                   r'^mdrctl: \S*empty_run\.csv:3: column "run": the cell is empty: every row '
                   r"needs its run's id\n$", "an empty run cell")
    expect_failure(m, ["loops", gross, "--run", "a"],
                   r"^mdrctl: --run: needs --run-column, the column of the runs' ids\n$",
                   "--run without --run-column")

    # A campaign whose sets are runs of one file fits as the campaign of separate files.
    os.makedirs(os.path.join(tmp, "fit"))
    campaign = small_campaign(m, os.path.join(tmp, "fit"))
    original = open(campaign).read()
    files = re.findall(r"\{file: (\S+), normal_force: (\S+)\}", original)
    check(len(files) == 4, f"sets {files}")
    directory = os.path.dirname(campaign)
    multi_run_csv(os.path.join(directory, "all.csv"),
                  {f"r{k}": os.path.join(directory, f) for k, (f, _) in enumerate(files)})
    merged = original.replace("time: time}", "time: time, run: run}")
    for k, (f, load) in enumerate(files):
        merged = merged.replace(f"{{file: {f}, normal_force: {load}}}",
                                f"{{file: all.csv, run: r{k}, normal_force: {load}}}")
    check(merged.count("all.csv") == 4 and "run: run}" in merged, merged)
    runs_campaign = write(os.path.join(directory, "runs.yaml"), merged)
    separate = json.loads(expect_success(m, ["fit", campaign, "--format", "json"],
                                         "fit of separate files").stdout)
    runs_report = os.path.join(tmp, "runs_report")
    as_runs = json.loads(expect_success(m, ["fit", runs_campaign, "--format", "json", "--report",
                                            runs_report], "fit of runs").stdout)
    check(separate["estimates"] == as_runs["estimates"],
          f"the runs fit otherwise than the files: {separate['estimates']} vs "
          f"{as_runs['estimates']}")
    document = json.load(open(os.path.join(runs_report, "report.json")))
    check([s["run"] for s in document["sets"]] == ["r0", "r1", "r2", "r3"], "report.json sets")
    check('all.csv run "r2"' in open(os.path.join(runs_report, "report.md")).read(),
          "report.md names the sets' runs")
    print("ok a campaign of four runs of one file fits as its four files")
    expect_failure(m, ["fit", write(os.path.join(directory, "no_run.yaml"),
                                    merged.replace("all.csv, run: r1, ", "all.csv, "))],
                   r'^mdrctl: sets\[1\]: its file \S*all\.csv holds 4 runs in column "run" '
                   r'\("r0", "r1", "r2", "r3"\): choose one with run: ID '
                   r'\(\S*no_run\.yaml:\d+\)\n$', "a set without its run")
    expect_failure(m, ["fit", write(os.path.join(directory, "bad_run.yaml"),
                                    merged.replace("run: r1,", "run: r9,"))],
                   r'^mdrctl: \S*all\.csv: no run "r9" in column "run"; its runs are "r0", "r1", '
                   r'"r2", "r3" \(\S*bad_run\.yaml:\d+\)\n$', "a campaign's missing run")
    expect_failure(m, ["fit", write(os.path.join(directory, "no_column.yaml"),
                                    merged.replace(", run: run}", "}"))],
                   r'^mdrctl: sets\[0\]\.run: needs a run column to find it in: columns: '
                   r'\{run: NAME\}, [^\n]*\(\S*no_column\.yaml:\d+\)\n$', "a run without a column")


# ---- cut_last_line ----

def case_cut_last_line(args, tmp):
    m = args.mdrctl
    rows = "".join(f"{1e-6 * math.sin(k * math.pi / 20)!r},{10 * math.sin(k * math.pi / 20 - 0.3)!r}\n"
                   for k in range(120))
    header = "displacement,tangential_force\n"
    whole = write(os.path.join(tmp, "whole.csv"), header + rows + "0,20.0\n")
    expect_success(m, ["loops", whole, "--normal-force", "100"], "a whole file")
    cut = write(os.path.join(tmp, "cut.csv"), header + rows + "0,2")
    expect_failure(m, ["loops", cut, "--normal-force", "100"],
                   r"^mdrctl: \S*cut\.csv:122: the last line has no line end: the file may be cut "
                   r"short \(a rig still writing it\?\), its last cell cut with it; if the file is "
                   r"complete, end its last line with a line end\n$", "a last line cut short")
    crlf_cut = write(os.path.join(tmp, "cut_crlf.csv"),
                     (header + rows).replace("\n", "\r\n") + "0,20.0\r")
    expect_failure(m, ["loops", crlf_cut, "--normal-force", "100"],
                   r"^mdrctl: \S*cut_crlf\.csv:122: the last line has no line end",
                   "a CRLF file cut after its last '\\r'")


# ---- json_fields ----

def case_json_fields(args, tmp):
    m = args.mdrctl
    campaign = small_campaign(m, tmp)
    out = expect_success(m, ["loops", os.path.join(os.path.dirname(campaign), "p200N_u8um.csv"),
                             "--normal-force", "200", "--format", "json"],
                         "loops --format json").stdout
    document = json.loads(out)
    check(document.get("friction_drifts") is False,
          f"friction_drifts: {document.get('friction_drifts')}")
    check(document["reversals"] and all(type(r) is int for r in document["reversals"]),
          f"reversals as numbers: {document['reversals']}")
    cycle = document["cycles"][0]
    for key in ("first_sample", "last_sample", "lower_reversal"):
        check(type(cycle[key]) is int, f"{key}: {cycle[key]!r} is not a JSON number")
    flags = cycle["flags"]
    check(flags["not_closed"] is False and flags["hooked"] is False and
          flags["asymmetric"] is False, f"flags without their false fields: {flags}")
    check(cycle["regime"] == "REGIME_UNSPECIFIED" and cycle["onset_system_free_ratio"] == 0,
          f"unset regime and onset not printed: {cycle}")
    print(f"ok loops JSON: false and zero fields present, indices as numbers "
          f"({cycle['first_sample']}, {cycle['lower_reversal']}, {cycle['last_sample']})")
    report = os.path.join(tmp, "report")
    expect_success(m, ["fit", campaign, "--report", report, "--format", "json"], "fit")
    document = json.load(open(os.path.join(report, "report.json")))
    fit = document["fit"]
    check(type(fit["residuals"]) is int and fit["residuals"] > 0, f"residuals {fit['residuals']!r}")
    analysis = document["sets"][0]["analysis"]
    check(type(analysis["cycles"][0]["first_sample"]) is int and
          analysis["friction_drifts"] is False, "report.json's analysis")
    check(document["request"]["reversal_threshold"] == 0 and
          document["request"]["max_iterations"] == 0, "report.json's request: zero fields")
    print("ok report.json: every field, residuals and indices as numbers")


CASES = {
    "runs": case_runs,
    "cut_last_line": case_cut_last_line,
    "json_fields": case_json_fields,
    "long_run": case_long_run,
    "csv_errors": case_csv_errors,
    "loops_figures": case_loops_figures,
    "fit_recovers": case_fit_recovers,
    "fit_without_gnuplot": case_fit_without_gnuplot,
    "campaign_errors": case_campaign_errors,
    "example_reproduces": case_example_reproduces,
}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--mdrctl", required=True)
    parser.add_argument("--mdrd", required=True)
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("case", choices=sorted(CASES))
    args = parser.parse_args()
    args.mdrctl = os.path.abspath(args.mdrctl)
    with tempfile.TemporaryDirectory(prefix="mdrctl-rig-") as tmp:
        try:
            CASES[args.case](args, tmp)
        except Failure as failure:
            print(f"FAILED {args.case}: {failure}")
            return 1
    print(f"passed {args.case}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

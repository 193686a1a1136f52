#!/usr/bin/env python3
"""Write docs/validation.md: bellyflop against the CasADi+IPOPT reference and the paper.

Runs `bellyflop sweep --json` (default formulation, PCHIP re-propagation) and
bench/reference/nlp_reference.py for P1 and P2 at each N, then writes a Markdown
report. Standard library only; normally started by bench/validation.sh with the
reference venv's python (the reference itself needs CasADi and SciPy).

Any failed run (non-zero exit, unparsable output, a status other than solved /
Solve_Succeeded) stops the script with a non-zero exit code and no report is
written. Missed targets do not change the exit code; they are reported as FAIL.
"""

import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The paper's published numbers (Chen et al., Mathematics 2023, 11, 288).
# Table 3 (N = 20, SCvx): t_f and final mass.
PAPER_TABLE3 = {20: {"tf_s": 11.5666, "final_mass_kg": 114568.6}}
# Tables 4-5: landing precision (position m, velocity m/s).
PAPER_SCVX = {15: (1.1597, 0.29861), 20: (0.77127, 0.30135), 30: (0.7097, 0.23689)}
PAPER_GPOPS = {15: (1.1636, 0.39594), 20: (0.62173, 0.33001), 30: (0.42617, 0.1531)}
# Table 2 (N = 40): GPOPS-II landing precision for P1 and P2.
PAPER_TABLE2 = {40: {"P1": (2.8273, 0.42003), "P2": (0.42707, 0.099739)}}
# Table 3: GPOPS-II's t_f and final mass (N = 20).
PAPER_GPOPS_TABLE3 = {"tf_s": 11.5666, "final_mass_kg": 114580.7}

MASS_TOL_PCT = 0.05
TF_TOL_PCT = 1.0
LANDING_TARGETS = {
    # N: (position m, velocity m/s, source)
    30: (0.7097, 0.23689, "paper SCvx, Tables 4-5"),
    20: (1.0, 0.35, "issue 3"),
}


class RunFailed(Exception):
    pass


def run(cmd):
    """Run cmd from the repository root, return its stdout parsed as JSON."""
    print("+ " + " ".join(cmd), file=sys.stderr, flush=True)
    proc = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        raise RunFailed(
            "command failed with exit code %d: %s\n--- stderr ---\n%s\n--- stdout ---\n%s"
            % (proc.returncode, " ".join(cmd), proc.stderr[-4000:], proc.stdout[-2000:])
        )
    try:
        return json.loads(proc.stdout)
    except json.JSONDecodeError as e:
        raise RunFailed("command printed invalid JSON (%s): %s\n%s" % (e, " ".join(cmd), proc.stdout[-2000:]))


def need(obj, key, what):
    if key not in obj or obj[key] is None:
        raise RunFailed("%s: missing field %r" % (what, key))
    return obj[key]


def run_ours(binary, nodes, scenario, repeat):
    """`repeat` sweeps; the numbers must agree, the solve time is the median."""
    cmd = [binary, "sweep", "--nodes", ",".join(map(str, nodes)), "--json"]
    if scenario:
        cmd += ["--scenario", scenario]
    sweeps = [run(cmd) for _ in range(repeat)]
    first = sweeps[0]
    out = {}
    for n in nodes:
        per = []
        for s in sweeps:
            match = [r for r in need(s, "runs", "sweep") if r.get("nodes") == n]
            if len(match) != 1:
                raise RunFailed("sweep output has %d runs for N = %d" % (len(match), n))
            r = match[0]
            if r.get("status") != "solved":
                raise RunFailed("bellyflop N = %d: status %r, message %r" % (n, r.get("status"), r.get("message")))
            per.append(r)
        r = per[0]
        for other in per[1:]:
            if abs(other["final_mass_kg"] - r["final_mass_kg"]) > 1e-6 * r["final_mass_kg"]:
                raise RunFailed("bellyflop N = %d: final mass differs between repeated sweeps" % n)
        le = need(r, "landing_error", "bellyflop N = %d" % n)
        out[n] = {
            "tf_s": need(r, "tf_s", "bellyflop"),
            "final_mass_kg": need(r, "final_mass_kg", "bellyflop"),
            "pos_m": need(le, "position_m", "bellyflop landing_error"),
            "vel_mps": need(le, "velocity_mps", "bellyflop landing_error"),
            "time_ms": statistics.median(p["solve_time_ms"] for p in per),
            "iterations": need(r, "iterations", "bellyflop"),
        }
    meta = {"formulation": first.get("formulation"), "interpolation": first.get("interpolation"),
            "scenario": first.get("scenario")}
    return out, meta, cmd


def run_reference(python, n, problem, scenario, repeat):
    cmd = [python, "bench/reference/nlp_reference.py", "--scenario", scenario,
           "--nodes", str(n), "--problem", problem, "--repeat", str(repeat), "--json"]
    r = run(cmd)
    what = "reference %s N = %d" % (problem, n)
    if not r.get("success") or r.get("status") != "Solve_Succeeded":
        raise RunFailed("%s: IPOPT status %r" % (what, r.get("status")))
    le = need(r, "landing_error", what)
    return {
        "tf_s": need(r, "tf_s", what),
        "final_mass_kg": need(r, "final_mass_kg", what),
        "pos_m": need(le, "position_m", what),
        "vel_mps": need(le, "velocity_mps", what),
        "time_ms": need(r, "solve_time_ms", what),
        "iterations": need(r, "ipopt_iterations", what),
    }


def run_refined(binary, scenario, tolerance, repeat, python):
    """Ours refined to `tolerance`, then IPOPT on exactly the mesh it reached
    (`--layout-json`), P2 with the ground bound as ours."""
    cmd = [binary, "solve", "--json", "--mesh-tolerance", "%g" % tolerance, "--repeat", str(repeat)]
    if scenario:
        cmd += ["--scenario", scenario]
    r = run(cmd)
    if r.get("status") != "solved":
        raise RunFailed("bellyflop refined: status %r, message %r" % (r.get("status"), r.get("message")))
    le = need(r, "landing_error", "bellyflop refined")
    ref = need(r, "refinement", "bellyflop refined")
    ours = {
        "tf_s": need(r, "tf_s", "bellyflop refined"),
        "final_mass_kg": need(r, "final_mass_kg", "bellyflop refined"),
        "pos_m": need(le, "position_m", "bellyflop refined landing_error"),
        "vel_mps": need(le, "velocity_mps", "bellyflop refined landing_error"),
        "time_ms": need(r, "solve_time_ms", "bellyflop refined"),
        "iterations": need(r, "iterations", "bellyflop refined"),
        "nodes": need(r, "nodes", "bellyflop refined"),
        "layout": need(r, "mesh_layout", "bellyflop refined"),
        "passes": need(ref, "passes", "bellyflop refinement"),
        "stop": need(ref, "stop", "bellyflop refinement"),
        "controls": (r.get("propagation") or {}).get("controls"),
    }
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as fh:
        json.dump(r, fh)
        layout_path = fh.name
    try:
        rcmd = [python, "bench/reference/nlp_reference.py", "--scenario", scenario, "--layout-json", layout_path,
                "--problem", "P2", "--ground", "--repeat", str(repeat), "--json"]
        x = run(rcmd)
    finally:
        os.unlink(layout_path)
    what = "reference P2 on the refined mesh"
    if not x.get("success") or x.get("status") != "Solve_Succeeded":
        raise RunFailed("%s: IPOPT status %r" % (what, x.get("status")))
    xle = need(x, "landing_error", what)
    reference = {
        "tf_s": need(x, "tf_s", what),
        "final_mass_kg": need(x, "final_mass_kg", what),
        "pos_m": need(xle, "position_m", what),
        "vel_mps": need(xle, "velocity_mps", what),
        "time_ms": need(x, "solve_time_ms", what),
        "iterations": need(x, "ipopt_iterations", what),
    }
    return ours, reference, cmd


def refined_section(ours, reference, cmd, tolerance):
    """Issue 16: the refined mesh against IPOPT on it and GPOPS-II's figures."""
    L = ["## Refined mesh (issue 16)", ""]
    L.append("Ours: `%s`; the reference: the same P2 with the ground bound, on the mesh ours refined to "
             "(`nlp_reference.py --layout-json`). GPOPS-II: the paper's Table 3 (t_f, m_f; its mesh is "
             "not published) and Tables 4–5 (landing precision at N = 20) and Table 2 (P2 at N = 40)."
             % " ".join([os.path.relpath(cmd[0], ROOT)] + cmd[1:]))
    L.append("")
    lay = ours["layout"]
    L.append("Refined: %d passes (%s), N = %d over %d intervals (%s points), breaks at t = %s s."
             % (len(ours["passes"]), ours["stop"], ours["nodes"], len(lay["points"]),
                "+".join(str(p) for p in lay["points"]),
                ", ".join("%.3f" % (0.5 * (b + 1.0) * ours["tf_s"]) for b in lay["breaks_tau"][1:-1])))
    L.append("")
    L.append("| pass | N | intervals | iterations | time [ms] | m_f [kg] | largest interval error |")
    L.append("|---:|---:|---:|---:|---:|---:|---:|")
    for p in ours["passes"]:
        L.append("| %d | %d | %d | %d | %.1f | %.2f | %.1e |" % (
            p["pass"], p["nodes"], len(p["mesh"]["points"]), p["iterations"], p["solve_time_ms"],
            p["final_mass_kg"], p["max_relative_error"]))
    L.append("")
    L.append("| | t_f [s] | m_f [kg] | landing position [m] | landing velocity [m/s] | iterations | time [ms] |")
    L.append("|---|---:|---:|---:|---:|---:|---:|")
    L.append("| bellyflop, refined to %g | %.4f | %.1f | %.4g | %.4g | %d | %.1f |" % (
        tolerance, ours["tf_s"], ours["final_mass_kg"], ours["pos_m"], ours["vel_mps"], ours["iterations"],
        ours["time_ms"]))
    L.append("| IPOPT on the same mesh | %.4f | %.1f | %.4g | %.4g | %d | %.1f |" % (
        reference["tf_s"], reference["final_mass_kg"], reference["pos_m"], reference["vel_mps"],
        reference["iterations"], reference["time_ms"]))
    L.append("| GPOPS-II, paper (N = 20) | %.4f | %.1f | %.5g | %.5g | — | — |" % (
        PAPER_GPOPS_TABLE3["tf_s"], PAPER_GPOPS_TABLE3["final_mass_kg"], PAPER_GPOPS[20][0], PAPER_GPOPS[20][1]))
    L.append("| GPOPS-II, paper (P2, N = 40) | — | — | %.5g | %.5g | — | — |" % PAPER_TABLE2[40]["P2"])
    L.append("")
    L.append("Ours re-integrates its refined controls with `%s` (the collocation's own controls as they can be "
             "flown, interval by interval: held on a bound over each point's quadrature cell, bang-bang inside the "
             "cell of a switch, the polynomial through each run of interior points; `control_profile.rs`); the "
             "reference re-integrates its own answer with linear interpolation through the nodes, so its landing "
             "columns measure that interpolation as much as the solution (the two optima agree to the kilogram's "
             "fraction above). Our time counts every pass and its error estimate; the reference's is one solve on "
             "the final mesh." % ours["controls"])
    L.append("")
    return L


def machine():
    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    try:
        nproc = subprocess.run(["nproc"], stdout=subprocess.PIPE, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        nproc = str(os.cpu_count())
    return nproc, cpu


def git_state():
    try:
        head = subprocess.run(["git", "rev-parse", "--short=12", "HEAD"], cwd=ROOT, stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "crates"],
                               cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                               check=True).stdout.strip()
        return head + (" (with uncommitted changes under crates/)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def rel_pct(a, b):
    return 100.0 * (a - b) / b


def pct(x):
    """A signed percentage; small values in scientific notation so they do not print as zero."""
    return "0" if x == 0 else (format(x, "+.4f") if abs(x) >= 1e-3 else format(x, "+.1e"))


def f(x, fmt):
    return "—" if x is None else format(x, fmt)


def per_n_table(n, ours, p2, p1):
    cols = ["bellyflop (SCvx)", "reference P2", "reference P1"]
    vals = [ours, p2, p1]
    if n in PAPER_TABLE3 or n in PAPER_SCVX:
        cols.append("paper SCvx")
        t3 = PAPER_TABLE3.get(n, {})
        sc = PAPER_SCVX.get(n)
        vals.append({"tf_s": t3.get("tf_s"), "final_mass_kg": t3.get("final_mass_kg"),
                     "pos_m": sc[0] if sc else None, "vel_mps": sc[1] if sc else None})
    if n in PAPER_GPOPS:
        cols.append("paper GPOPS-II")
        vals.append({"pos_m": PAPER_GPOPS[n][0], "vel_mps": PAPER_GPOPS[n][1]})
    if n in PAPER_TABLE2:
        for p in ("P2", "P1"):
            cols.append("paper GPOPS-II %s" % p)
            vals.append({"pos_m": PAPER_TABLE2[n][p][0], "vel_mps": PAPER_TABLE2[n][p][1]})
    rows = [
        ("t_f [s]", "tf_s", ".4f"),
        ("final mass [kg]", "final_mass_kg", ".1f"),
        ("landing position error [m]", "pos_m", ".5g"),
        ("landing velocity error [m/s]", "vel_mps", ".5g"),
        ("solve time [ms]", "time_ms", ".0f"),
        ("iterations", "iterations", "d"),
    ]
    lines = ["| N = %d | " % n + " | ".join(cols) + " |", "|---" + "|---:" * len(cols) + "|"]
    for label, key, fmt in rows:
        lines.append("| %s | " % label + " | ".join(f(v.get(key), fmt) for v in vals) + " |")
    p2m, p2t = p2["final_mass_kg"], p2["tf_s"]
    lines.append("| final mass vs reference P2 [%] | " + " | ".join(
        "—" if v.get("final_mass_kg") is None else pct(rel_pct(v["final_mass_kg"], p2m))
        for v in vals) + " |")
    lines.append("| t_f vs reference P2 [%] | " + " | ".join(
        "—" if v.get("tf_s") is None else pct(rel_pct(v["tf_s"], p2t)) for v in vals) + " |")
    return "\n".join(lines)


def targets(nodes, ours, ref):
    rows = []  # (target, measured, verdict)
    for n in nodes:
        d = rel_pct(ours[n]["final_mass_kg"], ref[n]["P2"]["final_mass_kg"])
        rows.append(("N = %d: final mass within %.2f%% of reference P2" % (n, MASS_TOL_PCT),
                     pct(d) + "%", abs(d) <= MASS_TOL_PCT))
    for n in nodes:
        d = rel_pct(ours[n]["tf_s"], ref[n]["P2"]["tf_s"])
        rows.append(("N = %d: t_f within %g%% of reference P2" % (n, TF_TOL_PCT),
                     pct(d) + "%", abs(d) <= TF_TOL_PCT))
    for n, (pos, vel, src) in sorted(LANDING_TARGETS.items(), reverse=True):
        if n not in ours:
            rows.append(("N = %d: landing position ≤ %g m (%s)" % (n, pos, src), "not run", False))
            rows.append(("N = %d: landing velocity ≤ %g m/s (%s)" % (n, vel, src), "not run", False))
            continue
        rows.append(("N = %d: landing position ≤ %g m (%s)" % (n, pos, src),
                     "%.5g m" % ours[n]["pos_m"], ours[n]["pos_m"] <= pos))
        rows.append(("N = %d: landing velocity ≤ %g m/s (%s)" % (n, vel, src),
                     "%.5g m/s" % ours[n]["vel_mps"], ours[n]["vel_mps"] <= vel))
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", default="15,20,30,40", help="comma-separated N (default 15,20,30,40)")
    ap.add_argument("--repeat", type=int, default=5,
                    help="solves per case; the median solve time is reported (default 5)")
    ap.add_argument("--scenario", default="scenarios/paper.toml", help="scenario TOML (default the paper's)")
    ap.add_argument("--bellyflop", default="target/release/bellyflop", help="bellyflop binary")
    ap.add_argument("--out", default="docs/validation.md", help="report path (default docs/validation.md)")
    ap.add_argument("--command", default=None, help="command line to name in the report")
    ap.add_argument("--mesh-tolerance", type=float, default=1e-6,
                    help="tolerance of the refined-mesh section (default 1e-6)")
    args = ap.parse_args()

    nodes = [int(x) for x in args.nodes.split(",") if x.strip()]
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    command = args.command or "bench/validation_report.py " + " ".join(sys.argv[1:])
    binary = args.bellyflop if os.path.isabs(args.bellyflop) else os.path.join(ROOT, args.bellyflop)
    if not os.access(binary, os.X_OK):
        raise RunFailed("no bellyflop binary at %s (run cargo build --release)" % binary)

    started = datetime.datetime.now(datetime.timezone.utc)
    ours, meta, our_cmd = run_ours(binary, nodes, args.scenario, args.repeat)
    ref = {n: {p: run_reference(sys.executable, n, p, args.scenario, args.repeat) for p in ("P2", "P1")}
           for n in nodes}
    refined, refined_ref, refined_cmd = run_refined(binary, args.scenario, args.mesh_tolerance, args.repeat,
                                                    sys.executable)
    nproc, cpu = machine()
    checks = targets(nodes, ours, ref)

    L = []
    L.append("# Validation: bellyflop against an NLP reference and the paper")
    L.append("")
    L.append("Generated by `%s` (from the repository root). Do not edit by hand; rerun the command." % command)
    L.append("")
    L.append("- Date: %s" % started.strftime("%Y-%m-%d %H:%M UTC"))
    L.append("- Machine: %s CPUs (`nproc`), CPU model `%s` (/proc/cpuinfo), %s %s"
             % (nproc, cpu, platform.system(), platform.machine()))
    L.append("- Source: git %s" % git_state())
    L.append("- Ours: `%s` (formulation `%s`, landing error re-propagated with `%s` control interpolation)"
             % (" ".join([os.path.relpath(our_cmd[0], ROOT)] + our_cmd[1:]), meta["formulation"],
                meta["interpolation"]))
    L.append("- Reference: `bench/reference/nlp_reference.py --scenario %s --nodes N --problem P1|P2 "
             "--repeat %d --json` (CasADi + IPOPT, versions pinned in `bench/reference/requirements.txt`)"
             % (args.scenario, args.repeat))
    L.append("")
    L.append("The machine is shared, so solve times are indicative only (benchmarking is issue 5). "
             "Times are the median of %d solves: for ours, `solve_time_ms` over %d runs of the sweep; "
             "for the reference, IPOPT's solve call alone (graph build excluded)." % (args.repeat, args.repeat))
    L.append("")
    L.append("## Targets (issue 3)")
    L.append("")
    L.append("| target | measured | result |")
    L.append("|---|---:|---|")
    for name, meas, ok in checks:
        L.append("| %s | %s | %s |" % (name, meas, "pass" if ok else "FAIL"))
    npass = sum(1 for c in checks if c[2])
    L.append("")
    L.append("%d of %d targets pass." % (npass, len(checks)))
    L.append("")
    L.append("## Summary")
    L.append("")
    L.append("| N | t_f ours [s] | t_f P2 [s] | t_f P1 [s] | Δt_f vs P2 | m_f ours [kg] | m_f P2 [kg] | m_f P1 [kg] "
             "| Δm_f vs P2 | pos err ours / P2 / P1 [m] | vel err ours / P2 / P1 [m/s] |")
    L.append("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in nodes:
        o, p2, p1 = ours[n], ref[n]["P2"], ref[n]["P1"]
        L.append("| %d | %.4f | %.4f | %.4f | %s%% | %.1f | %.1f | %.1f | %s%% | %.4g / %.4g / %.4g | %.4g / %.4g / %.4g |"
                 % (n, o["tf_s"], p2["tf_s"], p1["tf_s"], pct(rel_pct(o["tf_s"], p2["tf_s"])),
                    o["final_mass_kg"], p2["final_mass_kg"], p1["final_mass_kg"],
                    pct(rel_pct(o["final_mass_kg"], p2["final_mass_kg"])),
                    o["pos_m"], p2["pos_m"], p1["pos_m"], o["vel_mps"], p2["vel_mps"], p1["vel_mps"]))
    L.append("")
    L.append("## Side by side for each N")
    L.append("")
    L.append("Iterations are SCvx iterations for bellyflop and IPOPT iterations for the reference; they are not "
             "comparable counts. A dash means the paper gives no number for that cell.")
    L.append("")
    for n in nodes:
        L.append(per_n_table(n, ours[n], ref[n]["P2"], ref[n]["P1"]))
        L.append("")
    L.extend(refined_section(refined, refined_ref, refined_cmd, args.mesh_tolerance))
    L.append("## Notes")
    L.append("")
    L.append("- Landing error is ‖(x, z)(t_f)‖ and ‖(V_x, V_z)(t_f)‖ after integrating the nonlinear model "
             "from the initial state with the solution's controls (DOP853, tolerance 1e-10). Ours interpolates "
             "the controls with `%s`; the reference uses its own re-integration with linear interpolation "
             "(for P2 it interpolates the δ state), so the landing errors of ours and of the reference measure both "
             "the solution and the interpolation of its controls." % meta["interpolation"])
    L.append("- Paper numbers: Table 3 (N = 20, SCvx: t_f 11.5666 s, m_f 114568.6 kg); Tables 4–5 (landing "
             "precision, SCvx and GPOPS-II at N = 15, 20, 30); Table 2 (N = 40, GPOPS-II P1 and P2). The paper "
             "does not publish t_f or final mass at the other N.")
    L.append("- Relative differences are 100 × (value − reference P2) / reference P2, in percent. P2 is the "
             "reference optimum of the nozzle-rate-augmented problem that our SCvx formulation convexifies; "
             "P1 (no nozzle-rate state) is a different problem, so its t_f and final mass are not expected to equal P2's.")
    L.append("")

    out = args.out if os.path.isabs(args.out) else os.path.join(ROOT, args.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    tmp = out + ".tmp"
    with open(tmp, "w") as fh:
        fh.write("\n".join(L))
    os.replace(tmp, out)
    print("wrote %s (%d of %d targets pass)" % (os.path.relpath(out, ROOT), npass, len(checks)), file=sys.stderr)


if __name__ == "__main__":
    try:
        main()
    except RunFailed as e:
        print("validation_report.py: FAILED: %s" % e, file=sys.stderr)
        sys.exit(1)

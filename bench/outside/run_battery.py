#!/usr/bin/env python3
"""Outside battery: runs made by generate.py (written from the specs alone)
fed to `ttp diagnose`, scored against the outcome they call for.

Usage: run_battery.py [--ttp build/app/ttp] [--seed 20261125] [--reps 2]
                      [--spacings 300,1800,3600,7200] [--json results.json]
                      [--only EFFECTS] [--no-clouds] [--more-outside REPS]
                      [--rtest-noise-scale 1] [--machine-gain-scale 1]
       run_battery.py --check [--ttp ...]   (the small fixed set of the ctest)

Right outcome: the cause named for a catalogue effect, `none` for a run
without an effect, `unexplained` for an effect outside the catalogue,
`refused` for a mismatched log/piece pair. A false name is a cause named in
a run without a catalogue cause. Python 3 standard library only.
"""
import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time

sys.dont_write_bytecode = True  # nothing written into the source tree
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate  # noqa: E402

# effect sizes: from what the samples show (run-a gain 1.0, run-c 20 um/m,
# the project's doc 50-100 urad of C error) down to a few times the noise
SIZES = {
    "workpiece_expansion": [1.5, 1.0, 0.75],   # gain: piece dT / table mean dT
    "tool_wear": [20.0, 6.0, 2.0],            # um of radius per m cut
    "clamping_distortion": [3.0, 1.5, 0.8],   # um, three-lobe spring-back
    "c_axis_indexing": [100.0, 50.0, 25.0],   # urad, 1/turn harmonic
    "step": [3.0, 1.5],                       # um on all facets from a cycle
    "two_lobe": [3.0, 1.5],                   # um, two-lobe spring-back
    "strip_drift": [4.0, 2.0],                # um over the run, strips only
    # --more-outside only (generate.OUTSIDE_MORE)
    "angle_drift": [40.0, 20.0],              # urad over the run, every facet
    "spindle_growth": [3.0, 1.5],             # um, strips only, with its lag
    "cycle_jitter": [1.5, 0.75],              # um sd of a cycle's offset
}

# The smallest size of each catalogue cause that the targets' "effects down
# to the size the samples show" covers: run-a's workpiece expansion of gain
# 1.0; the 20 um/m of the project's wear sample and the 50-100 urad of C
# error of docs/DIAGNOSIS.md; clamping, which no sample shows, at the
# battery's largest size. Runs of a smaller size (and pairs, at middle
# sizes) are left out of that count; effects outside the catalogue, runs
# without an effect and mismatched pairs are in it.
SAMPLE_SIZES = {
    "workpiece_expansion": 1.0,
    "tool_wear": 20.0,
    "clamping_distortion": 3.0,
    "c_axis_indexing": 50.0,
}


def at_sample_size(r):
    if "+" in r["effect"]:
        return False
    if r["effect"] in SAMPLE_SIZES:
        return float(r["size"]) >= SAMPLE_SIZES[r["effect"]]
    return True


PAIRS = [("tool_wear", "clamping_distortion"), ("workpiece_expansion", "c_axis_indexing"),
         ("clamping_distortion", "c_axis_indexing"), ("tool_wear", "c_axis_indexing")]


def expected(effect):
    if "+" in effect:
        return "+".join(sorted(effect.split("+")))
    if effect in generate.CATALOGUE:
        return effect
    if effect in generate.OUTSIDE or effect in generate.OUTSIDE_MORE:
        return "unexplained"
    if effect in generate.MISMATCH:
        return "refused"
    return "none"


# the kinds the scenarios rotate through; dmis or probe replace json with --json-as
ROTATION = ["json", "dial", "cloud"]
KINDS = ROTATION + ["dmis", "probe", "probe-sparse"]


def scenarios(spacing, comp, rng, reps, clouds=False):
    """One block of runs for a spacing and compensation state. Without
    clouds the measurements alternate json/dial (the ctest's fixed set);
    with clouds they rotate json/dial/cloud (C indexing: json/cloud, a dial
    gauge cannot see it). The seeds are drawn the same way either way."""
    out = []
    for r in range(reps):
        q = r + (1 if comp else 0)   # clouds: the kinds' rotation shifted with compensation on
        for i in range(4):
            out.append(("none", 0.0, ROTATION[(i + q) % 3] if clouds else "json" if i % 2 == 0 else "dial"))
        for e in generate.CATALOGUE:
            for k, s in enumerate(SIZES[e]):
                if clouds:
                    kind = ("json", "cloud")[(k + q) % 2] if e == "c_axis_indexing" else ROTATION[(k + q) % 3]
                else:
                    kind = "json" if (e == "c_axis_indexing" or (k + r) % 2 == 0) else "dial"
                out.append((e, s, kind))
        for k, e in enumerate(generate.OUTSIDE):
            s = SIZES[e][(k + r) % 2]
            out.append((e, s, ROTATION[(k + q) % 3] if clouds else "json" if (k + r) % 2 == 0 else "dial"))
        # two catalogue causes at once, sizes in the middle of their ranges
        for k, (e1, e2) in enumerate(PAIRS[(r % 2) * 2:(r % 2) * 2 + 2]):
            kind = "json" if k % 2 == 0 or "c_axis_indexing" in (e1, e2) else "dial"
            out.append(("%s+%s" % (e1, e2), "%g+%g" % (SIZES[e1][1], SIZES[e2][1]),
                        "cloud" if clouds and k == 1 else kind))
        out.append(("other_log", 0.0, ROTATION[(q + 2) % 3] if clouds else "json" if r % 2 == 0 else "dial"))
        out.append(("short_log", 0.0, ROTATION[(q + 1) % 3] if clouds else "dial" if r % 2 == 0 else "json"))
    return [(e, s, kind, rng.randrange(1, 10 ** 6)) for e, s, kind in out]


def diagnose(ttp, meas, log, out_json, extra=()):
    p = subprocess.run([ttp, "diagnose", "--log", log, meas, "--json", out_json] + list(extra),
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    status, cause, detail, decision = None, None, "", None
    if os.path.exists(out_json):
        try:
            d = json.load(open(out_json))
            status, cause, decision = d.get("status"), d.get("cause"), d.get("decision")
            if decision is not None:
                decision["gain_pct"] = d.get("gain_pct")
                ext = d.get("extended") or {}
                decision["params"] = {k: [v, (ext.get("uncertainty") or {}).get(k)]
                                      for k, v in (ext.get("params") or {}).items()}
        except ValueError:
            pass
    if status is None:
        status = "error%d" % p.returncode
        detail = (p.stderr or p.stdout).strip().splitlines()[-1:] or [""]
        detail = detail[0]
    outcome = cause if status == "named" else status
    return outcome, p.returncode, detail, decision


def inspection_check(ttp, meas, truth_path, out_json):
    """A missed cloud run: how far `ttp inspect`'s figures are from the
    truth (the piece as cut), and the fitted top face's RMS, so that a miss
    of the inspection (a wrong W) is told from a miss of the diagnosis."""
    p = subprocess.run([ttp, "inspect", meas, "--json", out_json],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if not os.path.exists(out_json):
        return "inspect exit %d" % p.returncode
    got, truth = json.load(open(out_json)), json.load(open(truth_path))
    gf = {f["cycle"]: f for f in got.get("figures") or []}
    dev = 0.0
    for f in truth["figures"]:
        for k in ("E_X", "E_Y", "E_Z", "E_TTP"):
            g = (gf.get(f["cycle"]) or {}).get(k)
            dev = max(dev, abs(g - f[k]) if g is not None else float("inf"))
    a = got.get("alignment") or {}
    return "inspect: figures off the truth by up to %.2f um, top face rms %.1f um (%s points)" % (
        dev, a.get("top_face_rms_um", float("nan")), a.get("top_face_points"))


# Probing plans: `ttp plan probe` with its defaults, and a sparser one a lab
# might choose (two columns and two rows per facet).
PROBE_PLANS = {"probe": [], "probe-sparse": ["--facet-columns", "2", "--facet-rows", "2"]}


# Options given to every `ttp diagnose` (--diagnose-args).
DIAGNOSE_ARGS = []
NO_CLOSING_RTEST = False  # --no-closing-rtest
# The instrument stated with each DMIS and dial run (generate.STATED_ARGS);
# --dmis-cmm default leaves the CMM unstated (ttp's own program assumed).
STATED_ARGS = dict(generate.STATED_ARGS)


def stated_args(kind):
    return STATED_ARGS.get(kind, [])


def probe_points(ttp, work, kind="probe"):
    """The plan's probing points, as a user gets them (ttp plan probe)."""
    path = os.path.join(work, kind + "_points.csv")
    if not os.path.exists(path):
        subprocess.run([ttp, "plan", "probe", "-o", os.path.join(work, kind + ".nc"), "--points-csv", path]
                       + PROBE_PLANS[kind], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return path


def run_one(ttp, work, spacing, comp, effect, size, kind, seed, wall_top_mm=1.0,
            rtest_noise_scale=1.0, machine_gain_scale=1.0, closing_rtest=None, extra_args=()):
    if closing_rtest is None:
        closing_rtest = not NO_CLOSING_RTEST
    d = os.path.join(work, "run")
    shutil.rmtree(d, ignore_errors=True)
    points = probe_points(ttp, work, kind) if kind in PROBE_PLANS else None
    meas, log = generate.generate(d, effect, size, seed, spacing, comp, "probe" if points else kind,
                                  wall_top_mm=wall_top_mm, probe_points=points,
                                  rtest_noise_scale=rtest_noise_scale,
                                  machine_gain_scale=machine_gain_scale,
                                  closing_rtest=closing_rtest)
    # The point list goes with the results, as the user of a probing program
    # gives it.
    outcome, rc, detail, decision = diagnose(ttp, meas, log, os.path.join(d, "diag.json"),
                                             (["--probe-points", points] if points else [])
                                             + stated_args(kind) + DIAGNOSE_ARGS + list(extra_args))
    if kind == "cloud" and outcome != expected(effect):
        detail = (detail + "; " if detail else "") + inspection_check(
            ttp, meas, os.path.join(d, "truth.json"), os.path.join(d, "inspect.json"))
    return {"spacing_s": spacing, "compensation": "on" if comp else "off", "effect": effect,
            "size": size, "measurement": kind, "file": os.path.basename(meas), "seed": seed,
            "expected": expected(effect), "outcome": outcome, "exit": rc, "detail": detail,
            "wall_top_mm": wall_top_mm, "rtest_noise_scale": rtest_noise_scale,
            "machine_gain_scale": machine_gain_scale, "closing_rtest": closing_rtest,
            "decision": decision}


def parse_spacing(text):
    """A spacing of --spacings: seconds (an integer) or 'adaptive'."""
    return "adaptive" if text == "adaptive" else int(text)


def every(spacing):
    return ("adaptive (30 min after a load change, 2 h otherwise)" if spacing == "adaptive"
            else "every %d s" % spacing)


def fmt(size):
    return size if isinstance(size, str) else "%g" % size


def command_for(r):
    extra = " --wall-top-mm %g" % r["wall_top_mm"] if r.get("wall_top_mm", 1.0) != 1.0 else ""
    for key in ("rtest_noise_scale", "machine_gain_scale"):
        if r.get(key, 1.0) != 1.0:
            v = "%g" % r[key] if float("%g" % r[key]) == r[key] else repr(r[key])
            extra += " --%s %s" % (key.replace("_", "-"), v)
    if not r.get("closing_rtest", True):
        extra += " --no-closing-rtest"
    probed = r["measurement"] in PROBE_PLANS
    if probed:
        extra += " --probe-points out/points.csv"
    return (("ttp plan probe -o out/probe.nc --points-csv out/points.csv%s && " %
             "".join(" " + a for a in PROBE_PLANS[r["measurement"]]) if probed else "") +
            "python3 bench/outside/generate.py --effect %s --size %s --seed %d --spacing-s %s "
            "--compensation %s --measurement %s%s -o out/r && ttp diagnose --log out/r/talc.csv out/r/%s%s" %
            (r["effect"], fmt(r["size"]), r["seed"], r["spacing_s"], r["compensation"],
             "probe" if probed else r["measurement"], extra,
             r.get("file") or ("dial.csv" if r["measurement"] == "dial" else "piece.json"),
             " --probe-points out/points.csv" if probed else
             "".join(" " + a for a in stated_args(r["measurement"]))))


def report(results, spacings):
    cols = ["workpiece_expansion", "tool_wear", "clamping_distortion", "c_axis_indexing",
            "pair", "none", "unexplained", "refused", "other"]
    rows = ["workpiece_expansion", "tool_wear", "clamping_distortion", "c_axis_indexing",
            "pair", "none", "unexplained", "refused"]
    short = {"pair": "a+b", "workpiece_expansion": "wp_exp", "tool_wear": "wear", "clamping_distortion": "clamp",
             "c_axis_indexing": "c_idx", "none": "none", "unexplained": "unexpl",
             "refused": "refused", "other": "other"}
    total_right = total = 0
    for sp in spacings:
        rs = [r for r in results if r["spacing_s"] == sp]
        right = sum(r["outcome"] == r["expected"] for r in rs)
        false_names = [r for r in rs if r["expected"] in ("none", "unexplained", "refused")
                       and r["outcome"] in generate.CATALOGUE + ["other"]
                       or (r["expected"] in ("none", "unexplained", "refused") and "+" in r["outcome"])]
        no_cause = [r for r in rs if r["expected"] in ("none", "unexplained", "refused")]
        belong_refused = [r for r in rs if r["expected"] != "refused" and r["outcome"] == "refused"]
        belong = [r for r in rs if r["expected"] != "refused"]
        total_right += right
        total += len(rs)
        print("R-tests %s: right %d/%d (%.0f %%), false names %d/%d, refused belonging pairs %d/%d"
              % (every(sp), right, len(rs), 100.0 * right / max(1, len(rs)), len(false_names), len(no_cause),
                 len(belong_refused), len(belong)))
        print("  %-9s" % "expected" + "".join("%8s" % short[c] for c in cols))
        for e in rows:
            er = [r for r in rs if r["expected"] == e or (e == "pair" and "+" in r["expected"])]
            if not er:
                continue
            cnt = {c: 0 for c in cols}
            for r in er:
                o = "pair" if "+" in r["outcome"] else r["outcome"]
                o = o if o in cols else "other"
                cnt[o] += 1
            line = "  %-9s" % short[e] + "".join("%8s" % (cnt[c] or ".") for c in cols)
            if e == "pair":
                line += "   (right pair: %d)" % sum(r["outcome"] == r["expected"] for r in er)
            print(line)
        for comp in ("off", "on"):
            cr = [r for r in rs if r["compensation"] == comp]
            print("  compensation %s: right %d/%d" % (comp, sum(r["outcome"] == r["expected"] for r in cr), len(cr)))
        print("  measurement: " + ", ".join(
            "%s right %d/%d" % (k, sum(r["outcome"] == r["expected"] for r in rs if r["measurement"] == k),
                                sum(r["measurement"] == k for r in rs))
            for k in KINDS if any(r["measurement"] == k for r in rs)))
    print("all spacings: right %d/%d" % (total_right, total))
    print("effects down to the samples' sizes (SAMPLE_SIZES; pairs left out): right per spacing, and without"
          " another run's log with compensation on (undecidable: docs/DIAGNOSIS.md)")
    for sp in spacings:
        rs = [r for r in results if r["spacing_s"] == sp and at_sample_size(r)]
        rd = [r for r in rs if not (r["effect"] == "other_log" and r["compensation"] == "on")]
        rr = [sum(r["outcome"] == r["expected"] for r in x) for x in (rs, rd)]
        print("  R-tests %s: %d/%d (%.1f %%); %d/%d (%.1f %%)" % (
            every(sp), rr[0], len(rs), 100.0 * rr[0] / max(1, len(rs)), rr[1], len(rd),
            100.0 * rr[1] / max(1, len(rd))))
    print("per measurement (all spacings): right / false names (runs without a catalogue cause) / error exits")
    for k in KINDS:
        kr = [r for r in results if r["measurement"] == k]
        if not kr:
            continue
        nc = [r for r in kr if r["expected"] in ("none", "unexplained", "refused")]
        fn = [r for r in nc if r["outcome"] not in ("none", "unexplained", "refused")
              and not r["outcome"].startswith("error")]
        err = [r for r in kr if r["outcome"].startswith("error")]
        print("  %-6s right %d/%d, false names %d/%d, errors %d" % (
            k, sum(r["outcome"] == r["expected"] for r in kr), len(kr), len(fn), len(nc), len(err)))
        for e in ["none", "workpiece_expansion", "tool_wear", "clamping_distortion", "c_axis_indexing",
                  "pair", "unexplained", "refused"]:
            er = [r for r in kr if (r["expected"] == e) or (e == "pair" and "+" in r["expected"])]
            if er:
                print("    %-20s %d/%d" % (e, sum(r["outcome"] == r["expected"] for r in er), len(er)))
    print("right per effect and size (R-tests every %s):" % " / ".join(str(s) for s in spacings))
    keys = []
    for r in results:
        k = (r["effect"], fmt(r["size"]))
        if k not in keys:
            keys.append(k)
    for e, s in sorted(keys):
        cells = []
        for sp in spacings:
            rr = [r for r in results if (r["effect"], fmt(r["size"])) == (e, s) and r["spacing_s"] == sp]
            cells.append("%d/%d" % (sum(r["outcome"] == r["expected"] for r in rr), len(rr)))
        print("  %-40s %-8s %s" % (e, s, "  ".join(cells)))
    print("misses (reproduce from the repository root with ttp on PATH):")
    for r in results:
        if r["outcome"] != r["expected"]:
            print("  %-5s %-3s %-20s %-5s %-4s -> %-20s %s" % (
                r["spacing_s"], r["compensation"], r["effect"], fmt(r["size"]), r["measurement"],
                r["outcome"], r["detail"][:130]))
            print("        " + command_for(r))


# the ctest's fixed set: one block of the battery at 300 s (compensation off)
# and one at 3600 s (on), seed 7: 46 runs, 18 of them without a catalogue
# cause, in which no cause may be named
CHECK_BLOCKS = [(300, False), (3600, True)]
CHECK_SEED = 7
# right outcomes of the set as measured (see README.md), and the margin:
# the set is fixed, so a drop means the product changed; with p ~ 0.85 on
# 46 runs one binomial sd is 2.4 runs, and a product change that keeps the
# rate reshuffles outcomes within about that: fail below MEASURED - 3
# (about 7 percentage points)
CHECK_MEASURED_RIGHT = 42
CHECK_MARGIN = 3
# runs that once came out wrong, each paired with the outcome it must have
# (effect, size, seed, spacing_s, compensation on, measurement, expected):
# a two-lobe distortion named c_axis_indexing; strips drifting refused as
# another run's log; a cloud without an effect refused (the estimator fitted
# the residual of a prediction re-anchored at every R-test); another run's
# log named workpiece_expansion with its lag undetermined (561 +- 497 s);
# C-axis harmonics judged on held-out cycles at the edge of the angles cut
# by their residual alone (the fold's fit extrapolating, its uncertainty
# ignored); a strong tool wear refused for one figure kind's structure; a
# piece expanding that was clamped off its equilibrium with the table,
# named tool_wear+workpiece_expansion while its initial state was not free;
# a strong tool wear named with an expansion beside it while the estimator
# fitted a one-minute lag to R-tests an hour apart; a CMM's DMIS output
# (each plane given one touch's uncertainty, the program's touches not
# counted) with the clamping of a pair and a clamping alone not seen; and
# on-machine probing results at the points of `ttp plan probe`
# Logs as production may write them, ending before an R-test follows the
# last cuts (--no-closing-rtest): the machine errors of those cuts are
# extrapolated; a piece still gets its cause, another run's log is still
# refused.
OPEN_LOG_CASES = [
    ("workpiece_expansion", 1.0, 251034, 3600, True, "json", "workpiece_expansion"),
    ("none", 0.0, 697591, 3600, True, "dial", "none"),
    ("other_log", 0.0, 375384, 3600, False, "json", "refused"),
    # R-tests 2 h apart, five of them: `none` while five afforded the
    # estimator a constant only
    ("workpiece_expansion", 1.5, 665386, 7200, False, "dial", "workpiece_expansion"),
    ("tool_wear", 2.0, 280830, 7200, True, "json", "tool_wear"),
]

CHECK_CASES = [
    ("tool_wear+clamping_distortion", "6+1.5", 474525, 300, False, "dmis", "clamping_distortion+tool_wear"),
    ("clamping_distortion", 0.8, 615680, 1800, True, "dmis", "clamping_distortion"),
    ("none", 0.0, 20122, 1800, False, "dmis", "none"),
    # refused while a plane's tilt was left out of its distance's variance
    ("none", 0.0, 885618, 300, False, "dmis", "none"),
    ("workpiece_expansion", 1.0, 251034, 1800, True, "probe", "workpiece_expansion"),
    ("none", 0.0, 505738, 1800, True, "probe", "none"),
    # probed at the points of a sparser plan: read with that plan's point list
    ("clamping_distortion", 3.0, 573610, 1800, True, "probe-sparse", "clamping_distortion"),
    ("tool_wear", 20.0, 599260, 3600, True, "cloud", "tool_wear"),
    ("workpiece_expansion", 1.5, 632263, 1800, True, "cloud", "workpiece_expansion"),
    ("workpiece_expansion", 1.5, 737313, 1800, True, "dial", "workpiece_expansion"),
    ("c_axis_indexing", 50.0, 999931, 3600, False, "cloud", "c_axis_indexing"),
    ("tool_wear", 6.0, 856334, 1800, True, "cloud", "tool_wear"),
    ("two_lobe", 1.5, 526025, 300, True, "json", "unexplained"),
    ("other_log", 0.0, 514711, 3600, False, "json", "unexplained"),
    ("strip_drift", 4.0, 654812, 300, False, "json", "unexplained"),
    ("none", 0.0, 27776, 3600, True, "cloud", "none"),
    # a table's C error once, twice and four times per turn while the fit
    # took harmonics 1..K only: a four-lobed spring-back rivalled it (found
    # at 25 urad, where the evidence, 6.4 against the threshold 6, sits on
    # the detection limit and the held-out cycles go either way; the same
    # harmonics at 30 urad)
    ("c_axis_indexing", 30.0, 959450, 300, False, "cloud", "c_axis_indexing"),
    # no effect, a cloud: `unexplained` (E_OV at 4.5 deviates) while a
    # facet's scatter was taken as rms / sqrt(points), without the fitted
    # tilt's lever to W's origin above the points
    ("none", 0.0, 909599, 300, True, "cloud", "none"),
    # strips drifting 2 um over the run: `none` while a drift of one figure
    # kind had to explain chi2 20
    ("strip_drift", 2.0, 593140, 300, False, "json", "unexplained"),
    # facets 1.5 um nearer the axis from cycle 3 on, with its own log:
    # refused while E_Z was judged only after the best (wrong) cause, which
    # moved it off a log the nominal model agrees with
    ("step", 1.5, 265538, 300, True, "cloud", "unexplained"),
    # pieces with their own log and a cause named, refused while a named
    # cause had to leave E_X, E_Y and E_Z pooled within a deviate of 2.5
    # (they keep 2.6)
    ("workpiece_expansion", 1.0, 175161, 300, True, "json", "workpiece_expansion"),
    ("tool_wear", 6.0, 228828, 300, True, "json", "tool_wear"),
    # R-tests 2 h apart: `none` while the estimator's cross-validation
    # folds chose among the structures five R-tests afford (a budget
    # several times its error)
    ("workpiece_expansion", 1.0, 872985, 7200, True, "json", "workpiece_expansion"),
    # refused while only the best result and one kind's drift or step
    # could reconcile E_X, E_Y and E_Z with the log (the expansion's fit
    # ends at the shortest lag tried and does)
    ("workpiece_expansion", 1.5, 525808, 7200, True, "dial", "unexplained"),
    # every facet angle drifting 40 urad over the run (outside the battery's
    # rotation), R-tests an hour apart: named c_axis_indexing while no
    # turn of every facet alike rivalled the C stop error's harmonics twice
    # and four times per turn
    ("angle_drift", 40.0, 27357, 3600, False, "json", "unexplained"),
    ("angle_drift", 40.0, 27357, 3600, True, "cloud", "unexplained"),
    # every cycle cut at its own offset (facets and strip, 1.5 um sd), with
    # its own log: refused while E_X, E_Y and E_Z kept off the log had to
    # be explained by no other run's machine (each cycle's E_Z its own way)
    ("cycle_jitter", 1.5, 619703, 3600, False, "cloud", "unexplained"),
    ("cycle_jitter", 1.5, 330984, 300, False, "json", "unexplained"),
    ("cycle_jitter", 1.5, 361837, 300, False, "dial", "unexplained"),
    # seven R-tests 83 min apart: `none` while seven afforded the estimator
    # two lags (two R-tests to spare; two lags need three)
    ("step", 1.5, 187697, 5000, False, "dial", "unexplained"),
    ("step", 3.0, 640684, 5000, True, "json", "unexplained"),
]


# R-tests four times as noisy as thesis table 5.4 (diagnosis.md section 4
# allows up to 1.3 um and 6 urad), with the lab's R-test uncertainty stated
# in the configuration (machine.rtest_u95_um, rtest_u95_urad): refused with
# their own log while the estimator took the table's noise, whose floor
# the few R-tests at 1-2 h could not raise.
NOISY_LAB_SCALE = 4.0
NOISY_LAB_CASES = [
    ("workpiece_expansion+c_axis_indexing", "1+50", 710808, 3600, True, "cloud",
     "c_axis_indexing+workpiece_expansion"),
    ("c_axis_indexing", 50.0, 919130, 7200, False, "json", "c_axis_indexing"),
    ("tool_wear+c_axis_indexing", "6+50", 499716, 7200, False, "cloud", "c_axis_indexing+tool_wear"),
]


def lab_config(work, scale):
    """A configuration stating an R-test `scale` times as uncertain as
    thesis table 5.4 (U, k = 2)."""
    path = os.path.join(work, "noisy_lab.toml")
    u = generate.RTEST_U
    with open(path, "w") as f:
        f.write("[machine]\nrtest_u95_um = [%s]\nrtest_u95_urad = [%s]\n" % (
            ", ".join("%g" % (scale * u[e]) for e in ("EX0C", "EY0C", "EZ0T", "ER0T")),
            ", ".join("%g" % (scale * u[e]) for e in ("EA0C", "EB0C", "EC0C"))))
    return path


def check(ttp, work):
    rng = random.Random(CHECK_SEED)
    results = []
    for sp, comp in CHECK_BLOCKS:
        for e, s, kind, seed in scenarios(sp, comp, rng, 1):
            results.append(run_one(ttp, work, sp, comp, e, s, kind, seed))
    bad = 0
    no_cause = [r for r in results if r["expected"] in ("none", "unexplained", "refused")]
    for r in results:
        if r["outcome"].startswith("error"):
            print("FAIL (bad input or internal error): %s: %s" % (command_for(r), r["detail"]))
            bad += 1
    named = [r for r in no_cause if r["outcome"] not in ("none", "unexplained", "refused")
             and not r["outcome"].startswith("error")]
    for r in named:
        print("FAIL: %s named in a run without a catalogue cause (%s): %s" % (
            r["outcome"], r["effect"], command_for(r)))
    right = sum(r["outcome"] == r["expected"] for r in results)
    for effect, size, seed, sp, comp, kind, want, closing in (
            [c + (True,) for c in CHECK_CASES] + [c + (False,) for c in OPEN_LOG_CASES]):
        r = run_one(ttp, work, sp, comp, effect, size, kind, seed, closing_rtest=closing)
        if r["outcome"] != want:
            print("FAIL: a case that once came out wrong: %s expected %s, got %s: %s" % (
                effect, want, r["outcome"], command_for(r)))
            bad += 1
    config = lab_config(work, NOISY_LAB_SCALE)
    for effect, size, seed, sp, comp, kind, want in NOISY_LAB_CASES:
        r = run_one(ttp, work, sp, comp, effect, size, kind, seed, rtest_noise_scale=NOISY_LAB_SCALE,
                    extra_args=["--config", config])
        if r["outcome"] != want:
            print("FAIL: a noisy lab's case, its R-test uncertainty stated: %s expected %s, got %s: %s"
                  " (ttp diagnose --config FILE stating %g x thesis table 5.4)" % (
                      effect, want, r["outcome"], command_for(r), NOISY_LAB_SCALE))
            bad += 1
    for r in results:
        if r["outcome"] != r["expected"]:
            print("miss: %s expected %s, got %s: %s" % (r["effect"], r["expected"], r["outcome"], command_for(r)))
    need = (CHECK_MEASURED_RIGHT - CHECK_MARGIN) if CHECK_MEASURED_RIGHT is not None else 0
    print("runs without a catalogue cause: %d, causes named in them: %d (0 allowed)" % (len(no_cause), len(named)))
    print("right outcomes: %d/%d (measured: %s; at least %d required)" % (
        right, len(results), CHECK_MEASURED_RIGHT, need))
    if named or right < need:
        bad += 1
    return 1 if bad else 0


# the detection curve: sizes per catalogue cause, from below the battery's
# smallest to above its largest (workpiece expansion stays above the gain
# near 0.47 at which the piece grows like the table and the effect vanishes)
LADDER = {
    "workpiece_expansion": [0.6, 0.75, 1.0, 1.5, 2.0],
    "tool_wear": [0.5, 1.0, 2.0, 4.0, 6.0],
    "clamping_distortion": [0.25, 0.5, 0.8, 1.5, 3.0],
    "c_axis_indexing": [10.0, 25.0, 50.0, 100.0, 200.0],
}


def detection(ttp, work, spacings, runs, seed, scales=(1.0, 1.0)):
    """Share of runs in which a cause alone is named right, per size, R-test
    spacing and measurement (json; dial too where a dial gauge can see the
    cause), compensation alternating; and the detection limit: the smallest
    size from which every larger one is named in at least 90 %."""
    rng = random.Random(seed)
    t0 = time.time()
    n = 0
    print("detection (share named right, %d runs per point, compensation alternating)" % runs)
    for effect, sizes in LADDER.items():
        kinds = ["json"] if effect == "c_axis_indexing" else ["json", "dial"]
        for kind in kinds:
            for sp in spacings:
                shares = []
                for size in sizes:
                    right = 0
                    for k in range(runs):
                        r = run_one(ttp, work, sp, k % 2 == 1, effect, size, kind, rng.randrange(1, 10 ** 6),
                                    1.0, *scales)
                        right += r["outcome"] == effect
                        n += 1
                    shares.append(right / runs)
                limit = None
                for i in range(len(sizes) - 1, -1, -1):
                    if shares[i] < 0.9:
                        break
                    limit = sizes[i]
                print("  %-20s %-4s %7s: %s -> %s" % (
                    effect, kind, "%s s" % sp if sp != "adaptive" else sp,
                    "  ".join("%g:%d%%" % (z, round(100 * f)) for z, f in zip(sizes, shares)),
                    "90 %% at %g" % limit if limit is not None else "90 %% at > %g" % sizes[-1]))
    print("%d runs in %.0f s" % (n, time.time() - t0))
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ttp", default="build/app/ttp")
    ap.add_argument("--seed", type=int, default=20261125)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--spacings", default="300,1800,3600,7200")
    ap.add_argument("--only", help="comma-separated effects to keep (e.g. none,step,two_lobe,strip_drift)")
    ap.add_argument("--json", help="write every run's result here")
    ap.add_argument("--check", action="store_true", help="the ctest's fixed small set")
    ap.add_argument("--detection", type=int, metavar="RUNS",
                    help="the detection curve per catalogue cause instead, RUNS runs per point "
                         "(at the spacings given; 300,3600 is a good choice)")
    ap.add_argument("--more-outside", type=int, default=0, metavar="REPS",
                    help="after the battery, REPS runs per spacing, compensation state and size of "
                         "each effect outside the catalogue that the battery does not rotate through "
                         "(%s; measurements json/dial/cloud in turn; seeds of their own)"
                         % ", ".join(generate.OUTSIDE_MORE))
    ap.add_argument("--summarise", nargs="+", metavar="JSON",
                    help="report the results of earlier --json files (several seeds pooled) without running")
    ap.add_argument("--workdir", help="scratch folder (default: a temporary one)")
    ap.add_argument("--no-clouds", action="store_true",
                    help="measurements json/dial only (the battery before point clouds)")
    ap.add_argument("--json-as", choices=["json", "dmis", "probe", "probe-sparse"], default="json",
                    help="the runs measured by a per-feature CMM report (json) measured instead by a "
                         "CMM's DMIS output (dmis: features fitted from touches, in the CMM's frame) or "
                         "by on-machine probing (probe: the points of ttp plan probe, machine frame; "
                         "probe-sparse: of ttp plan probe --facet-columns 2 --facet-rows 2); "
                         "the same runs and seeds otherwise")
    ap.add_argument("--cloud-wall-top-mm", type=float, default=1.0,
                    help="clouds: highest facet and flank points, mm below the top face (generate.py --wall-top-mm)")
    ap.add_argument("--diagnose-args", default="",
                    help="options added to every ttp diagnose, e.g. '--evidence 20'")
    ap.add_argument("--dmis-cmm", choices=["stated", "default"], default="stated",
                    help="DMIS runs: read with the generator's CMM stated (MPE and touches, default) or with "
                         "ttp's defaults (the touches of ttp plan cmm at MPE 1.2 um + L/400)")
    generate.add_scale_args(ap)
    generate.add_log_end_arg(ap)
    a = ap.parse_args()
    scales = (a.rtest_noise_scale, a.machine_gain_scale)
    if a.check and scales != (1.0, 1.0):
        ap.error("--check is the ctest's fixed set: without --rtest-noise-scale or --machine-gain-scale")
    DIAGNOSE_ARGS.extend(a.diagnose_args.split())
    global NO_CLOSING_RTEST
    NO_CLOSING_RTEST = a.no_closing_rtest
    if a.check and a.no_closing_rtest:
        ap.error("--check is the ctest's fixed set: without --no-closing-rtest")
    if a.dmis_cmm == "default":
        del STATED_ARGS["dmis"]
    if a.summarise:
        results = []
        for path in a.summarise:
            with open(path) as f:
                results.extend(json.load(f))
        report(results, sorted({r["spacing_s"] for r in results}, key=lambda sp: (isinstance(sp, str), sp)))
        return 0
    work = a.workdir or tempfile.mkdtemp(prefix="ttp-outside-")
    os.makedirs(work, exist_ok=True)
    try:
        if a.check:
            return check(a.ttp, work)
        spacings = [parse_spacing(x) for x in a.spacings.split(",")]
        if a.detection:
            return detection(a.ttp, work, spacings, a.detection, a.seed, scales)
        rng = random.Random(a.seed)
        results = []
        t0 = time.time()
        for sp in spacings:
            for comp in (False, True):
                for e, s, kind, seed in scenarios(sp, comp, rng, a.reps, clouds=not a.no_clouds):
                    if a.only and e not in a.only.split(","):
                        continue
                    if kind == "json":
                        kind = a.json_as
                    results.append(run_one(a.ttp, work, sp, comp, e, s, kind, seed, a.cloud_wall_top_mm,
                                           *scales))
        # (a generator of its own: the battery's runs and seeds stay as they are)
        more = random.Random(a.seed + 1)
        for sp in spacings:
            for comp in (False, True):
                for r in range(a.more_outside):
                    for k, e in enumerate(generate.OUTSIDE_MORE):
                        for i, s in enumerate(SIZES[e]):
                            kind = ROTATION[(r + k + i + comp) % 3]
                            results.append(run_one(a.ttp, work, sp, comp, e, s, kind,
                                                   more.randrange(1, 10 ** 6), a.cloud_wall_top_mm,
                                                   *scales))
        report(results, spacings)
        print("%d runs in %.0f s" % (len(results), time.time() - t0))
        if a.json:
            with open(a.json, "w") as f:
                json.dump(results, f, indent=1)
    finally:
        if not a.workdir:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

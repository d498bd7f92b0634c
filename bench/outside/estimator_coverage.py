#!/usr/bin/env python3
"""How well the machine-error estimator's uncertainty describes its error
on the outside generator: per run (no effect; compensation off and on in
turn; R-tests every 300, 1800, 3600 and 7200 s, or adaptive: --spacings) the log is written by
generate.py, `ttp simulate --log LOG --json` gives the estimator's machine
errors and their standard uncertainties (`machine_errors`,
`machine_errors_u`) at every cut, and the generator's own machine errors
at those times are the truth. What a figure sees is a cut's error against
the reference cycle's (every figure is a difference to cycle 0), so per
error and cut after the first

    z = (dev(t) - dev(t0)) / sqrt(u(t)^2 + u(t0)^2 - 2 rho u(t) u(t0)),

dev = estimate - truth, rho = exp(-|t - t0| / mean R-test spacing) (the
correlation the diagnosis's budget gives the estimator's error). An honest
budget gives an RMS z near 1; much less is a budget wider than the error
(evidence without power), much more one narrower (false alarms).

Usage: estimator_coverage.py [--ttp build/app/ttp] [--runs 10] [--seed 7]
                             [--spacings 300,1800,3600,7200|adaptive]
                             [--rtest-noise-scale 1] [--machine-gain-scale 1]
Python 3 standard library only.
"""
import argparse
import json
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate  # noqa: E402

SPACINGS = "300,1800,3600,7200"


def machine_at_cuts(sim):
    """The generator's machine errors (um, um/m; relative to the first
    R-test's time, as the log's R-test values are) at each cut's row time."""
    return {round(f["t"] + 3.0, 1): f["machine_errors"] for f in sim["features"].values()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ttp", default="build/app/ttp")
    ap.add_argument("--runs", type=int, default=10, help="logs per spacing and compensation state")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--spacings", default=SPACINGS,
                    help="R-test spacings, s, or 'adaptive' (generate.py --spacing-s; default %s)" % SPACINGS)
    generate.add_scale_args(ap)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    work = tempfile.mkdtemp(prefix="ttp-estimator-coverage-")
    try:
        print("RMS z per error (dev against the reference cut over the budget's u), "
              f"{a.runs} logs per row; share of |z| <= 2 in brackets")
        print(f"{'spacing':>8} {'comp':>4}  " + "  ".join(f"{e:>12}" for e in generate.ERRS))
        for spacing in [generate.parse_spacing(x) for x in a.spacings.split(",")]:
            for comp in (False, True):
                z = {e: [] for e in generate.ERRS}
                for _ in range(a.runs):
                    seed = rng.randrange(10 ** 6)
                    sim = generate.simulate(seed, "none", 0.0, spacing, comp,
                                            a.rtest_noise_scale, a.machine_gain_scale)
                    log = os.path.join(work, "talc.csv")
                    out = os.path.join(work, "sim.json")
                    generate.write_log(log, sim["rows"], comp)
                    p = subprocess.run([a.ttp, "-q", "simulate", "--log", log, "--json", out],
                                       stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                    if p.returncode != 0:
                        print(f"  seed {seed}: ttp simulate exit {p.returncode}: {p.stderr.strip()}")
                        continue
                    truth = machine_at_cuts(sim)
                    rt = sim["rtests"]
                    spacing_mean = (rt[-1] - rt[0]) / (len(rt) - 1)
                    cuts = sorted(json.load(open(out))["cuts"], key=lambda c: c["t_s"])
                    ref = cuts[0]
                    for c in cuts[1:]:
                        rho = math.exp(-abs(c["t_s"] - ref["t_s"]) / spacing_mean)
                        for e in generate.ERRS:
                            dev = (c["machine_errors"][e] - ref["machine_errors"][e]) - \
                                  (truth[round(c["t_s"], 1)][e] - truth[round(ref["t_s"], 1)][e])
                            u, u0 = c["machine_errors_u"][e], ref["machine_errors_u"][e]
                            var = u * u + u0 * u0 - 2 * rho * u * u0
                            if var > 0:
                                z[e].append(dev / math.sqrt(var))
                cells = []
                for e in generate.ERRS:
                    v = z[e]
                    if not v:
                        cells.append(f"{'-':>12}")
                        continue
                    rms = math.sqrt(sum(x * x for x in v) / len(v))
                    inside = sum(abs(x) <= 2 for x in v) / len(v)
                    cells.append(f"{rms:6.2f} ({100 * inside:3.0f}%)")
                print(f"{spacing:>8} {'on' if comp else 'off':>4}  " + "  ".join(cells))
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()

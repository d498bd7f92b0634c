#!/usr/bin/env python3
"""Holds the outside generator's nominal model (test-piece.md sections 4 and
6, as coded in generate.py) against the sample runs, which were made outside
the project: the machine errors at each cut are interpolated linearly
between the log's R-tests (residual + pred_ with compensation on), the
piece is cut through them, and the figures and facet angles are compared
with the sample's truth.json. Agreement within the R-test noise says that
the generator's frames, signs and compensation reading are the samples'.

Usage: check_samples.py [samples/run-a samples/run-b ...]
"""
import csv
import json
import math
import os
import sys

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate as g  # noqa: E402


def nominal(log_path):
    rows = [r for r in csv.DictReader(l for l in open(log_path) if not l.startswith("#"))]
    comp = any(r.get("pred_EX0C") for r in rows)
    preds = [(float(r["t_s"]), {e: float(r["pred_" + e]) for e in g.ERRS})
             for r in rows if comp and r.get("pred_EX0C")]

    def pred_at(t):
        last = {e: 0.0 for e in g.ERRS} if comp else None
        for tt, p in preds:
            if tt <= t:
                last = p
        return last

    rt = []
    for r in rows:
        if r["event"] == "rtest":
            t = float(r["t_s"]) - float(r["dur_s"] or 0) / 2
            p = pred_at(t) or {e: 0.0 for e in g.ERRS}
            rt.append((t, {e: float(r[e]) + p[e] for e in g.ERRS}))

    def machine(t):
        for (a, ea), (b, eb) in zip(rt, rt[1:]):
            if a <= t <= b:
                w = (t - a) / (b - a)
                return {e: ea[e] * (1 - w) + eb[e] * w for e in g.ERRS}
        return rt[-1][1]

    feats = {}
    for r in rows:
        if r["event"] != "cut":
            continue
        t = float(r["t_s"]) - 3.0
        name = r["feature"]
        E, P = machine(t), pred_at(t)
        if name.startswith("Z"):
            y = (int(name[1:]) - 5) * 11.75
            zc = g.Z_TOP_MM + g.Z_FLOOR_W_MM
            n3 = (0.0, 0.0, 1.0)
            u0 = g.normal_shift(E, P, n3, (0.0, y, zc), (0.0, y, zc))
            u1 = g.normal_shift(E, P, n3, (1.0, y, zc), (1.0, y, zc))
            feats[name] = {"depth": -u0, "beta": (u1 - u0) * 1000.0}
        else:
            s = name.split("-")[0]
            nx, ny = g.NORMAL_M[s]
            n3, tx, ty, zm = (nx, ny, 0.0), -ny, nx, g.Z_TOP_MM - 6.0
            r0 = g.R_FACET_MM
            p0, q0 = (r0 * nx, r0 * ny, zm), ((r0 + g.CUTTER_R_MM) * nx, (r0 + g.CUTTER_R_MM) * ny, zm)
            u0 = g.normal_shift(E, P, n3, p0, q0)
            u1 = g.normal_shift(E, P, n3, (p0[0] + tx, p0[1] + ty, zm), (q0[0] + tx, q0[1] + ty, zm))
            feats[name] = {"d": u0, "angle": -(u1 - u0) * 1000.0}
    return g.figures_from(feats), {k: v["angle"] for k, v in feats.items() if "angle" in v}


def main():
    runs = sys.argv[1:] or ["samples/run-a", "samples/run-b"]
    for run in runs:
        truth = json.load(open(os.path.join(run, "truth.json")))
        figs, ang = nominal(os.path.join(run, "talc.csv"))
        print("%s (truth: %s, compensation %s): generator's nominal model minus truth, RMS over cycles 1-8"
              % (run, truth.get("cause"), truth.get("compensation")))
        for k in ["E_X", "E_Y", "E_Z", "E_B", "E_TTP"]:
            d = [f[k] - t[k] for f, t in zip(figs, truth["figures"])]
            print("  %-5s %6.2f   (truth RMS %6.2f)" % (k, math.sqrt(sum(x * x for x in d) / len(d)),
                                                     math.sqrt(sum(t[k] ** 2 for t in truth["figures"]) / 8)))
        ta = truth.get("facet_angle_err_urad", {})
        if ta:
            d = [(ang[n] - ang[n[:2] + "-5"]) - (ta[n] - ta[n[:2] + "-5"]) for n in ta]
            tr = [ta[n] - ta[n[:2] + "-5"] for n in ta]
            print("  angles %5.2f urad (truth RMS %5.2f), relative to each set's reference facet"
                  % (math.sqrt(sum(x * x for x in d) / len(d)), math.sqrt(sum(x * x for x in tr) / len(tr))))


if __name__ == "__main__":
    main()

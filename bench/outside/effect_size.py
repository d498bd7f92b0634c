#!/usr/bin/env python3
"""Size of each effect on the figures of test-piece.md section 4 (compensation
off, no noise): RMS over cycles 1-8 of the change in E_X, E_Y, E_Z, E_TTP and
the facet angles' RMS change, averaged over a few machines."""
import math
import sys
sys.dont_write_bytecode = True
import generate as g
import run_battery as b


def figs(sim):
    f = {k: {"d": v.get("dist_um"), "depth": v.get("depth_um"), "beta": v.get("beta_urad")}
         for k, v in sim["features"].items()}
    return g.figures_from(f), {k: v["angle_urad"] for k, v in sim["features"].items() if "angle_urad" in v}


def main():
    print("%-20s %6s %8s %8s %8s %8s %9s" % ("effect", "size", "E_X", "E_Y", "E_Z", "E_TTP", "angle_urad"))
    for e, sizes in b.SIZES.items():
        for s in sizes:
            acc = [0.0] * 5
            for seed in (1, 2, 3, 4):
                f0, a0 = figs(g.simulate(seed, "none", 0.0, 300, False))
                f1, a1 = figs(g.simulate(seed, e, s, 300, False))
                for i, k in enumerate(["E_X", "E_Y", "E_Z", "E_TTP"]):
                    acc[i] += math.sqrt(sum((x[k] - y[k]) ** 2 for x, y in zip(f0, f1)) / 8) / 4
                # angles relative to the segment's reference facet (a datum offset is free)
                d = [a1[n] - a0[n] - (a1[n[:2] + "-5"] - a0[n[:2] + "-5"]) for n in a0]
                acc[4] += math.sqrt(sum(x * x for x in d) / len(d)) / 4
            print("%-20s %6g %8.2f %8.2f %8.2f %8.2f %9.1f" % (e, s, *acc))


if __name__ == "__main__":
    main()

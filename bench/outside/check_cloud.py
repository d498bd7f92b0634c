#!/usr/bin/env python3
"""Holds what `ttp inspect` reads from the outside generator's point clouds
against the generator's truth (the piece as cut, before any measurement
noise): per facet the distance and the angle error, per strip the depth and
beta, and the figures E_X..E_TTP of every cycle. Agreement within the
clouds' noise says that the cloud's frames, orientation conventions and
feature geometry are those of the specs as the CLI reads them.

Usage: check_cloud.py [--ttp build/app/ttp] [--runs 6] [--seed 1]
                      [--effect none] [--points 20000] [DIR ...]
With DIRs: check those runs (each with truth.json and piece.ply/.xyz);
without: generate --runs runs (seeds seed, seed+1, ...: PLY and .xyz, table
and arbitrary poses alternate) and check them. One ttp process at a time.
Python 3 standard library only.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate  # noqa: E402

FIGS = ["E_X", "E_Y", "E_Z", "E_B", "E_TTP"]


def inspect(ttp, path, out_json):
    p = subprocess.run([ttp, "inspect", path, "--json", out_json],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode not in (0, 1) or not os.path.exists(out_json):
        return None, p.returncode, (p.stderr or p.stdout).strip()
    return json.load(open(out_json)), p.returncode, ""


def compare(truth, got):
    """Differences (measured - truth) per kind."""
    diff = {k: [] for k in ["facet d um", "facet angle urad", "strip depth um", "strip beta urad"] + FIGS}
    for name, t in truth["facets"].items():
        g = (got.get("facets") or {}).get(name)
        if not g or g.get("distance_mm") is None:
            continue
        diff["facet d um"].append((g["distance_mm"] - t["distance_mm"]) * 1e3)
        if g.get("angle_error_urad") is not None:
            diff["facet angle urad"].append(g["angle_error_urad"] - t["angle_error_urad"])
    for name, t in truth["strips"].items():
        g = (got.get("strips") or {}).get(name)
        if not g or g.get("depth_mm") is None:
            continue
        diff["strip depth um"].append((g["depth_mm"] - t["depth_mm"]) * 1e3)
        if g.get("beta_urad") is not None:
            diff["strip beta urad"].append(g["beta_urad"] - t["beta_urad"])
    gf = {f["cycle"]: f for f in got.get("figures") or []}
    for f in truth["figures"]:
        g = gf.get(f["cycle"])
        for k in FIGS:
            if g and g.get(k) is not None:
                diff[k].append(g[k] - f[k])
    return diff


def stats(v):
    if not v:
        return "   (none)"
    rms = math.sqrt(sum(x * x for x in v) / len(v))
    mx = max(v, key=abs)
    return "n %4d  mean %+7.3f  rms %6.3f  max %+7.3f" % (len(v), sum(v) / len(v), rms, mx)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ttp", default="build/app/ttp")
    ap.add_argument("--runs", type=int, default=6)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--effect", default="none")
    ap.add_argument("--size", default="0")
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("dirs", nargs="*")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="ttp-cloud-")
    try:
        dirs = a.dirs
        if not dirs:
            size = a.size if "+" in a.size else float(a.size)
            for i in range(a.runs):
                d = os.path.join(work, "r%d" % i)
                generate.generate(d, a.effect, size, a.seed + i, 300.0, False, "cloud", a.points)
                dirs.append(d)
        total = {}
        bad = 0
        for d in dirs:
            truth = json.load(open(os.path.join(d, "truth.json")))
            cloud = [f for f in os.listdir(d) if f.startswith("piece.") and f[-3:] in ("ply", "xyz")][0]
            got, rc, err = inspect(a.ttp, os.path.join(d, cloud), os.path.join(work, "inspect.json"))
            c = truth.get("cloud", {})
            head = "%s seed %s %s pose %s, %s points, noise %.2f um" % (
                d, truth["seed"], cloud, c.get("pose", {}).get("kind"), c.get("points"), c.get("noise_um", 0))
            if got is None:
                print(head + ": ttp inspect exit %d: %s" % (rc, err.splitlines()[-1:] if err else ""))
                bad += 1
                continue
            print(head + ": warnings %d" % len(got.get("warnings") or []))
            for w in got.get("warnings") or []:
                print("   warning: %s" % w)
            diff = compare(truth, got)
            for k, v in diff.items():
                total.setdefault(k, []).extend(v)
        print("measured - truth over %d runs:" % (len(dirs) - bad))
        for k, v in total.items():
            print("  %-18s %s" % (k, stats(v)))
        return 1 if bad else 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())

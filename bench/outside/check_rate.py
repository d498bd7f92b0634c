#!/usr/bin/env python3
"""How often `ttp check` judges a piece to disagree with its log: pieces
and logs from generate.py (no effect, or `--effect E --size S` for the
check's power), every measurement kind in turn (json, dial and dmis with
their instrument stated, cloud), compensation on and off in turn, R-tests
every 300, 1800, 3600 and 7200 s. Prints per spacing the runs
judged to disagree (exit 1) and the figures outside their own U.

Usage: check_rate.py [--ttp build/app/ttp] [--runs 16] [--seed 11] [--effect E --size S]
Python 3 standard library only.
"""
import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import generate  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ttp", default="build/app/ttp")
    ap.add_argument("--runs", type=int, default=16, help="pieces per R-test spacing")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--effect", default="none", help="an effect of generate.py (default none)")
    ap.add_argument("--size", type=float, default=0.0)
    a = ap.parse_args()
    rng = random.Random(a.seed)
    work = tempfile.mkdtemp(prefix="ttp-check-rate-")
    try:
        for spacing in (300, 1800, 3600, 7200):
            failed = outside = compared = errors = 0
            for r in range(a.runs):
                kind = ("json", "dial", "dmis", "cloud")[r % 4]
                seed = rng.randrange(1, 10 ** 6)
                d = os.path.join(work, "run")
                shutil.rmtree(d, ignore_errors=True)
                meas, log = generate.generate(d, a.effect, a.size, seed, spacing, r % 2 == 1, kind)
                out = os.path.join(d, "check.json")
                # DMIS and dial pieces read with their instrument stated, as a
                # lab states its own.
                stated = generate.STATED_ARGS.get(kind, [])
                p = subprocess.run([a.ttp, "check", "--log", log, meas, "--json", out] + stated,
                                   stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                if p.returncode not in (0, 1):
                    errors += 1
                    print("error %d: %s" % (p.returncode, p.stderr.strip().splitlines()[-1:]))
                    continue
                failed += p.returncode == 1
                c = json.load(open(out))
                outside += c["disagreements"]
                compared += c["compared"]
            print("R-tests every %d s: %d of %d pieces (%s %g) judged to disagree; "
                  "%d of %d figures outside their U; %d errors" % (
                      spacing, failed, a.runs, a.effect, a.size, outside, compared, errors), flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())

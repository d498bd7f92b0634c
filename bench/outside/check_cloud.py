#!/usr/bin/env python3
"""Holds what `ttp inspect` reads from the outside generator's point clouds
against the generator's truth (the piece as cut, before any measurement
noise): per facet the distance and the angle error, per strip the depth and
beta, and the figures E_X..E_TTP of every cycle. Agreement within the
clouds' noise says that the cloud's frames, orientation conventions and
feature geometry are those of the specs as the CLI reads them.

Usage: check_cloud.py [--ttp build/app/ttp] [--runs 6] [--seed 1]
                      [--effect none] [--points 20000]
                      [--surroundings none|adapter|table|posts|vise|
                                      angle_plate|tilted|both|fixtures]
                      [--table-share 2] [--limits] [DIR ...]
       check_cloud.py --stats DIR ...   (points per surface, ranges in W)
With DIRs: check those runs (each with truth.json and piece.ply/.xyz);
without: generate --runs runs (seeds seed, seed+1, ...: PLY and .xyz, table
and arbitrary poses alternate) and check them. One ttp process at a time.
--surroundings adds other surfaces to each cloud, which measurements.md
section 1 says may be present and are to be ignored, in the cloud's pose
from truth.json: 'adapter' the piece's adapter (test-piece.md section 1:
a cylinder of 180 mm, 30 mm high, under the bottom face at z = -24) and
the machine table under it (z = -54, a 600 x 500 mm rectangle about a
point up to 100 mm off the piece's axis); 'table' the piece straight on
a CMM table (z = -24, same rectangle, no adapter); 'posts' that table
with three clamp posts beside the piece (16 mm across, 125 mm from its
axis, their tops 30 to 50 mm above the piece's top, a tenth as many
points as the piece each); 'vise' the piece held in a vise on that table
by its 201 mm cylinder (two jaws 30 mm thick and 150 mm wide touching
it at x = +-100.5, their tops at z = -20.5, a vise base 360 x 200 mm
at z = -24 under the piece, the CMM table at z = -90); 'angle_plate' an
angle plate beside the piece on the table (a vertical face 120 to 250
mm wide and 84 mm high, 105 mm from the axis at a random angle, its top 60 mm
above the piece's top, half as many points as the piece, with its 25 mm
thick top edge and ends); 'tilted' the table tilted against the piece by
0.5 to 3 degrees (the piece on shims or a tilting fixture; the table 2 mm
below the piece's bottom under its axis); 'both' alternates adapter and
table, 'fixtures' vise, angle plate and tilted table.
--limits: exit 1 also when a figure or a facet distance is off the truth
by more than 1 um or a facet angle by more than 100 urad (the clouds'
noise gives at most about 0.25 um and 40 urad), or when the features'
errors over their own scatter (U_scatter / 2, the part common to a run
taken out) have an RMS outside 0.75-1.33 for a kind with 100 features or
more; always exit 1 when ttp inspect refuses a cloud. The ctest
outside.inspect_clouds_in_fixtures runs `--runs 12 --seed 11
--surroundings fixtures --limits`.
The table holds --table-share (default 2) times, the adapter a fifth as
many points as the piece, with the piece's noise; the table's points under
the piece's rim are not seen (a scanner looks from above).
Python 3 standard library only.
"""
import argparse
import json
import math
import os
import shutil
import struct
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
    diff["angle pairs"] = []
    facets = truth.get("facets") or {n: {"distance_mm": None, "angle_error_urad": a}   # the samples' truth
                                     for n, a in truth.get("facet_angle_err_urad", {}).items()}
    for name, t in facets.items():
        g = (got.get("facets") or {}).get(name)
        if not g or g.get("distance_mm") is None:
            continue
        if t["distance_mm"] is not None:
            diff["facet d um"].append((g["distance_mm"] - t["distance_mm"]) * 1e3)
        if g.get("angle_error_urad") is not None:
            diff["facet angle urad"].append(g["angle_error_urad"] - t["angle_error_urad"])
            diff["angle pairs"].append((t["angle_error_urad"], g["angle_error_urad"]))
    for name, t in (truth.get("strips") or {}).items():
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


# (measured - truth) / u_scatter per kind, the part common to a run (the
# datum's: the top face's height and tilt for strips, the notch's direction
# for facet angles) taken out first: U_scatter is by its definition what
# differs from one feature to the next. The fields are U = 2u; the truth
# and the inspection name each value alike.
SCATTER_KINDS = [("facet d", "facets", "distance_mm", 1e3, "U_scatter_distance_um"),
                 ("facet angle", "facets", "angle_error_urad", 1.0, "U_scatter_angle_urad"),
                 ("strip depth", "strips", "depth_mm", 1e3, "U_scatter_depth_um"),
                 ("strip beta", "strips", "beta_urad", 1.0, "U_scatter_beta_urad")]
# --limits: RMS of those z over at least this many features must lie in
# this band (a scatter 2.3 times too small, a facet's d without its tilt's
# lever, gives 2.3; the sampling spread of the RMS over 400 features is
# about 0.04)
SCATTER_MIN_FEATURES = 100
SCATTER_RMS_Z_BAND = (0.75, 1.33)


def scatter_z(truth, got):
    """Per kind the z of each feature against its U_scatter, the run's mean
    error taken out (with the n / (n - 1) that taking it out costs)."""
    out = {}
    for kind, sect, field, scale, ufield in SCATTER_KINDS:
        errs = []
        measured = got.get(sect) or {}
        for name, t in (truth.get(sect) or {}).items():
            g = measured.get(name) or {}
            if g.get(field) is None or not g.get(ufield) or t.get(field) is None:
                continue
            errs.append(((g[field] - t[field]) * scale, g[ufield] / 2.0))
        if len(errs) < 3:
            continue
        mean = sum(e for e, _ in errs) / len(errs)
        f = math.sqrt(len(errs) / (len(errs) - 1.0))
        out[kind] = [(e - mean) / u * f for e, u in errs]
    return out


def stats(v):
    if not v:
        return "   (none)"
    rms = math.sqrt(sum(x * x for x in v) / len(v))
    mx = max(v, key=abs)
    return "n %4d  mean %+7.3f  rms %6.3f  max %+7.3f" % (len(v), sum(v) / len(v), rms, mx)


def read_cloud(path):
    data = open(path, "rb").read()
    if data.startswith(b"ply"):
        end = data.index(b"end_header\n") + len(b"end_header\n")
        head = data[:end].decode("ascii").splitlines()
        n = int([h for h in head if h.startswith("element vertex")][0].split()[2])
        props = [h.split() for h in head if h.startswith("property")]
        assert "binary_little_endian" in data[:end].decode() and all(p[1] == "double" for p in props)
        v = struct.unpack_from("<%dd" % (n * len(props)), data, end)
        return [v[i * len(props):i * len(props) + 3] for i in range(n)]
    pts = []
    for line in data.decode().splitlines():
        line = line.split("#")[0].replace(",", " ").replace(";", " ").split()
        if len(line) >= 3:
            pts.append(tuple(float(x) for x in line[:3]))
    return pts


def add_surroundings(d, kind, seed, table_share=2.0):
    """Appends the surroundings `kind` (adapter, table, posts, vise,
    angle_plate or tilted: see the
    module doc) to the cloud in d, in the cloud's pose; rewrites it in its
    format."""
    truth = json.load(open(os.path.join(d, "truth.json")))
    pose = truth.get("pose") or truth["cloud"]["pose"]
    R, t = pose["R"], pose["t_mm"]
    noise = (truth.get("cloud") or {}).get("noise_um", 1.0) * 1e-3
    name = [f for f in os.listdir(d) if f.startswith("piece.") and f[-3:] in ("ply", "xyz")][0]
    path = os.path.join(d, name)
    pts = read_cloud(path)
    rng = generate.random.Random(seed)
    n = len(pts)
    w = []
    table_z = -54.0 if kind == "adapter" else -24.0
    if kind == "posts":
        # three clamp posts (studs) standing on the table beside the piece,
        # 16 mm across, their tops 30, 40 and 50 mm above the piece's top
        for k, top in enumerate((30.0, 40.0, 50.0)):
            a0 = rng.uniform(0, 2 * math.pi) if k == 0 else a0 + 2 * math.pi / 3
            px, py = 125.0 * math.cos(a0), 125.0 * math.sin(a0)
            for _ in range(n // 10):
                a = rng.uniform(0, 2 * math.pi)
                if rng.random() < 0.8:   # the wall
                    r, z = 8.0 + rng.gauss(0, noise), rng.uniform(table_z, top)
                else:                    # the top
                    r, z = 8.0 * math.sqrt(rng.random()), top + rng.gauss(0, noise)
                w.append((px + r * math.cos(a), py + r * math.sin(a), z))
    if kind == "adapter":
        for _ in range(n // 5):
            a = rng.uniform(0, 2 * math.pi)
            r = 90.0 + rng.gauss(0, noise)
            w.append((r * math.cos(a), r * math.sin(a), rng.uniform(-54.0, -24.5)))
    if kind == "vise":
        table_z = -90.0
        phi = rng.uniform(0, 2 * math.pi)     # the jaws' direction in W
        c, s = math.cos(phi), math.sin(phi)
        vise = []
        for _ in range(n // 4):
            side = 1.0 if rng.random() < 0.5 else -1.0
            f = rng.random()
            if f < 0.5:      # a jaw's top
                u, v, z = side * rng.uniform(100.5, 130.5), rng.uniform(-75, 75), -20.5 + rng.gauss(0, noise)
            elif f < 0.75:   # a jaw's outer face
                u, v, z = side * (130.5 + rng.gauss(0, noise)), rng.uniform(-75, 75), rng.uniform(-24, -20.5)
            else:            # a jaw's inner face where the disc does not hide it
                v = rng.uniform(-75, 75)
                if abs(v) < 30.0:
                    continue
                u, z = side * (100.5 + rng.gauss(0, noise)), rng.uniform(-24, -20.5)
            vise.append((u, v, z))
        for _ in range(n // 2):  # the vise's base around the piece and the jaws
            u, v = rng.uniform(-180, 180), rng.uniform(-100, 100)
            if math.hypot(u, v) < 101.0 or (100.5 <= abs(u) <= 130.5 and abs(v) <= 75):
                continue
            vise.append((u, v, -24.0 + rng.gauss(0, noise)))
        w.extend((c * u - s * v, s * u + c * v, z) for u, v, z in vise)
    if kind == "angle_plate":
        phi = rng.uniform(0, 2 * math.pi)
        c, s = math.cos(phi), math.sin(phi)
        half = rng.uniform(60.0, 125.0)   # half the plate's width
        plate = []
        for _ in range(n // 2):
            f = rng.random()
            if f < 0.75:     # the face towards the piece
                u, v, z = 105.0 + rng.gauss(0, noise), rng.uniform(-half, half), rng.uniform(-24, 60)
            elif f < 0.9:    # its top edge
                u, v, z = rng.uniform(105, 130), rng.uniform(-half, half), 60.0 + rng.gauss(0, noise)
            else:            # its ends
                u, v, z = rng.uniform(105, 130), math.copysign(half, rng.random() - 0.5) + rng.gauss(0, noise), \
                    rng.uniform(-24, 60)
            plate.append((u, v, z))
        w.extend((c * u - s * v, s * u + c * v, z) for u, v, z in plate)
    tilt = None
    if kind == "tilted":
        a, phi = math.radians(rng.uniform(0.5, 3.0)), rng.uniform(0, 2 * math.pi)
        tilt = (math.tan(a) * math.cos(phi), math.tan(a) * math.sin(phi))
        table_z = -26.0
    cx, cy = rng.uniform(-100, 100), rng.uniform(-100, 100)
    n_before = len(w)
    while len(w) < n_before + int(table_share * n):
        x, y = cx + rng.uniform(-300, 300), cy + rng.uniform(-250, 250)
        if math.hypot(x, y) < 101.0:
            continue
        if kind == "angle_plate" and 104.0 < x * c + y * s < 131.0 and abs(-x * s + y * c) < half + 1.0:
            continue
        z = table_z + (tilt[0] * x + tilt[1] * y if tilt else 0.0)
        w.append((x, y, z + rng.gauss(0, noise)))
    extra = [tuple(R[i][0] * p[0] + R[i][1] * p[1] + R[i][2] * p[2] + t[i] for i in range(3)) for p in w]
    allp = list(pts) + extra
    rng.shuffle(allp)
    if name.endswith(".ply"):
        head = ("ply\nformat binary_little_endian 1.0\ncomment outside generator, with %s\n"
                "element vertex %d\nproperty double x\nproperty double y\nproperty double z\n"
                "end_header\n" % (kind, len(allp)))
        flat = [c for p in allp for c in p]
        open(path, "wb").write(head.encode("ascii") + struct.pack("<%dd" % len(flat), *flat))
    else:
        open(path, "w").write("# outside generator, with %s\n" % kind +
                              "".join("%.6f %.6f %.6f\n" % p for p in allp))
    return len(extra)


def surface_of(p, tol=0.02):
    """The nominal surface a W point lies on (within tol mm), else 'off'."""
    x, y, z = p
    r = math.hypot(x, y)
    if abs(z) < tol:
        return "top"
    u = (math.cos(math.radians(60)), math.sin(math.radians(60)))
    if -0.3 - tol < z < 0 and abs(-x * u[1] + y * u[0]) < 0.3 + tol and 69 < x * u[0] + y * u[1] < 91:
        return "mark"
    if abs(abs(y) - 53.0) < tol and -12.0 <= z <= 0:
        return "flank"
    if abs(z + 12.1) < tol and abs(y) < 53:
        return "strip"
    for s, c in generate.CENTRES_DEG.items():
        for j in range(1, 10):
            ph = math.radians(c + (j - 5) * 6)
            n, t = (math.cos(ph), math.sin(ph)), (-math.sin(ph), math.cos(ph))
            if abs(x * n[0] + y * n[1] - 97.3) < tol and abs(x * t[0] + y * t[1]) < 5.2 and -12.2 < z < 0:
                return "facet"
    for d in (199.0, 200.0, 201.0):
        if abs(r - d / 2) < tol:
            return "cyl%d" % d
    if abs(z + 14.0) < tol or (abs(abs(x) - 5.0) < tol and z > -14.0):
        return "small_notch"
    return "off"


def cloud_stats(d):
    """Points per surface and their extents in W (the truth's pose)."""
    truth = json.load(open(os.path.join(d, "truth.json")))
    pose = truth.get("pose") or truth["cloud"]["pose"]
    R, t = pose["R"], pose["t_mm"]
    cloud = [f for f in os.listdir(d) if f.startswith("piece.") and f[-3:] in ("ply", "xyz")][0]
    pts = read_cloud(os.path.join(d, cloud))
    by = {}
    for c in pts:
        q = [c[i] - t[i] for i in range(3)]
        w = tuple(sum(q[i] * R[i][j] for i in range(3)) for j in range(3))   # W = (cloud - t) R
        by.setdefault(surface_of(w), []).append(w)
    print("%s (%s, %d points): points per surface, x y z ranges in W (mm)" % (d, cloud, len(pts)))
    for k in ["top", "mark", "flank", "facet", "strip", "cyl199", "cyl200", "cyl201", "small_notch", "off"]:
        v = by.get(k, [])
        if v:
            print("  %-11s %6d  x [%7.2f %7.2f]  y [%7.2f %7.2f]  z [%7.3f %7.3f]" % (
                k, len(v), min(p[0] for p in v), max(p[0] for p in v), min(p[1] for p in v),
                max(p[1] for p in v), min(p[2] for p in v), max(p[2] for p in v)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ttp", default="build/app/ttp")
    ap.add_argument("--runs", type=int, default=6)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--effect", default="none")
    ap.add_argument("--size", default="0")
    ap.add_argument("--points", type=int, default=20000)
    ap.add_argument("--stats", action="store_true",
                    help="only the points per surface and their ranges of the DIRs' clouds, in W "
                         "from truth.json's pose (the samples' or the generator's); no ttp")
    ap.add_argument("--surroundings", choices=["none", "adapter", "table", "posts", "vise", "angle_plate", "tilted", "both",
                             "fixtures"], default="none",
                    help="add the adapter and the machine table, a CMM table, a CMM table with clamp posts, "
                         "a vise, an angle plate or a tilted table to each cloud")
    ap.add_argument("--table-share", type=float, default=2.0,
                    help="points on the table per point on the piece (--surroundings)")
    ap.add_argument("--limits", action="store_true",
                    help="exit 1 also when a figure or facet distance is off by more than 1 um, "
                         "or a facet angle by more than 100 urad")
    ap.add_argument("dirs", nargs="*")
    a = ap.parse_args()
    if a.stats:
        for d in a.dirs:
            cloud_stats(d)
        return 0
    work = tempfile.mkdtemp(prefix="ttp-cloud-")
    try:
        dirs = a.dirs
        if not dirs:
            size = a.size if "+" in a.size else float(a.size)
            for i in range(a.runs):
                d = os.path.join(work, "r%d" % i)
                generate.generate(d, a.effect, size, a.seed + i, 300.0, False, "cloud", a.points)
                if a.surroundings != "none":
                    kind = {"both": ("adapter", "table")[i % 2],
                            "fixtures": ("vise", "angle_plate", "tilted")[i % 3]}.get(a.surroundings,
                                                                                   a.surroundings)
                    add_surroundings(d, kind, a.seed + i, a.table_share)
                dirs.append(d)
        total = {}
        bad = refused = 0
        zs = {}
        for d in dirs:
            truth = json.load(open(os.path.join(d, "truth.json")))
            cloud = [f for f in os.listdir(d) if f.startswith("piece.") and f[-3:] in ("ply", "xyz")][0]
            truth.setdefault("seed", "?")
            got, rc, err = inspect(a.ttp, os.path.join(d, cloud), os.path.join(work, "inspect.json"))
            c = truth.get("cloud", {})
            head = "%s seed %s %s pose %s, %s points, noise %.2f um" % (
                d, truth["seed"], cloud, c.get("pose", {}).get("kind"), c.get("points"),
                c.get("noise_um", truth.get("noise_um", 0)))
            if got is None:
                print(head + ": ttp inspect exit %d: %s" % (rc, err.splitlines()[-1:] if err else ""))
                bad += 1
                refused += 1
                continue
            diff = compare(truth, got)
            figure_devs = [abs(x) for k in ("E_X", "E_Y", "E_Z", "E_TTP") for x in diff[k]]
            dev = max(figure_devs or [float("nan")])
            print(head + ": warnings %d, figures off by up to %.2f um, top face rms %.2f um" % (
                len(got.get("warnings") or []), dev, (got.get("alignment") or {}).get("top_face_rms_um", float("nan"))))
            for w in got.get("warnings") or []:
                print("   warning: %s" % w)
            worst_um = max(figure_devs + [abs(x) for x in diff["facet d um"]] or [0.0])
            worst_urad = max([abs(x) for x in diff["facet angle urad"]] or [0.0])
            if a.limits and (worst_um > 1.0 or worst_urad > 100.0):
                print("   beyond the limits: %.2f um, %.0f urad" % (worst_um, worst_urad))
                bad += 1
            for k, v in diff.items():
                total.setdefault(k, []).extend(v)
            for k, v in scatter_z(truth, got).items():
                zs.setdefault(k, []).extend(v)
        print("measured - truth over %d runs (%d refused; %d beyond the limits):" % (
            len(dirs) - refused, refused, bad - refused))
        pairs = total.pop("angle pairs", [])
        for k, v in total.items():
            print("  %-18s %s" % (k, stats(v)))
        if pairs:
            st = sum(t * t for t, _ in pairs)
            print("  facet angles: truth RMS %.1f urad, slope of measured on truth %.3f" % (
                math.sqrt(st / len(pairs)), sum(t * m for t, m in pairs) / st if st else float("nan")))
        scatter_bad = 0
        if zs:
            print("each feature against its own scatter (U_scatter / 2), the run's common part out:")
        for k, v in zs.items():
            rms = math.sqrt(sum(z * z for z in v) / len(v))
            cover = sum(1 for z in v if abs(z) <= 2.0) / len(v)
            off = (a.limits and len(v) >= SCATTER_MIN_FEATURES and
                   not SCATTER_RMS_Z_BAND[0] <= rms <= SCATTER_RMS_Z_BAND[1])
            scatter_bad += off
            print("  %-18s n %4d  RMS z %.2f  within 2u %.1f %%%s" % (
                k, len(v), rms, 100 * cover,
                "  beyond the band %.2f-%.2f" % SCATTER_RMS_Z_BAND if off else ""))
        return 1 if bad or scatter_bad else 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())

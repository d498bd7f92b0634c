#!/usr/bin/env python3
"""Outside generator: a TALC log and a measured piece, written from the
customer's specs alone (../shared/spec/test-piece.md, talc-log.md,
measurements.md, diagnosis.md rev. 2) and the thesis (R-test noise of table
5.4). It shares no code and no parameterisation with the project's sim/.

Usage: generate.py --effect NAME[+NAME] [--size S[+S]] --seed N [--spacing-s 300|adaptive]
                   [--compensation off|on] [--measurement json|dial|cloud|dmis|probe]
                   [--probe-points FILE]
                   [--points 20000] [--cloud-format auto|ply|xyz] [--pose auto|table|any]
                   [--rtest-noise-scale 1] [--machine-gain-scale 1] -o DIR
Writes DIR/talc.csv, DIR/piece.json, DIR/dial.csv, DIR/piece.ply,
DIR/piece.xyz, DIR/piece.dmo or DIR/probe.csv, and DIR/truth.json.
Robustness stresses (default 1: the R-test of table 5.4 and the machine as
written): --rtest-noise-scale F multiplies the R-test noise by F,
--machine-gain-scale F the machine's thermal error gains by F (the table's
temperature, read from ER0T, and with it a workpiece expansion, grow by F
too); the random draws are the same whatever F.
Python 3 standard library only.
"""
import argparse
import bisect
import json
import math
import os
import random
import struct

# ---------------------------------------------------------------- constants
R_FACET_MM = 97.3          # finished facet plane distance (test-piece.md 2)
CUTTER_R_MM = 6.0          # 12 mm finishing end mill
Z_TOP_MM = 54.0            # W origin at M z = 54 (adapter 30 + piece 24)
Z_FLOOR_W_MM = -12.1       # strip floor / facet bottom in W
SPHERE_MM = 160.0          # d/2
ALPHA_PIECE = 23.4         # um/(m K), EN AW-6082
ALPHA_TABLE = 11.0         # um/(m K), cast iron
CYCLE0_S = 320.0           # the program's t = 0 in log time
CYCLE_S = 3600.0
FEATURE_OFFSETS_S = {"Z": 0.0, "X1": 10.0, "X2": 17.0, "Y1": 27.0, "Y2": 34.0}
CENTRES_DEG = {"X1": 60.0, "Y1": 120.0, "X2": 240.0, "Y2": 300.0}
NORMAL_M = {"X1": (1.0, 0.0), "X2": (-1.0, 0.0), "Y1": (0.0, 1.0), "Y2": (0.0, -1.0)}
ERRS = ["EX0C", "EY0C", "EZ0T", "ER0T", "EA0C", "EB0C", "EC0C"]
# thesis table 5.4: expanded uncertainty U (k = 2) of the R-test: um, um/m
RTEST_U = {"EX0C": 0.4, "EY0C": 0.5, "EZ0T": 0.4, "ER0T": 0.6,
           "EA0C": 2.3, "EB0C": 2.5, "EC0C": 2.6}
RTEST_DUR_S = 95.0

CATALOGUE = ["workpiece_expansion", "tool_wear", "clamping_distortion",
             "c_axis_indexing"]
OUTSIDE = ["step", "two_lobe", "strip_drift"]
# more effects outside the catalogue, not in the battery's rotation (its
# runs and seeds stay as they were): every facet angle drifting over the
# cycles (the piece turning on its fixture, a C offset the R-tests do not
# see), the spindle's axial growth with its heat (strips deeper, facets
# alone unchanged), and an offset of every feature of a cycle along its
# normal, drawn per cycle (tool length and radius set again each cycle)
OUTSIDE_MORE = ["angle_drift", "spindle_growth", "cycle_jitter"]
MISMATCH = ["other_log", "short_log"]


def jprime(k):
    return k if k <= 4 else k + 1


def cut_schedule():
    """(t_s, feature, set, j, commanded C deg) in cutting order."""
    cuts = []
    for k in range(9):
        j = 5 if k == 0 else jprime(k)
        t0 = CYCLE0_S + k * CYCLE_S
        c = CENTRES_DEG["X1"] + (j - 5) * 6.0
        cuts.append((t0, "Z%d" % (5 if k == 0 else jprime(k)), "Z", j, 0.0, k))
        for s in ("X1", "X2", "Y1", "Y2"):
            cc = c if s[0] == "X" else c - 30.0
            cuts.append((t0 + FEATURE_OFFSETS_S[s], "%s-%d" % (s, j), s, j, cc, k))
    return cuts


# ------------------------------------------------------------ the machine
class Machine:
    """Seven C-axis errors as the response of a few thermal paths to the
    C-axis heat (linear and squared in speed), the spindle and the room.
    Each path is a first- or second-order lag; each error is a random mix
    of the paths. The state is integrated exactly for piecewise constant
    inputs (10 s steps). gain_scale multiplies every gain (a machine with
    larger thermal errors); the random draws do not depend on it."""

    def __init__(self, rng, gain_scale=1.0):
        self.rng = rng
        # paths: (input, time constants)
        self.paths = [("c", (rng.uniform(600, 1500),)),
                      ("c", (rng.uniform(2000, 4000), rng.uniform(1500, 3000))),
                      ("s", (rng.uniform(300, 900),)),
                      ("env", (rng.uniform(3000, 8000),))]
        # steady-state gain of each error on each path (um, um/m per unit)
        base = {"EX0C": 1.5, "EY0C": 3.0, "EZ0T": -9.0, "ER0T": 5.0,
                "EA0C": -6.0, "EB0C": 2.5, "EC0C": -6.0}
        self.gain = {}
        for e in ERRS:
            b = base[e] * rng.uniform(0.5, 1.5)
            w = [rng.uniform(0.3, 1.0), rng.uniform(0.3, 1.0)]
            self.gain[e] = [b * w[0] / sum(w), b * w[1] / sum(w),
                            base[e] * rng.uniform(-0.15, 0.15),
                            base[e] * rng.uniform(-0.5, 0.5)]
            self.gain[e] = [g * gain_scale for g in self.gain[e]]
        self.c_lin = rng.uniform(0.2, 0.5)   # share of heat linear in speed
        # the machine did not start cold: a random earlier load
        self.state = []
        pre = rng.uniform(0.0, 0.6)
        for inp, taus in self.paths:
            self.state.append([pre if inp == "c" else 0.0] * len(taus))
        self.env0 = rng.uniform(19.0, 21.0)
        self.env_amp = rng.uniform(0.3, 1.0)
        self.env_phase = rng.uniform(0, 2 * math.pi)

    def env(self, t):
        return self.env0 + self.env_amp * math.sin(2 * math.pi * t / 86400.0 + self.env_phase)

    def heat(self, inp, c_rpm, sp_rpm, t):
        if inp == "c":
            x = c_rpm / 1200.0
            return self.c_lin * x + (1 - self.c_lin) * x * x
        if inp == "s":
            return (sp_rpm / 8000.0) ** 2
        return self.env(t) - self.env0

    def step(self, dt, c_rpm, sp_rpm, t):
        for p, (inp, taus) in enumerate(self.paths):
            u = self.heat(inp, c_rpm, sp_rpm, t)
            st = self.state[p]
            for i, tau in enumerate(taus):
                a = math.exp(-dt / tau)
                st[i] = a * st[i] + (1 - a) * u
                u = st[i]

    def errors(self):
        last = [st[-1] for st in self.state]
        out = {}
        for e in ERRS:
            acc = 0
            for g, x in zip(self.gain[e], last):
                acc += g * x
            out[e] = acc
        return out


def displacement(E, x, y, z):
    """test-piece.md section 6: table point displacement (um) at machine
    position (mm); E in um and um/m."""
    dx = E["EB0C"] * z * 1e-3 + E["EX0C"] + E["ER0T"] * x / SPHERE_MM - E["EC0C"] * y * 1e-3
    dy = E["EY0C"] + E["ER0T"] * y / SPHERE_MM - E["EA0C"] * z * 1e-3 + E["EC0C"] * x * 1e-3
    dz = -E["EB0C"] * x * 1e-3 + E["EZ0T"] + E["EA0C"] * y * 1e-3
    return dx, dy, dz


def normal_shift(E, P, n, p, q):
    """n . (o(q) - dP(p)) in um (P: predicted errors, None = comp off)."""
    d = displacement(E, *p)
    o = displacement(P, *q) if P is not None else (0.0, 0.0, 0.0)
    return sum(n[i] * (o[i] - d[i]) for i in range(3))


# ------------------------------------------------------------- the effects
class Effect:
    def __init__(self, name, size, rng):
        self.name, self.size = name, size
        self.params = {}
        if name == "workpiece_expansion":
            self.params = {"gain": size, "tau_wp_s": rng.uniform(1500, 4000)}
        elif name == "tool_wear":
            self.params = {"wear_um_per_m": size}
        elif name == "clamping_distortion":
            self.params = {"amplitude_um": size * rng.choice([-1, 1]),
                           "phase_jitter_deg": rng.uniform(-8, 8)}
        elif name == "c_axis_indexing":
            # encoder eccentricity (1/turn), worm (2/turn), bearing (4/turn)
            self.params = {"harmonics": [
                [1, size, rng.uniform(0, 360)],
                [2, size * rng.uniform(0.4, 0.8), rng.uniform(0, 360)],
                [4, size * rng.uniform(0.2, 0.5), rng.uniform(0, 360)]]}
        elif name == "step":
            self.params = {"step_um": size * rng.choice([-1, 1]),
                           "from_cycle": rng.randint(3, 7)}
        elif name == "two_lobe":
            self.params = {"amplitude_um": size, "phase_deg": rng.uniform(0, 180)}
        elif name == "strip_drift":
            self.params = {"total_um": size * rng.choice([-1, 1])}
        elif name == "angle_drift":
            self.params = {"total_urad": size * rng.choice([-1, 1])}
        elif name == "spindle_growth":
            self.params = {"growth_um": size, "tau_s": rng.uniform(1200, 3600)}
        elif name == "cycle_jitter":
            self.params = {"offsets_um": [rng.gauss(0, size) for _ in range(10)]}

    def c_error_urad(self, c_deg):
        if self.name != "c_axis_indexing":
            return 0.0
        return sum(a * math.cos(math.radians(k * c_deg + ph))
                   for k, a, ph in self.params["harmonics"])

    def lobes(self):
        """(count, amplitude um, phase deg) of an elastic pattern in W."""
        if self.name == "clamping_distortion":
            return 3, self.params["amplitude_um"], 60.0 + self.params["phase_jitter_deg"]
        if self.name == "two_lobe":
            return 2, self.params["amplitude_um"], self.params["phase_deg"]
        return None


class Effects:
    """Several effects acting at once (each adds to the piece)."""

    def __init__(self, effs):
        self.effs = effs
        self.params = {n: e.params for n, e in effs.items()} if len(effs) > 1 else \
            next(iter(effs.values())).params

    def c_error_urad(self, c_deg):
        return sum(e.c_error_urad(c_deg) for e in self.effs.values())

    def lobes(self):
        return [e.lobes() for e in self.effs.values() if e.lobes()]


# --------------------------------------------------------------- one run
def check_scale(name, f):
    """A stress factor: finite and > 0."""
    f = float(f)
    if not (math.isfinite(f) and f > 0.0):
        raise ValueError("%s must be finite and > 0, got %r" % (name, f))
    return f


# An adaptive TALC (thesis 6.2-6.3) measures often while the machine
# changes fast and seldom while it settles: every 30 min for the 2 h after a
# load change (the C axis starts turning at cycle 0; the cool-down starts at
# cycle 4), every 2 h otherwise, but no later than 30 min after a load
# change that falls inside a long interval; never during a cut (a
# measuring cycle that would overlap one starts when the cut has ended).
# The controller knows the load changes from the program, not from the
# machine's response.
ADAPTIVE_DENSE_S = 1800.0
ADAPTIVE_SPARSE_S = 7200.0
ADAPTIVE_SETTLE_S = 7200.0


def parse_spacing(text):
    """--spacing-s: seconds between R-tests, or 'adaptive'."""
    if str(text) == "adaptive":
        return "adaptive"
    return check_scale("spacing_s", text)


def rtest_times(spacing_s, last_cut):
    """R-test row times (the end of each measurement cycle): the first at
    95 s, then every spacing_s (or the adaptive schedule) while before the
    last cut, and one 150 s after the last cut (production closes the log
    with an R-test)."""
    rt = [95.0]
    if spacing_s == "adaptive":
        changes = [CYCLE0_S, CYCLE0_S + 4 * CYCLE_S]
        cycle_starts = [CYCLE0_S + k * CYCLE_S for k in range(9)]
        t = rt[0]
        while True:
            if any(c <= t < c + ADAPTIVE_SETTLE_S for c in changes):
                t_next = t + ADAPTIVE_DENSE_S
            else:
                t_next = t + ADAPTIVE_SPARSE_S
                inside = [c for c in changes if t < c < t_next]
                if inside:
                    t_next = min(t_next, inside[0] + ADAPTIVE_DENSE_S)
            # the controller measures between cuts: a cycle that would
            # overlap a cut starts when the cut has ended
            for c in cycle_starts:
                if t_next - RTEST_DUR_S - 10.0 < c + 45.0 and t_next + 5.0 > c - 20.0:
                    t_next = c + 45.0 + RTEST_DUR_S + 10.0
            if t_next >= last_cut:
                break
            rt.append(t_next)
            t = t_next
    else:
        t = 95.0 + spacing_s
        while t < last_cut:
            rt.append(t)
            t += spacing_s
    rt.append(last_cut + 150.0)
    return rt


def simulate(seed, effect, size, spacing_s, comp_on, rtest_noise_scale=1.0, machine_gain_scale=1.0):
    """One run. rtest_noise_scale multiplies the R-test noise of table 5.4,
    machine_gain_scale the Machine's thermal error gains (1: as written)."""
    rtest_noise_scale = check_scale("rtest_noise_scale", rtest_noise_scale)
    machine_gain_scale = check_scale("machine_gain_scale", machine_gain_scale)
    rng = random.Random(seed)
    m = Machine(rng, machine_gain_scale)
    # "a+b": two effects at once, each of the given size (sizes "s1+s2")
    names = effect.split("+")
    sizes = [float(x) for x in str(size).split("+")] if isinstance(size, str) else [size] * len(names)
    effs = {n: Effect(n, s, rng) for n, s in zip(names, sizes)}
    eff = Effects(effs)
    cuts = cut_schedule()
    last_cut = cuts[-1][0]
    # R-test times (row time = end of the cycle)
    rt = rtest_times(spacing_s, last_cut)
    t_end = rt[-1] + 60.0
    cut_windows = [(CYCLE0_S + k * CYCLE_S - 20.0, CYCLE0_S + k * CYCLE_S + 45.0) for k in range(9)]

    def c_speed(t):
        if t < -2700 or (-2700 <= t < -2400 and False):
            return 0.0
        if -2700 <= t < -2400:          # step 1: turning the outer profile
            return 600.0
        if t < CYCLE0_S + 45.0:         # pre-machining rest and NC hold
            return 0.0
        if t >= CYCLE0_S + 4 * CYCLE_S:  # cool-down
            return 0.0
        for a, b in cut_windows:
            if a <= t < b:
                return 0.0
        for r in rt:
            if r - RTEST_DUR_S - 10 <= t < r + 5:
                return 0.0
        return 1200.0

    def sp_speed(t):
        if -2400 <= t < -1800:          # steps 2-5
            return 8000.0
        for a, b in cut_windows:
            if a <= t < b:
                return 8000.0
        return 0.0

    # integrate from before pre-machining; keep the state on a 10 s grid
    dt = 10.0
    t0 = -3000.0
    grid = {}
    env = {}
    tt = t0
    n = int((t_end - t0) / dt) + 2
    for i in range(n):
        grid[round(tt, 1)] = m.errors()
        env[round(tt, 1)] = m.env(tt)
        m.step(dt, c_speed(tt), sp_speed(tt), tt)
        tt += dt

    def at(t):
        k = math.floor((t - t0) / dt)
        a = t0 + k * dt
        e0, e1 = grid[round(a, 1)], grid[round(a + dt, 1)]
        w = (t - a) / dt
        return {e: e0[e] * (1 - w) + e1[e] * w for e in ERRS}

    ref = at(rt[0] - RTEST_DUR_S / 2)

    def rel(t):
        a = at(t)
        return {e: a[e] - ref[e] for e in ERRS}

    # R-tests: noise of table 5.4 (sigma = U / 2, times rtest_noise_scale);
    # values relative to the first R-test, which carries its own noise into
    # all of them
    noise = [{e: rng.gauss(0, RTEST_U[e] / 2 * rtest_noise_scale) for e in ERRS} for _ in rt]
    meas = []
    for i, r in enumerate(rt):
        tr = rel(r - RTEST_DUR_S / 2)
        meas.append({e: tr[e] + noise[i][e] - noise[0][e] for e in ERRS})

    # the compensation in force: TALC's model, re-anchored at every R-test,
    # follows 75 % of the machine's change since (an imperfect model)
    G_PRED = 0.75

    def pred(t):
        if not comp_on:
            return None
        last = bisect.bisect_right(rt, t) - 1   # rt is increasing
        if last < 0:
            return {e: 0.0 for e in ERRS}
        base = rel(rt[last] - RTEST_DUR_S / 2)
        now = rel(t)
        return {e: meas[last][e] + G_PRED * (now[e] - base[e]) for e in ERRS}

    # ---- the piece
    # datum X direction: big-notch flanks cut at C = 0 in pre-machining
    t_notch = -2150.0
    datum_urad = eff.c_error_urad(0.0) - rel(t_notch)["EC0C"]

    # lumped aluminium mass (piece + adapter) lagging the table temperature
    piece_T = {}
    if "workpiece_expansion" in effs:
        g, tau = effs["workpiece_expansion"].params["gain"], effs["workpiece_expansion"].params["tau_wp_s"]
        Tp = 0.0
        tt = t0
        for i in range(n - 1):
            Tt = grid[round(tt, 1)]["ER0T"] / (ALPHA_TABLE * SPHERE_MM * 1e-3)
            a = math.exp(-dt / tau)
            Tp = a * Tp + (1 - a) * g * Tt
            piece_T[round(tt + dt, 1)] = Tp
            tt += dt

    def piece_dT(t):
        k = math.floor((t - t0) / dt)
        return piece_T.get(round(t0 + k * dt, 1), 0.0)

    path_mm = 0.0
    features = {}
    first_cut_t = min(c[0] for c in cuts) - 3.0
    for (tc, name, s, j, c_cmd, k) in cuts:
        t_cut = tc - 3.0   # the row marks the end of the cut
        E = rel(t_cut)
        P = pred(t_cut)
        if s == "Z":
            y = (j - 5) * 11.75
            zc = Z_TOP_MM + Z_FLOOR_W_MM
            n3 = (0.0, 0.0, 1.0)
            u0 = normal_shift(E, P, n3, (0.0, y, zc), (0.0, y, zc))
            u1 = normal_shift(E, P, n3, (1.0, y, zc), (1.0, y, zc))
            depth_um = -u0
            beta_urad = (u1 - u0) * 1000.0
            if "workpiece_expansion" in effs:
                depth_um += ALPHA_PIECE * piece_dT(t_cut) * zc * 1e-3
            if "strip_drift" in effs:
                depth_um += effs["strip_drift"].params["total_um"] * k / 8.0
            if "spindle_growth" in effs:
                g = effs["spindle_growth"].params
                depth_um += g["growth_um"] * (1 - math.exp(-max(0.0, t_cut - first_cut_t) / g["tau_s"]))
            if "cycle_jitter" in effs:
                depth_um += effs["cycle_jitter"].params["offsets_um"][k]
            half = math.sqrt(101.5 ** 2 - y * y)
            path_mm += 2 * (half - 5.0)
            features[name] = {"depth_um": depth_um, "beta_urad": beta_urad, "t": t_cut, "cycle": k,
                              "machine_errors": E}
            continue
        nx, ny = NORMAL_M[s]
        n3 = (nx, ny, 0.0)
        tx, ty = -ny, nx
        zm = Z_TOP_MM - 6.0                # middle of the facet's height
        p0 = (R_FACET_MM * nx, R_FACET_MM * ny, zm)
        q0 = ((R_FACET_MM + CUTTER_R_MM) * nx, (R_FACET_MM + CUTTER_R_MM) * ny, zm)
        u0 = normal_shift(E, P, n3, p0, q0)
        p1 = (p0[0] + tx, p0[1] + ty, zm)
        q1 = (q0[0] + tx, q0[1] + ty, zm)
        u1 = normal_shift(E, P, n3, p1, q1)
        dist_um = u0
        ang_urad = -(u1 - u0) * 1000.0     # normal turned by -du/ds
        phi = CENTRES_DEG[s] + (j - 5) * 6.0
        ang_urad += eff.c_error_urad(c_cmd) - datum_urad
        if "workpiece_expansion" in effs:
            dist_um -= (ALPHA_PIECE * piece_dT(t_cut) - E["ER0T"] / (SPHERE_MM * 1e-3)) * R_FACET_MM * 1e-3
        if "tool_wear" in effs:
            dist_um += effs["tool_wear"].params["wear_um_per_m"] * (path_mm + 6.1) * 1e-3
        for lob in eff.lobes():
            nl, amp, ph = lob
            a = math.radians(nl * (phi - ph))
            dist_um -= amp * math.cos(a)                       # spring-back
            ang_urad += -nl * amp * math.sin(a) / R_FACET_MM * 1000.0
        if "step" in effs and k >= effs["step"].params["from_cycle"]:
            dist_um += effs["step"].params["step_um"]
        if "angle_drift" in effs:
            ang_urad += effs["angle_drift"].params["total_urad"] * k / 8.0
        if "cycle_jitter" in effs:
            dist_um += effs["cycle_jitter"].params["offsets_um"][k]
        path_mm += 12.2
        features[name] = {"dist_um": dist_um, "angle_urad": ang_urad, "t": t_cut, "cycle": k,
                          "machine_errors": E}

    # ---- the log rows
    cut_rows = {round(c[0], 1): c for c in cuts}
    rows = []
    times = sorted(set([round(x * 60.0, 1) for x in range(int(t_end // 60) + 1)] +
                       [round(r, 1) for r in rt] + list(cut_rows)))
    for t in times:
        Pt = pred(t)
        predcols = {("pred_" + e): Pt[e] for e in ERRS} if Pt else {}
        if t in cut_rows:
            c = cut_rows[t]
            rows.append(dict(t_s=t, event="cut", spindle_rpm=8000, feature=c[1], c_deg=c[4], **predcols))
        if t in rt:
            i = rt.index(t)
            v = {e: meas[i][e] - (pred(t - RTEST_DUR_S / 2)[e] if comp_on else 0.0) for e in ERRS}
            rows.append(dict(t_s=t, event="rtest", dur_s=RTEST_DUR_S, **v, **predcols))
        if abs(t / 60.0 - round(t / 60.0)) < 1e-9:
            cs = c_speed(t)
            rows.append(dict(t_s=t, event="sample", T_env=env[round(math.floor(t / 10) * 10, 1)],
                             T_ws=env[round(math.floor(t / 10) * 10, 1)] + 0.6 + 0.3 * m.heat("c", cs, 0, t),
                             dT_cool=0.05 * (cs / 1200.0) ** 2, c_rpm=cs, spindle_rpm=sp_speed(t),
                             mwf=0, c_deg=0.0, **predcols))
    return {"rows": rows, "features": features, "rtests": rt, "effect": eff,
            "comp": comp_on, "t_end": t_end}


# ------------------------------------------------------------ the outputs
COLS = ["t_s", "event", "T_env", "T_ws", "dT_cool", "c_rpm", "spindle_rpm", "mwf"] + ERRS + \
       ["pred_" + e for e in ERRS] + ["feature", "c_deg", "dur_s"]


def write_log(path, rows, comp_on, start="2026-03-02T06:00:00+01:00"):
    cols = COLS if comp_on else [c for c in COLS if not c.startswith("pred_")]
    with open(path, "w") as f:
        f.write("# talc-log: 1\n# machine: outside generator, C-axis table\n")
        f.write("# start: %s\n# sphere_distance_mm: 160\n# sphere_height_mm: 80\n" % start)
        f.write("# compensation: %s\n" % ("on" if comp_on else "off"))
        f.write(",".join(cols) + "\n")
        for r in rows:
            out = []
            for c in cols:
                v = r.get(c, "")
                if isinstance(v, float):
                    v = "%.4f" % v
                out.append(str(v))
            f.write(",".join(out) + "\n")


SIG_D_UM, SIG_ANG_URAD, SIG_DEPTH_UM, SIG_BETA_URAD, SIG_DIAL_UM = 0.4, 6.0, 0.4, 2.0, 0.5


def figures_from(features):
    """test-piece.md section 4, from per-feature d (um, relative to
    nominal) and strip depth (um)."""
    figs = []
    d = {k: v.get("d") for k, v in features.items()}
    for i in range(1, 9):
        j = jprime(i)
        g = lambda s: d["%s-%d" % (s, j)] - d["%s-5" % s]
        ex = (g("X2") - g("X1")) / 2
        ey = (g("Y2") - g("Y1")) / 2
        ettp = -((g("X1") + g("X2")) + (g("Y1") + g("Y2"))) / 4
        ez = features["Z%d" % j]["depth"] - features["Z5"]["depth"]
        eb = features["Z%d" % j]["beta"] - features["Z5"]["beta"]
        figs.append({"cycle": i, "E_X": ex, "E_Y": ey, "E_Z": ez, "E_B": eb, "E_TTP": ettp})
    return figs


def measure(sim, kind, rng):
    f = sim["features"]
    if kind == "dial":
        lines = ["feature,reading_um"]
        for name in sorted(f):
            v = f[name]
            if name.startswith("Z"):
                if name == "Z5":
                    continue
                r = v["depth_um"] - f["Z5"]["depth_um"] + rng.gauss(0, SIG_DIAL_UM)
            else:
                s, j = name.split("-")
                if j == "5":
                    continue
                r = -(v["dist_um"] - f[s + "-5"]["dist_um"]) + rng.gauss(0, SIG_DIAL_UM)
            lines.append("%s,%.1f" % (name, r))
        return "dial.csv", "\n".join(lines) + "\n"
    facets, strips, noisy = {}, {}, {}
    for name in sorted(f):
        v = f[name]
        if name.startswith("Z"):
            dep = v["depth_um"] + rng.gauss(0, SIG_DEPTH_UM)
            bet = v["beta_urad"] + rng.gauss(0, SIG_BETA_URAD)
            strips[name] = {"depth_mm": -Z_FLOOR_W_MM + dep * 1e-3, "beta_urad": bet,
                            "U_depth_um": 2 * SIG_DEPTH_UM, "U_beta_urad": 2 * SIG_BETA_URAD}
            noisy[name] = {"depth": dep, "beta": bet}
        else:
            dd = v["dist_um"] + rng.gauss(0, SIG_D_UM)
            aa = v["angle_urad"] + rng.gauss(0, SIG_ANG_URAD)
            facets[name] = {"distance_mm": R_FACET_MM + dd * 1e-3, "angle_error_urad": aa,
                            "U_distance_um": 2 * SIG_D_UM, "U_angle_urad": 2 * SIG_ANG_URAD}
            noisy[name] = {"d": dd}
    doc = {"kind": "inspection-json", "source": "outside generator (per-feature CMM report)",
           "figures": figures_from(noisy), "facets": facets, "strips": strips,
           "units": {"U": "expanded uncertainty, k = 2"}, "warnings": []}
    return "piece.json", json.dumps(doc, indent=1, sort_keys=True) + "\n"


# ------------------------------------------------------- the point cloud
# A CMM point cloud of the finished piece, written from test-piece.md
# sections 1-5 and measurements.md section 1 only. Shares of the points per
# surface follow what a CMM program spreads over the features (and what the
# sample clouds hold): 250 per facet, 555 per strip, 800 per flank, 1800 on
# the 199 cylinder at 20,000 points.
CLOUD_SHARES = [             # (surface, share of the points on surfaces)
    ("facets", 0.450),       # 36 facets, an equal share each
    ("strips", 0.250),       # 9 strips, an equal share each
    ("top", 0.085),          # top faces of the four segments, z = 0
    ("mark", 0.005),         # the engraved groove's two flanks
    ("flanks", 0.080),       # y = +-53, an equal share each
    ("cyl199", 0.090),       # the datum cylinder (most in z -16..-14)
    ("cyl200", 0.015),
    ("cyl201", 0.015),
    ("small_notch", 0.010),  # floor z = -14 and walls x = +-5: to be ignored
]
CLOUD_STRAY_SHARE = 0.002    # dust and double hits
CLOUD_SIG_UM = (0.4, 0.6)    # Gaussian noise per point along the surface normal (drawn per run)
# where a CMM program puts its points (mm, W): inside each feature's edges
FACET_U_MM = 4.0             # facets 10.2 mm wide: +-4 mm about the middle
FACET_Z_MM = (-11.1, -1.0)   # facets z -12.1 .. 0
FLANK_Z_MM = (-11.0, -1.0)   # flanks z -12 .. 0 (the upper ends: --wall-top-mm)
STRIP_HALF_MM = 5.0          # strips 12 mm wide, 0.25 mm overlap
MARK = {"phi_deg": 60.0, "r0": 70.0, "r1": 90.0, "depth": 0.3, "half_w": 0.3}
FLANK_Y_MM = 53.0
SMALL_NOTCH_X_MM = 5.0


def _unit(v):
    n = math.sqrt(sum(c * c for c in v))
    return tuple(c / n for c in v)


def _split(total, weights):
    """Integers summing to total, proportional to weights."""
    s = sum(weights)
    out = [int(total * w / s) for w in weights]
    rem = sorted(range(len(weights)), key=lambda i: -(total * weights[i] / s - out[i]))
    for i in rem[:total - sum(out)]:
        out[i] += 1
    return out


def cloud_surfaces(features, n_points, rng, wall_top_mm=1.0):
    """Noise-free points of the finished piece in W with their outward unit
    normals and the surface each lies on: a list of (p, n, label)."""
    pts = []
    names = [n for n, _ in CLOUD_SHARES]
    counts = dict(zip(names, _split(n_points, [w for _, w in CLOUD_SHARES])))
    # facets: vertical planes, normal turned by the angle error towards +phi,
    # at the cut distance from W's Z axis; points 1 mm inside the side edges
    # (10.2 mm wide) and 0.7 mm inside the top and bottom (z -12.1 .. 0)
    facet_names = ["%s-%d" % (s, j) for s in ("X1", "Y1", "X2", "Y2") for j in range(1, 10)]
    for name, cnt in zip(facet_names, _split(counts["facets"], [1] * 36)):
        s, j = name.split("-")
        f = features[name]
        phi = math.radians(CENTRES_DEG[s] + (int(j) - 5) * 6.0) + f["angle_urad"] * 1e-6
        n = (math.cos(phi), math.sin(phi), 0.0)
        t = (-n[1], n[0], 0.0)
        d = R_FACET_MM + f["dist_um"] * 1e-3
        for _ in range(cnt):
            u, z = rng.uniform(-FACET_U_MM, FACET_U_MM), rng.uniform(FACET_Z_MM[0], -wall_top_mm)
            pts.append(((d * n[0] + u * t[0], d * n[1] + u * t[1], z), n, name))
    # strips: floor z = -12.1 - depth + tan(beta) x, along X across the big
    # notch floor, 5 mm either side of y_k, clear of the small notch
    # (|x| <= 5) and of the 199 cylinder's rim
    for k, cnt in zip(range(1, 10), _split(counts["strips"], [1] * 9)):
        f = features["Z%d" % k]
        yk = (k - 5) * 11.75
        z0 = Z_FLOOR_W_MM - f["depth_um"] * 1e-3
        tb = math.tan(f["beta_urad"] * 1e-6)
        n = _unit((-tb, 0.0, 1.0))
        for _ in range(cnt):
            y = yk + rng.uniform(-STRIP_HALF_MM, STRIP_HALF_MM)
            xmax = math.sqrt(99.5 ** 2 - y * y) - 2.0
            x = rng.uniform(SMALL_NOTCH_X_MM + 2.0, xmax) * rng.choice([-1, 1])
            pts.append(((x, y, z0 + tb * x), n, "Z%d" % k))
    # top faces of the segments (z = 0): outside the big notch (|y| > 53),
    # outside the small notch (|x| > 5), inside the facets; not in the groove
    ang = math.radians(MARK["phi_deg"])
    mu, mv = (math.cos(ang), math.sin(ang)), (-math.sin(ang), math.cos(ang))
    got = 0
    while got < counts["top"]:
        x, y = rng.uniform(-96.0, 96.0), rng.uniform(-96.0, 96.0)
        if abs(y) < FLANK_Y_MM + 1.0 or abs(x) < SMALL_NOTCH_X_MM + 1.0 or math.hypot(x, y) > 95.5:
            continue
        r_along, lat = x * mu[0] + y * mu[1], x * mv[0] + y * mv[1]
        if abs(lat) < MARK["half_w"] + 0.05 and MARK["r0"] - 0.4 < r_along < MARK["r1"] + 0.4:
            continue
        pts.append(((x, y, 0.0), (0.0, 0.0, 1.0), "top"))
        got += 1
    # the engraved mark: a 90 deg V groove, 0.3 mm deep, 0.6 mm wide, along
    # phi = 60 deg from r = 70 to 90 mm (segment X1); points on its flanks
    for _ in range(counts["mark"]):
        lat = rng.uniform(-MARK["half_w"] + 0.02, MARK["half_w"] - 0.02)
        r_along = rng.uniform(MARK["r0"] + 0.3, MARK["r1"] - 0.3)
        z = -(MARK["depth"] - abs(lat) * MARK["depth"] / MARK["half_w"])
        sg = 1.0 if lat > 0 else -1.0
        n = _unit((-sg * mv[0], -sg * mv[1], 1.0))
        pts.append(((r_along * mu[0] + lat * mv[0], r_along * mu[1] + lat * mv[1], z), n, "mark"))
    # big-notch flanks, y = +-53 (normals into the notch), z in [-12, 0];
    # clear of the small notch and of the facets at their ends
    for sg, cnt in zip((1, -1), _split(counts["flanks"], [1, 1])):
        for _ in range(cnt):
            x = rng.uniform(SMALL_NOTCH_X_MM + 2.0, 78.0) * rng.choice([-1, 1])
            pts.append(((x, sg * FLANK_Y_MM, rng.uniform(FLANK_Z_MM[0], -wall_top_mm)), (0.0, -sg, 0.0),
                        "flank%s" % ("+" if sg > 0 else "-")))
    # reference cylinders turned in step 1: 199 on z -16..-12 (above -14 the
    # small notch removes it at |x| <= 5; the strips' and the facets' cutter
    # ends at -12.1), 200 on -20..-16, 201 on -24..-20
    for label, rad, z0, z1 in (("cyl199", 99.5, -15.8, -12.4), ("cyl200", 100.0, -19.7, -16.3),
                               ("cyl201", 100.5, -23.7, -20.3)):
        got = 0
        while got < counts[label]:
            # the 199: three quarters of its points in the datum band -16..-14
            if label == "cyl199":
                z = rng.uniform(-15.8, -14.2) if rng.random() < 0.75 else rng.uniform(-14.0, z1)
            else:
                z = rng.uniform(z0, z1)
            a = rng.uniform(0.0, 2.0 * math.pi)
            x, y = rad * math.cos(a), rad * math.sin(a)
            if z > -14.0 and abs(x) < SMALL_NOTCH_X_MM + 0.5:
                continue
            pts.append(((x, y, z), (math.cos(a), math.sin(a), 0.0), label))
            got += 1
    # the small notch (|x| <= 5, floor z = -14, through along Y): floor and walls
    for _ in range(counts["small_notch"]):
        y = rng.uniform(-98.0, 98.0)
        if rng.random() < 0.5:
            pts.append(((rng.uniform(-4.5, 4.5), y, -14.0), (0.0, 0.0, 1.0), "small_notch"))
        else:
            sg = rng.choice([-1, 1])
            ztop = -12.0 if abs(y) < FLANK_Y_MM else 0.0
            pts.append(((sg * SMALL_NOTCH_X_MM, y, rng.uniform(-13.7, ztop - 0.3)), (-sg, 0.0, 0.0),
                        "small_notch"))
    return pts


def random_rotation(rng, kind):
    """Proper rotation matrix: 'table' = any yaw, tilted up to 2 deg (the
    piece on a CMM table); 'any' = uniform over all orientations."""
    if kind == "table":
        yaw = rng.uniform(0.0, 2.0 * math.pi)
        tilt = math.radians(rng.uniform(0.0, 2.0))
        ax = rng.uniform(0.0, 2.0 * math.pi)
        q = (math.cos(tilt / 2), math.sin(tilt / 2) * math.cos(ax), math.sin(tilt / 2) * math.sin(ax), 0.0)
        qz = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        w1, x1, y1, z1 = q
        w2, x2, y2, z2 = qz
        q = (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
             w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)
    else:
        q = _unit([rng.gauss(0, 1) for _ in range(4)])
    w, x, y, z = q
    return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]


def measure_cloud(sim, rng, n_points, fmt, pose_kind, wall_top_mm=1.0):
    """measurements.md section 1: the piece's points in an arbitrary CMM
    pose (cloud = R w + t), Gaussian noise along each surface's normal,
    a share of stray points; binary little-endian PLY of doubles or .xyz."""
    sigma_um = rng.uniform(*CLOUD_SIG_UM)
    n_stray = int(round(n_points * CLOUD_STRAY_SHARE))
    surf = cloud_surfaces(sim["features"], n_points - n_stray, rng, wall_top_mm)
    pts = []
    for p, n, _ in surf:
        e = rng.gauss(0.0, sigma_um * 1e-3)
        pts.append((p[0] + e * n[0], p[1] + e * n[1], p[2] + e * n[2]))
    # strays: half of them 10-150 um off a surface along its normal (inside
    # the band a fit has to reject, like the samples' strays), half 0.5-4 mm
    # off in any direction (dust, double hits)
    strays = []
    for i in range(n_stray):
        p, n, _ = surf[rng.randrange(len(surf))]
        if i % 2 == 0:
            o = rng.uniform(0.01, 0.15) * rng.choice([-1, 1])
            strays.append((p[0] + o * n[0], p[1] + o * n[1], p[2] + o * n[2]))
        else:
            dv = _unit([rng.gauss(0, 1) for _ in range(3)])
            o = rng.uniform(0.5, 4.0)
            strays.append((p[0] + o * dv[0], p[1] + o * dv[1], p[2] + o * dv[2]))
    for q in strays:   # scattered through the file, as a CMM writes them
        pts.insert(rng.randrange(len(pts) + 1), q)
    R = random_rotation(rng, pose_kind)
    t = [rng.uniform(-400.0, 400.0) for _ in range(3)]
    cloud = [tuple(R[i][0] * p[0] + R[i][1] * p[1] + R[i][2] * p[2] + t[i] for i in range(3)) for p in pts]
    counts = {}
    for _, _, label in surf:
        key = label if not (label[0] in "XY" and "-" in label) else "facet"
        key = "strip" if key[0] == "Z" else key
        counts[key] = counts.get(key, 0) + 1
    counts["stray"] = n_stray
    info = {"noise_um": sigma_um, "points": len(cloud), "format": fmt, "wall_top_mm": wall_top_mm,
            "points_per_surface": counts,
            "pose": {"kind": pose_kind, "R": R, "t_mm": t, "convention": "cloud = W @ R.T + t"}}
    if fmt == "ply":
        head = ("ply\nformat binary_little_endian 1.0\ncomment outside generator, CMM point cloud (mm)\n"
                "element vertex %d\nproperty double x\nproperty double y\nproperty double z\n"
                "end_header\n" % len(cloud))
        flat = [c for p in cloud for c in p]
        return "piece.ply", head.encode("ascii") + struct.pack("<%dd" % len(flat), *flat), info
    lines = ["# outside generator: CMM point cloud of the thermal test piece, x y z in mm"]
    lines += ["%.6f %.6f %.6f" % p for p in cloud]
    return "piece.xyz", "\n".join(lines) + "\n", info


# ------------------------------------------------------- the DMIS output
# What a CMM writes when it runs a DMIS program for this piece
# (measurements.md: the CMM at 20 degC, MPE 1.2 um + L/400): every feature
# probed with a few touches, each off the true surface along its normal by
# a Gaussian error of a third of the MPE for L its distance from the
# piece's centre, the feature fitted by least squares and reported as
# FA(label)=FEAT/PLANE,CART,x,y,z,i,j,k (a circle for the datum cylinder),
# four decimals of mm, in the CMM's frame (the piece placed on the CMM
# table: any yaw, a small tilt, an offset). The datums (top face, the
# big-notch flanks, the 199 cylinder) are reported too, so that the frame
# W can be found from them (test-piece.md section 5).
DMIS_TOUCH_SIG_FRACTION_OF_MPE = 1.0 / 3.0
# What a lab knows of this CMM, as ttp's options say it: ttp takes a touch's
# u as MPE'/sqrt(3), so MPE' = sqrt(3)/3 (1.2 um + L/400) = 0.69 um + L/693;
# 9 touches per plane, the fewest this CMM takes (facets).
CMM_STATED_ARGS = ["--cmm-mpe-um", "0.69", "--cmm-mpe-l-mm", "693", "--cmm-touches", "9"]
# What a lab knows of this dial gauge (measure(): readings off by
# SIG_DIAL_UM, written to 0.1 um).
DIAL_STATED_ARGS = ["--dial-resolution-um", "0.1", "--dial-repeatability-um", "%g" % SIG_DIAL_UM]
# The instrument a lab states with each measurement kind (ttp options).
STATED_ARGS = {"dmis": CMM_STATED_ARGS, "dial": DIAL_STATED_ARGS}


def _fit_plane(points):
    """Least-squares plane: centroid and unit normal (smallest eigenvector
    of the scatter, by inverse iteration on the 3x3 matrix)."""
    n = len(points)
    c = [sum(p[i] for p in points) / n for i in range(3)]
    m = [[sum((p[i] - c[i]) * (p[j] - c[j]) for p in points) for j in range(3)] for i in range(3)]
    # inverse iteration with a tiny shift: converges to the smallest eigenvalue
    a = [[m[i][j] + (1e-12 if i == j else 0.0) for j in range(3)] for i in range(3)]
    v = _unit([0.3, 0.5, 0.8])
    for _ in range(60):
        v = _unit(_solve3(a, v))
    return c, v


def _solve3(a, b):
    """Solve the 3x3 system a x = b (Cramer's rule)."""
    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    d = det(a)
    out = []
    for k in range(3):
        mk = [[b[i] if j == k else a[i][j] for j in range(3)] for i in range(3)]
        out.append(det(mk) / d)
    return out


def _fit_circle_xy(points):
    """Algebraic circle fit (Kasa) in XY: centre and radius."""
    sx = sy = sxx = syy = sxy = sxz = syz = sz = 0.0
    n = len(points)
    for x, y, _ in points:
        z = x * x + y * y
        sx += x; sy += y; sxx += x * x; syy += y * y; sxy += x * y
        sxz += x * z; syz += y * z; sz += z
    a = [[sxx, sxy, sx], [sxy, syy, sy], [sx, sy, n]]
    b = [sxz, syz, sz]
    A, B, C = _solve3(a, b)
    cx, cy = A / 2.0, B / 2.0
    return cx, cy, math.sqrt(C + cx * cx + cy * cy)


def measure_dmis(sim, rng):
    f = sim["features"]
    R = random_rotation(rng, "table")
    t = [rng.uniform(-300.0, 300.0), rng.uniform(-300.0, 300.0), rng.uniform(-100.0, 100.0)]
    to_cmm = lambda p: tuple(R[i][0] * p[0] + R[i][1] * p[1] + R[i][2] * p[2] + t[i] for i in range(3))
    turn = lambda v: tuple(R[i][0] * v[0] + R[i][1] * v[1] + R[i][2] * v[2] for i in range(3))

    def touch(p, n):
        # MPE for the length the touch is measured over: its distance from
        # the piece's datum origin (L in mm)
        L = math.sqrt(sum(c * c for c in p))
        e = rng.gauss(0.0, DMIS_TOUCH_SIG_FRACTION_OF_MPE * (1.2 + L / 400.0)) * 1e-3
        return tuple(p[i] + e * n[i] for i in range(3))

    lines = ["$$ outside generator: DMIS output of the thermal test piece (CMM frame)",
             "DMISMN/'outside generator',05.2", "UNITS/MM,ANGDEC"]

    def plane(label, pts, outward):
        c, n = _fit_plane([to_cmm(p) for p in pts])
        o = turn(outward)
        if sum(n[i] * o[i] for i in range(3)) < 0:
            n = tuple(-x for x in n)
        lines.append("FA(%s)=FEAT/PLANE,CART,%.4f,%.4f,%.4f,%.7f,%.7f,%.7f" % ((label,) + tuple(c) + tuple(n)))

    # datums: the top face (12 touches on the four segments' top faces)
    top = []
    for a_deg in (20, 45, 70, 110, 135, 160, 200, 225, 250, 290, 315, 340):
        a = math.radians(a_deg)
        p = (88.0 * math.cos(a), 88.0 * math.sin(a), 0.0)
        if abs(p[1]) < FLANK_Y_MM + 1.0:
            p = (p[0], math.copysign(FLANK_Y_MM + 8.0, p[1]), 0.0)
        top.append(touch(p, (0.0, 0.0, 1.0)))
    plane("TOP", top, (0.0, 0.0, 1.0))
    # the big-notch flanks y = +-53 (normals into the notch)
    for sg, label in ((1, "FLANK_PY"), (-1, "FLANK_NY")):
        pts = [touch((x, sg * FLANK_Y_MM, z), (0.0, -sg, 0.0))
               for x in (-70.0, -40.0, -15.0, 15.0, 40.0, 70.0) for z in (-10.0, -3.0)]
        plane(label, pts, (0.0, -float(sg), 0.0))
    # the 199 cylinder in its datum band: a circle of 12 touches at z = -15
    circ = []
    for k in range(12):
        a = 2 * math.pi * (k + 0.5) / 12
        circ.append(touch((99.5 * math.cos(a), 99.5 * math.sin(a), -15.0), (math.cos(a), math.sin(a), 0.0)))
    # fitted in the circle's plane (W's XY: a CMM fits it in the plane its
    # top face gives), reported in the CMM frame with W's Z as its axis
    cx, cy, rad = _fit_circle_xy(circ)
    c = to_cmm((cx, cy, -15.0))
    ax = turn((0.0, 0.0, 1.0))
    lines.append("FA(CYL199)=FEAT/CIRCLE,OUTER,CART,%.4f,%.4f,%.4f,%.7f,%.7f,%.7f,%.4f"
                 % (c + ax + (2 * rad,)))
    # facets: 3 x 3 touches over +-4 mm and z -10 .. -2 on the cut plane
    for s in ("X1", "Y1", "X2", "Y2"):
        for j in range(1, 10):
            v = f["%s-%d" % (s, j)]
            phi = math.radians(CENTRES_DEG[s] + (j - 5) * 6.0) + v["angle_urad"] * 1e-6
            n = (math.cos(phi), math.sin(phi), 0.0)
            tv = (-n[1], n[0], 0.0)
            d = R_FACET_MM + v["dist_um"] * 1e-3
            pts = [touch((d * n[0] + u * tv[0], d * n[1] + u * tv[1], z), n)
                   for u in (-4.0, 0.0, 4.0) for z in (-10.0, -6.0, -2.0)]
            plane("%s_%d" % (s, j), pts, n)
    # strips: two lines 2.5 mm either side of the strip's centre, four
    # touches each side of the small notch
    for k in range(1, 10):
        v = f["Z%d" % k]
        yk = (k - 5) * 11.75
        z0 = Z_FLOOR_W_MM - v["depth_um"] * 1e-3
        tb = math.tan(v["beta_urad"] * 1e-6)
        n = _unit((-tb, 0.0, 1.0))
        pts = []
        for y in (yk - 2.5, yk + 2.5):
            xmax = math.sqrt(99.5 ** 2 - y * y) - 4.0
            for x in (-xmax, -0.5 * (xmax + 8.0), 0.5 * (xmax + 8.0), xmax):
                pts.append(touch((x, y, z0 + tb * x), n))
        plane("Z%d" % k, pts, (0.0, 0.0, 1.0))
    lines.append("ENDFIL")
    return "piece.dmo", "\n".join(lines) + "\n"


# ------------------------------------------------------- on-machine probing
# measurements.md section 2: the machine probes the finished piece with a
# touch-trigger probe at the points of the plan the toolkit wrote (`ttp
# plan probe --points-csv`: id, feature, the nominal point in W and the
# approach direction) and writes point_id,x,y,z,c_deg: the stylus centre at
# trigger in the machine frame M, the table at c_deg. Written from
# test-piece.md section 1 alone: with C = c a direction at angle phi in W
# points along phi - c in M, W's origin at M = (0, 0, 54). The table is
# indexed so that only one linear axis moves per point (measurements.md):
# a horizontal approach turned onto M's -X (the surface's outward normal,
# at angle phi in W, along M's +X: c = phi), a vertical one at C = 0. The ball (radius 1.5 mm) travels along
# the approach direction and triggers where it meets the true surface;
# each touch is off by the probe's repeatability (Gaussian, 0.4 um), and
# the machine's own error at probing time adds a translation in M common
# to every touch (up to 3 um per axis) and a drift along the probing order
# (up to 0.5 um over the run).
PROBE_BALL_R_MM = 1.5
PROBE_SIG_UM = 0.4


def read_probe_points(path):
    out = []
    with open(path) as fh:
        head = fh.readline().strip().split(",")
        for line in fh:
            v = dict(zip(head, line.strip().split(",")))
            if not v.get("point_id"):
                continue
            out.append((int(v["point_id"]), v["feature"],
                        tuple(float(v[k]) for k in ("x_mm", "y_mm", "z_mm")),
                        tuple(float(v[k]) for k in ("approach_i", "approach_j", "approach_k"))))
    return out


def measure_probe(sim, rng, points_path):
    f = sim["features"]
    pts = read_probe_points(points_path)
    offset_um = [rng.uniform(-3.0, 3.0) for _ in range(3)]
    drift_um = [rng.uniform(-0.5, 0.5) for _ in range(3)]
    dot = lambda a, b: sum(x * y for x, y in zip(a, b))
    lines = ["point_id,x,y,z,c_deg"]
    for k, (pid, feat, p0, a) in enumerate(pts):
        c_deg = 0.0
        if math.hypot(a[0], a[1]) > 0.5:
            c_deg = round(math.degrees(math.atan2(-a[1], -a[0])), 6)
        # the true surface: outward normal n, n . p = h in W
        if feat in f and not feat.startswith("Z"):
            s, j = feat.split("-")
            v = f[feat]
            phi_deg = CENTRES_DEG[s] + (int(j) - 5) * 6.0
            phi = math.radians(phi_deg) + v["angle_urad"] * 1e-6
            n = (math.cos(phi), math.sin(phi), 0.0)
            h = R_FACET_MM + v["dist_um"] * 1e-3
        elif feat in f:
            v = f[feat]
            tb = math.tan(v["beta_urad"] * 1e-6)
            n = _unit((-tb, 0.0, 1.0))
            h = (Z_FLOOR_W_MM - v["depth_um"] * 1e-3) * n[2]
        elif feat == "TOP":
            n, h = (0.0, 0.0, 1.0), 0.0
        elif feat in ("FLANK+Y", "FLANK-Y"):
            sg = 1.0 if feat == "FLANK+Y" else -1.0
            n, h = (0.0, -sg, 0.0), -FLANK_Y_MM
        elif feat == "CYL199":
            n, h = None, 99.5
        else:
            raise ValueError("probe plan: unknown feature %s" % feat)
        # the ball's centre moves along a from 4 mm before the surface
        c0 = tuple(p0[i] - (PROBE_BALL_R_MM + 4.0) * a[i] for i in range(3))
        if n is None:   # the cylinder: centre at radius 99.5 + r from the axis
            # |c0_xy + s a_xy| = 99.5 + r, the smaller root
            A = a[0] ** 2 + a[1] ** 2
            B = 2 * (c0[0] * a[0] + c0[1] * a[1])
            C = c0[0] ** 2 + c0[1] ** 2 - (h + PROBE_BALL_R_MM) ** 2
            sv = (-B - math.sqrt(B * B - 4 * A * C)) / (2 * A)
            nn = _unit((c0[0] + sv * a[0], c0[1] + sv * a[1], 0.0))
        else:
            sv = (h + PROBE_BALL_R_MM - dot(n, c0)) / dot(n, a)
            nn = n
        e = rng.gauss(0.0, PROBE_SIG_UM) * 1e-3
        cw = tuple(c0[i] + sv * a[i] + e * nn[i] for i in range(3))
        # to M: turn by -c about Z, lift by 54 mm; the machine's error
        cr, sr = math.cos(math.radians(-c_deg)), math.sin(math.radians(-c_deg))
        frac = k / max(1, len(pts) - 1)
        m = (cr * cw[0] - sr * cw[1], sr * cw[0] + cr * cw[1], cw[2] + Z_TOP_MM)
        m = tuple(m[i] + (offset_um[i] + frac * drift_um[i]) * 1e-3 for i in range(3))
        lines.append("%d,%.4f,%.4f,%.4f,%.4f" % (pid, m[0], m[1], m[2], c_deg))
    return "probe.csv", "\n".join(lines) + "\n"


def noise_free_figures(features):
    f = {}
    for k, v in features.items():
        f[k] = {"depth": v["depth_um"], "beta": v["beta_urad"]} if k.startswith("Z") else {"d": v["dist_um"]}
    return figures_from(f)


def generate(out, effect, size, seed, spacing_s, comp_on, kind, points=20000, cloud_format="auto",
             pose="auto", wall_top_mm=1.0, probe_points=None, rtest_noise_scale=1.0,
             machine_gain_scale=1.0, closing_rtest=True):
    """closing_rtest False: the log keeps no R-test after the last cut (a
    production log that ends before the next R-test is due)."""
    os.makedirs(out, exist_ok=True)
    eff_name = effect
    if effect in MISMATCH:
        eff_name = "none"
    sim = simulate(seed, eff_name, size, spacing_s, comp_on, rtest_noise_scale, machine_gain_scale)
    rows = sim["rows"]
    if effect == "other_log":
        rows = simulate(seed + 7919, "none", 0.0, spacing_s, comp_on, rtest_noise_scale,
                        machine_gain_scale)["rows"]
    elif effect == "short_log":
        cut_at = CYCLE0_S + 5 * CYCLE_S + 600.0   # the log ends after cycle 5
        rows = [r for r in rows if r["t_s"] <= cut_at]
    if not closing_rtest:
        last_cut = max(r["t_s"] for r in rows if r["event"] == "cut")
        rows = [r for r in rows if not (r["event"] == "rtest" and r["t_s"] > last_cut)]
    write_log(os.path.join(out, "talc.csv"), rows, comp_on)
    rng = random.Random(seed * 31 + 5)
    info = None
    if kind == "cloud":
        fmt = cloud_format if cloud_format != "auto" else ("ply" if seed % 2 == 0 else "xyz")
        pk = pose if pose != "auto" else ("table" if (seed // 2) % 2 == 0 else "any")
        fname, text, info = measure_cloud(sim, rng, points, fmt, pk, wall_top_mm)
    elif kind == "dmis":
        fname, text = measure_dmis(sim, rng)
    elif kind == "probe":
        if not probe_points:
            raise ValueError("--measurement probe needs --probe-points (ttp plan probe --points-csv)")
        fname, text = measure_probe(sim, rng, probe_points)
    else:
        fname, text = measure(sim, kind, rng)
    for stale in ("piece.json", "dial.csv", "piece.ply", "piece.xyz", "piece.dmo", "probe.csv"):
        if stale != fname and os.path.exists(os.path.join(out, stale)):
            os.remove(os.path.join(out, stale))
    with open(os.path.join(out, fname), "wb" if isinstance(text, bytes) else "w") as fh:
        fh.write(text)
    f = sim["features"]
    truth = {"effect": effect, "size": size, "seed": seed, "spacing_s": spacing_s,
             "compensation": "on" if comp_on else "off", "measurement": kind,
             "params": sim["effect"].params,
             # the piece as cut (no measurement noise): what a measurement should give
             "figures": noise_free_figures(f),
             "facets": {k: {"distance_mm": R_FACET_MM + v["dist_um"] * 1e-3, "angle_error_urad": v["angle_urad"]}
                        for k, v in sorted(f.items()) if not k.startswith("Z")},
             "strips": {k: {"depth_mm": -Z_FLOOR_W_MM + v["depth_um"] * 1e-3, "beta_urad": v["beta_urad"]}
                        for k, v in sorted(f.items()) if k.startswith("Z")}}
    if info:
        truth["cloud"] = info
    # the stresses, when applied (absent at 1: the files as without them)
    if rtest_noise_scale != 1.0:
        truth["rtest_noise_scale"] = rtest_noise_scale
    if machine_gain_scale != 1.0:
        truth["machine_gain_scale"] = machine_gain_scale
    if not closing_rtest:
        truth["closing_rtest"] = False
    with open(os.path.join(out, "truth.json"), "w") as fh:
        json.dump(truth, fh, indent=1)
    return os.path.join(out, fname), os.path.join(out, "talc.csv")


def scale_arg(text):
    """argparse type of a stress factor: a finite number > 0."""
    try:
        return check_scale("the factor", text)
    except ValueError:
        raise argparse.ArgumentTypeError("must be a finite number > 0, got %r" % text)


def add_scale_args(ap):
    """The two stress options (generate.py, run_battery.py,
    estimator_coverage.py)."""
    ap.add_argument("--rtest-noise-scale", type=scale_arg, default=1.0, metavar="F",
                    help="R-test noise (thesis table 5.4) times F: a noisier R-test (default 1)")
    ap.add_argument("--machine-gain-scale", type=scale_arg, default=1.0, metavar="F",
                    help="the machine's thermal error gains (every path) times F: larger thermal "
                         "errors (default 1)")


def add_log_end_arg(ap):
    """How the log ends (generate.py, run_battery.py)."""
    ap.add_argument("--no-closing-rtest", action="store_true",
                    help="no R-test after the last cut: the log ends before the next one is due, as "
                         "a production log may (default: an R-test closes the run)")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    known = ["none"] + CATALOGUE + OUTSIDE + OUTSIDE_MORE + MISMATCH
    ap.add_argument("--effect", default="none",
                    help="one of %s, or two joined by + (e.g. tool_wear+clamping_distortion)" % ", ".join(known))
    ap.add_argument("--size", default="0", help="effect size; for two effects S1+S2")
    ap.add_argument("--seed", type=int, required=True)
    ap.add_argument("--spacing-s", type=parse_spacing, default=300.0,
                    help="seconds between R-tests (default 300), or 'adaptive': every 30 min for 2 h "
                         "after a load change, every 2 h otherwise")
    ap.add_argument("--compensation", choices=["on", "off"], default="off")
    ap.add_argument("--measurement", choices=["json", "dial", "cloud", "dmis", "probe"], default="json",
                    help="json: per-feature CMM report; dial: dial-gauge CSV; cloud: CMM point cloud; "
                         "dmis: a CMM's DMIS output (features fitted from touches, CMM frame); "
                         "probe: on-machine probing results (needs --probe-points)")
    ap.add_argument("--probe-points", help="probe: the plan's point list (ttp plan probe --points-csv FILE)")
    ap.add_argument("--points", type=int, default=20000, help="cloud: points in total (default 20000)")
    ap.add_argument("--cloud-format", choices=["auto", "ply", "xyz"], default="auto",
                    help="cloud: binary PLY or .xyz text (auto: by the seed's parity, even = ply)")
    ap.add_argument("--pose", choices=["auto", "table", "any"], default="auto",
                    help="cloud: 'table' any yaw and up to 2 deg tilt, 'any' a uniform random "
                         "rotation (auto: by the seed)")
    ap.add_argument("--wall-top-mm", type=float, default=1.0,
                    help="cloud: the highest points on the facets and flanks, mm below the top face "
                         "(default 1: a CMM program's margin, as in the samples; a scanner sees up to the edge)")
    add_scale_args(ap)
    add_log_end_arg(ap)
    ap.add_argument("-o", required=True)
    a = ap.parse_args()
    if any(n not in known for n in a.effect.split("+")):
        ap.error("unknown effect %s" % a.effect)
    if "+" not in a.size:
        a.size = float(a.size)
    m, l = generate(a.o, a.effect, a.size, a.seed, a.spacing_s, a.compensation == "on", a.measurement,
                    a.points, a.cloud_format, a.pose, a.wall_top_mm, a.probe_points,
                    a.rtest_noise_scale, a.machine_gain_scale, not a.no_closing_rtest)
    print(m, l)


if __name__ == "__main__":
    main()

#!/usr/bin/python3
# The "display" of ttp.ini: leaves E-stop, homes, runs $TTP_PROGRAM at feed
# override $TTP_FEED_OVERRIDE and writes $TTP_RUN_LOG (JSON): every
# (debug,...) message with the time and axis position when it arrived,
# the polled positions, the errors, and the run time.
import json, os, sys, time
import linuxcnc

program = os.environ["TTP_PROGRAM"]
out_path = os.environ["TTP_RUN_LOG"]
override = float(os.environ.get("TTP_FEED_OVERRIDE", "40"))
limit_s = float(os.environ.get("TTP_RUN_LIMIT_S", "200"))
s = linuxcnc.stat()
c = linuxcnc.command()
e = linuxcnc.error_channel()
log = {"messages": [], "errors": [], "samples": [], "completed": False}


def wait_for(pred, timeout):
    end = time.time() + timeout
    while time.time() < end:
        s.poll()
        if pred():
            return True
        time.sleep(0.02)
    return False


def drain(t0):
    while True:
        m = e.poll()
        if not m:
            return
        kind, text = m
        s.poll()
        entry = {"t": time.time() - t0, "text": text,
                 "pos": list(s.actual_position)[:9], "line": s.current_line}
        if kind in (linuxcnc.NML_ERROR, linuxcnc.OPERATOR_ERROR):
            log["errors"].append(entry)
        else:
            log["messages"].append(entry)


try:
    c.state(linuxcnc.STATE_ESTOP_RESET)
    c.state(linuxcnc.STATE_ON)
    wait_for(lambda: s.task_state == linuxcnc.STATE_ON, 10)
    c.mode(linuxcnc.MODE_MANUAL)
    c.home(-1)
    wait_for(lambda: all(s.homed[:5]), 20)
    c.mode(linuxcnc.MODE_AUTO)
    wait_for(lambda: s.task_mode == linuxcnc.MODE_AUTO, 5)
    c.program_open(program)
    c.feedrate(override / 1.0)
    c.wait_complete()
    t0 = time.time()
    c.auto(linuxcnc.AUTO_RUN, 0)
    wait_for(lambda: s.interp_state != linuxcnc.INTERP_IDLE, 5)
    # Task may show the interpreter idle while it waits for the tool
    # changer (M6 empties the queue): the run has ended when the
    # interpreter is idle with nothing left to execute for a whole second;
    # its time is when that began.
    idle_since = None
    while time.time() - t0 < limit_s:
        s.poll()
        drain(t0)
        now = time.time() - t0
        log["samples"].append([now] + list(s.actual_position)[:6])
        done = (s.interp_state == linuxcnc.INTERP_IDLE and
                s.exec_state == linuxcnc.EXEC_DONE and s.queue == 0)
        if not done:
            idle_since = None
        elif idle_since is None:
            idle_since = now
        elif now - idle_since >= 1.0:
            log["completed"] = len(log["errors"]) == 0
            log["end_s"] = idle_since
            break
        time.sleep(0.02)
    drain(t0)
    log["run_s"] = time.time() - t0
except Exception as ex:  # reported, not hidden
    log["errors"].append({"t": 0, "text": "display: %r" % ex})
with open(out_path, "w") as f:
    json.dump(log, f)

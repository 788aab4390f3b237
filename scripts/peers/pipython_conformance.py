#!/usr/bin/env python3
"""Conformance check of the nanopush GCS simulator against PI's own client.

Drives `nanopush rig sim-gcs` with PIPython (PI's GCS client from PyPI) through
connect / identify / servo / move / query / error, the way a lab script would,
and fails loudly on any mismatch. It lives outside the product: set up its venv
with scripts/peers/setup-venv-pipython.sh, then run

    VENV/bin/python scripts/peers/pipython_conformance.py [--nanopush target/debug/nanopush]

It starts the simulator itself on a free loopback port (and, for the serial
run, on a pseudo-terminal standing in for a serial port) and stops it at the end.
"""
import argparse
import re
import subprocess
import sys
import time

from pipython import GCSDevice, GCSError, gcserror, pitools
from pipython.pidevice.interfaces.piserial import PISerial
from pipython.pidevice.interfaces.pisocket import PISocket


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what)
    if not cond:
        raise SystemExit(1)


def run_checks(pidev):
    """Connect / servo / move / query / error, as a lab script would."""
    idn = pidev.qIDN().strip()
    check("GCS simulator" in idn, f"qIDN -> {idn!r}")
    check(float(pidev.qCSV()) == 2.0, f"qCSV -> {pidev.qCSV()}")
    axes = pidev.qSAI()
    check(axes == ["1", "2", "3"], f"qSAI -> {axes}")
    check(pidev.IsControllerReady(), "IsControllerReady (#7)")
    tmn, tmx = pidev.qTMN(), pidev.qTMX()
    check(tmx["3"] == 15.0 and tmn["1"] == 0.0, f"qTMN/qTMX -> {dict(tmn)} / {dict(tmx)}")

    # move with servo off -> GCSError 5
    try:
        pidev.MOV("1", 10.0)
        check(False, "MOV with servo off raised")
    except GCSError as err:
        check(err.val == gcserror.E5_PI_CNTR_MOVE_WITHOUT_REF_OR_NO_SERVO, f"MOV with servo off -> {err}")

    pidev.SVO(axes, [True] * len(axes))
    check(all(pidev.qSVO(axes).values()), f"SVO on -> qSVO {dict(pidev.qSVO(axes))}")
    pidev.VEL("1", 50.0)
    check(pidev.qVEL("1")["1"] == 50.0, "VEL/qVEL")

    pidev.MOV({"1": 20.0, "2": 70.0})
    moving = pidev.IsMoving()
    check(moving["1"] and moving["2"], f"IsMoving (#5) right after MOV -> {dict(moving)}")
    check(not pidev.qONT("1")["1"], "qONT false while moving")
    pitools.waitontarget(pidev, axes=["1", "2"], timeout=10)
    pos = pidev.qPOS(["1", "2"])
    check(abs(pos["1"] - 20.0) < 1e-9 and abs(pos["2"] - 70.0) < 1e-9, f"qPOS after waitontarget -> {dict(pos)}")
    check(pidev.qMOV("1")["1"] == 20.0, "qMOV")
    pidev.MVR("1", 5.0)
    pitools.waitontarget(pidev, axes="1", timeout=10)
    check(abs(pidev.qPOS("1")["1"] - 25.0) < 1e-9, f"MVR -> qPOS {pidev.qPOS('1')['1']}")

    try:
        pidev.MOV("1", 150.0)
        check(False, "MOV out of limits raised")
    except GCSError as err:
        check(err.val == gcserror.E7_PI_CNTR_POS_OUT_OF_LIMITS, f"MOV out of limits -> {err}")
    try:
        pidev.MOV("9", 1.0)
        check(False, "MOV on unknown axis raised")
    except GCSError as err:
        check(err.val == gcserror.E15_PI_CNTR_INVALID_AXIS_IDENTIFIER, f"MOV on axis 9 -> {err}")

    pidev.MOV("2", 10.0)
    time.sleep(0.05)
    try:
        pidev.STP()
        check(False, "STP raised error 10")
    except GCSError as err:
        check(err.val == gcserror.E10_PI_CNTR_STOP, f"STP -> {err}")
    check(not any(pidev.IsMoving().values()), "no axis moving after STP")
    check(pidev.qERR() == 0, "qERR clear afterwards")
    pidev.HLT("1", noraise=True)
    check(pidev.qERR() in (0, 10), "HLT leaves 0 or 10 in ERR?")


def start_simulator(binary, pty):
    """Starts `nanopush rig sim-gcs` on a free loopback port (and a pty)."""
    cmd = [binary, "rig", "sim-gcs", "--port", "0"] + (["--pty"] if pty else [])
    sim = subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True)
    tcp_line = sim.stdout.readline()
    port = int(re.search(r":(\d+)\s*$", tcp_line).group(1))
    tty = sim.stdout.readline().split()[-1] if pty else None
    return sim, port, tty


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--nanopush", default="target/debug/nanopush")
    args = ap.parse_args()
    for link in ("tcp", "serial"):
        sim, port, tty = start_simulator(args.nanopush, pty=(link == "serial"))
        try:
            if link == "tcp":
                print(f"--- PIPython over TCP, 127.0.0.1:{port}")
                gateway = PISocket(host="127.0.0.1", port=port)
            else:
                print(f"--- PIPython over serial, pseudo-terminal {tty}")
                gateway = PISerial(port=tty, baudrate=115200)
            with GCSDevice(gateway=gateway) as pidev:
                run_checks(pidev)
        finally:
            sim.terminate()
            sim.wait(timeout=5)
    print("PIPython conformance: all checks passed (TCP and serial)")


if __name__ == "__main__":
    main()

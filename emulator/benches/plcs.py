"""User PLCs on `pmacwd serve` (wall clock), through dls-pmaclib (run it with the venv
`cli/tests/dls/run.sh` makes):

1. The server's CPU time (user + system from /proc/PID/stat, Linux) over 10 s, idle, without
   and with a position-reporting PLC in DLS's form (`Q87=P4801*M162/(I108*32)+P4901`).
2. A `???` poller's round trips (2,000 in a row), without PLCs and beside three hostile ones:
   an endless WHILE, 167 lines of 30 statements (5,010) without a loop, and a storm of
   `CMD"P100..8191=1"`.
3. Virtual time (`--virtual-time`): the control port's `step 1000000`, without and with the
   position-reporting PLC (a card with PLCs running steps a servo cycle at a time).

    target/dls-venv/bin/python emulator/benches/plcs.py target/release/pmacwd
"""
import os
import re
import socket
import subprocess
import sys
import time

from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

PMACWD = sys.argv[1]

REPORTING = [
    "M162->D:$00008B M262->D:$00010B P4801=0.001 P4802=0.001",
    "OPEN PLC 16 CLEAR",
    "ADDRESS&1",
    "Q87=P4801*M162/(I108*32)+P4901",
    "Q88=P4802*M262/(I208*32)+P4902",
    "CLOSE",
    "I5=2 ENABLE PLC 16",
]

HOSTILE = (
    ["OPEN PLC 1 CLEAR", "WHILE (1<2)", "P1=P1+1", "ENDWHILE", "CLOSE"]
    + ["OPEN PLC 3 CLEAR", 'CMD"P100..8191=1"', 'CMD"P9=P9+1"', "CLOSE", "OPEN PLC 2 CLEAR"]
    # dls-pmaclib sends at most 255 bytes a line.
    + [" ".join(["P2=P2+1"] * 30) for _ in range(167)]
    + ["CLOSE", "I5=2 ENABLE PLC 1..3"]
)


def serve(virtual=False):
    control = ["--control", "127.0.0.1:0", "--virtual-time"] if virtual else ["--no-control"]
    proc = subprocess.Popen(
        [PMACWD, "serve", "--listen", "127.0.0.1:0", *control],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    ports = re.findall(r"127\.0\.0\.1:(\d+)", proc.stdout.readline())
    pmac = PmacEthernetInterface(timeout=2.0)
    pmac.setConnectionParams("127.0.0.1", ports[0])
    assert pmac.connect() is None
    proc.control_port = ports[1] if virtual else None
    return proc, pmac


def send(pmac, lines):
    for line in lines:
        reply, ok = pmac.sendCommand(line)
        assert ok and reply.endswith("\x06") and "\x07" not in reply, (line, reply)


def cpu(pid):
    f = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")


def idle_cpu(plc):
    proc, pmac = serve()
    if plc:
        send(pmac, REPORTING)
    time.sleep(0.5)
    c0 = cpu(proc.pid)
    time.sleep(10)
    used = cpu(proc.pid) - c0
    pmac.disconnect()
    proc.terminate()
    proc.communicate()
    name = "a position-reporting PLC" if plc else "no PLC"
    print(f"idle card, {name}: server CPU {used:.2f} s in 10 s = {used * 10:.1f}% of one core")


def poller(hostile):
    proc, pmac = serve()
    if hostile:
        send(pmac, HOSTILE)
    time.sleep(1)
    ts = []
    for _ in range(2000):
        t = time.perf_counter()
        _, ok = pmac.sendCommand("???")
        ts.append((time.perf_counter() - t) * 1e6)
        assert ok
    scans = pmac.sendCommand("P1 P2 P9")[0].rstrip("\x06").split("\r")[:-1]
    pmac.disconnect()
    proc.terminate()
    proc.communicate()
    ts.sort()
    name = "beside 3 hostile PLCs" if hostile else "no PLC"
    print(
        f"??? x 2000, {name}: p50 {ts[1000]:.0f} us, p90 {ts[1800]:.0f} us, p99 {ts[1980]:.0f} us, "
        f"max {ts[-1]:.0f} us (P1 P2 P9 = {' '.join(scans)})"
    )


def virtual_step(plc):
    proc, pmac = serve(virtual=True)
    if plc:
        send(pmac, REPORTING)
    c = socket.create_connection(("127.0.0.1", int(proc.control_port)))
    f = c.makefile("rw", newline="\n")
    t = time.perf_counter()
    f.write("step 1000000\n")
    f.flush()
    assert f.readline().startswith("ok")
    took = time.perf_counter() - t
    c.close()
    pmac.disconnect()
    proc.terminate()
    proc.communicate()
    name = "a position-reporting PLC" if plc else "no PLC"
    print(f"virtual time, step 1000000, {name}: {took * 1000:.0f} ms ({took * 1000:.0f} ns a servo cycle)")


for plc in (False, True):
    idle_cpu(plc)
for hostile in (False, True, False, True):
    poller(hostile)
for plc in (False, True, False, True):
    virtual_step(plc)

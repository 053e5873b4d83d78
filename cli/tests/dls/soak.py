"""The soak of issue 30: 10 dls-pmaccontrol-like GUIs poll `pmacwd serve` while 8 motors jog and
home, over and over; the server's RSS is sampled over time and every poll's round trip is
timed. A measurement, not a test: it fails (exit 1) only on a wrong answer, a homing search
that does not complete or a server that dies, never on a figure.

    cli/tests/dls/soak.sh [SECONDS]          (installs dls-pmaclib, builds, runs this)

- Each GUI is a process of its own (no shared interpreter lock between the clients) with its
  own connection through dls-pmaclib's PmacEthernetInterface, the GUI's library, sending
  dls-pmaccontrol's 52-value poll line (dls_pmac_control/commsThread.py: identity, `???`,
  `&1??`, `%`, then `#n?PVF mn90 p99` for motors 1-8) every 0.1 s and checking that 52 values
  come back. The round trip is timed around sendCommand, so it includes the client library.
- A motion process, on a connection of its own: closes the eight loops, places each motor's
  home flag 300 counts ahead through the control port, then over and over jogs all eight
  negative for 1 s (`#nJ-`), stops them (`#nJ/`), homes them (`#nHM`, Ixx23 = +32 counts/ms
  back to the flag) and waits until every one reports home complete (`#n?` second word bit
  10), at most 10 s.
- A probe, a process of its own, sends the same line every 0.1 s on a plain socket (the
  Ethernet request of the Acc-54E protocol, as dls-pmaclib builds it) and times it without
  the client library: the server's round trip as a minimal client sees it.
- Every 5 s the server's VmRSS (/proc/PID/status, Linux) with the polls so far.
"""
import multiprocessing as mp
import os
import re
import socket
import subprocess
import sys
import time

PMACWD = os.environ["PMACWD"]
SECONDS = float(sys.argv[1]) if len(sys.argv) > 1 else 60.0
GUIS = 10
MOTORS = 8
POLL_LINE = "i65???&1??%" + "".join(f"#{m}?PVF m{m}90 p99" for m in range(1, MOTORS + 1))


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return -1


def connect(port):
    from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

    pmac = PmacEthernetInterface(timeout=5.0)
    pmac.setConnectionParams("127.0.0.1", port)
    error = pmac.connect()
    if error is not None:
        raise RuntimeError(f"connect: {error}")
    return pmac


def gui(port, deadline, out):
    """One GUI: the poll line every 0.1 s until the deadline; its round trips (s) and faults."""
    pmac = connect(port)
    times, wrong = [], 0
    start = time.monotonic()
    n = 0
    while time.monotonic() < deadline:
        t0 = time.perf_counter()
        reply, ok = pmac.sendCommand(POLL_LINE)
        times.append(time.perf_counter() - t0)
        if not ok or not reply.endswith("\x06") or "\x07" in reply or reply.count("\r") != 52:
            wrong += 1
        n += 1
        time.sleep(max(0.0, start + n * 0.1 - time.monotonic()))
    pmac.disconnect()
    out.put((times, wrong))


def probe(port, deadline, out):
    """The poll line on a plain socket every 0.1 s: round trips without the client library."""
    import struct

    request = struct.pack("8B", 0x40, 0xBF, 0, 0, 0, 0, 0, len(POLL_LINE)) + POLL_LINE.encode()
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    times, wrong = [], 0
    start = time.monotonic()
    n = 0
    while time.monotonic() < deadline:
        t0 = time.perf_counter()
        s.sendall(request)
        reply = b""
        while not (reply.endswith(b"\x06") or b"\x07" in reply and reply.endswith(b"\r")):
            chunk = s.recv(4096)
            if not chunk:
                raise RuntimeError("the server closed the probe's connection")
            reply += chunk
        times.append(time.perf_counter() - t0)
        if reply.count(b"\r") != 52 or b"\x07" in reply:
            wrong += 1
        n += 1
        time.sleep(max(0.0, start + n * 0.1 - time.monotonic()))
    s.close()
    out.put((times, wrong))


def motion(port, control_port, deadline, out):
    """Jog all eight, stop, home all eight, again; the searches started and completed."""
    pmac = connect(port)
    control = socket.create_connection(("127.0.0.1", control_port), timeout=5)
    cf = control.makefile("rw", newline="\n")

    def ask(line):
        reply, ok = pmac.sendCommand(line)
        if not ok or "\x07" in reply:
            raise RuntimeError(f"{line!r}: {reply!r}")
        return reply.rstrip("\x06").split("\r")[:-1]

    motors = range(1, MOTORS + 1)
    ask("".join(f"#{m}J/" for m in motors))
    for m in motors:
        cf.write(f"home-flag {m} 300\n")
        cf.flush()
        if not cf.readline().startswith("ok"):
            raise RuntimeError("home-flag refused")
    started = completed = cycles = 0
    while time.monotonic() + 12 < deadline:
        ask("".join(f"#{m}J-" for m in motors))
        time.sleep(1.0)
        ask("".join(f"#{m}J/" for m in motors))
        time.sleep(0.2)
        ask("".join(f"#{m}HM" for m in motors))
        started += MOTORS
        homed = set()
        until = time.monotonic() + 10
        while time.monotonic() < until and len(homed) < MOTORS:
            words = ask("".join(f"#{m}?" for m in motors))
            for m, w in zip(motors, words):
                if int(w[6:12], 16) & (1 << 10) and not int(w[0:6], 16) & (1 << 10):
                    homed.add(m)
            time.sleep(0.05)
        completed += len(homed)
        cycles += 1
    pmac.disconnect()
    out.put((cycles, started, completed))


def percentile(sorted_values, p):
    k = min(len(sorted_values) - 1, max(0, round(p / 100 * (len(sorted_values) - 1))))
    return sorted_values[k]


def main():
    server = subprocess.Popen(
        [PMACWD, "serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    port, control_port = (int(p) for p in re.findall(r"127\.0\.0\.1:(\d+)", server.stdout.readline())[:2])
    load_start = os.getloadavg()
    time.sleep(0.5)
    print(f"soak: {GUIS} GUIs polling the 52-value line at 10 Hz while {MOTORS} motors jog and home, {SECONDS:.0f} s")
    print(f"load average at the start: {load_start[0]:.2f} {load_start[1]:.2f} {load_start[2]:.2f} ({os.cpu_count()} cores)")
    t0 = time.monotonic()
    deadline = t0 + SECONDS
    polls, moves, probes = mp.Queue(), mp.Queue(), mp.Queue()
    procs = [mp.Process(target=gui, args=(port, deadline, polls)) for _ in range(GUIS)]
    procs.append(mp.Process(target=motion, args=(port, control_port, deadline, moves)))
    procs.append(mp.Process(target=probe, args=(port, deadline, probes)))
    for p in procs:
        p.start()
    samples = []
    while time.monotonic() < deadline:
        time.sleep(min(5.0, max(0.0, deadline - time.monotonic())))
        if server.poll() is not None:
            print(f"the server exited with {server.returncode}")
            return 1
        samples.append((time.monotonic() - t0, rss_kb(server.pid)))
        print(f"  t = {samples[-1][0]:5.1f} s  server RSS {samples[-1][1]:,} kB", flush=True)
    results = [polls.get(timeout=60) for _ in range(GUIS)]
    cycles, started, completed = moves.get(timeout=60)
    probe_times, probe_wrong = probes.get(timeout=60)
    for p in procs:
        p.join(timeout=30)
    load_end = os.getloadavg()
    server.terminate()
    server.wait(timeout=10)
    times = sorted(t for r in results for t in r[0])
    wrong = sum(r[1] for r in results)
    us = lambda s: f"{s * 1e6:,.1f} us"
    print(
        f"polls: {len(times):,}, wrong {wrong}; round trip through dls-pmaclib min {us(times[0])}, p10 {us(percentile(times, 10))}, "
        f"p50 {us(percentile(times, 50))}, "
        f"p90 {us(percentile(times, 90))}, p99 {us(percentile(times, 99))}, max {us(times[-1])}"
    )
    probe_times.sort()
    print(
        f"probe (plain socket): {len(probe_times):,} polls, wrong {probe_wrong}; round trip min {us(probe_times[0])}, "
        f"p10 {us(percentile(probe_times, 10))}, p50 {us(percentile(probe_times, 50))}, "
        f"p90 {us(percentile(probe_times, 90))}, p99 {us(percentile(probe_times, 99))}, max {us(probe_times[-1])}"
    )
    wrong += probe_wrong
    print(f"motion: {cycles} jog-and-home rounds, {completed} of {started} homing searches completed")
    rss = [kb for _, kb in samples]
    settled = rss[min(1, len(rss) - 1)]
    print(
        f"server RSS: first sample {rss[0]:,} kB, after 10 s {settled:,} kB, last {rss[-1]:,} kB, "
        f"max {max(rss):,} kB (last - after 10 s: {rss[-1] - settled:+,} kB)"
    )
    print(f"load average at the end: {load_end[0]:.2f} {load_end[1]:.2f} {load_end[2]:.2f}")
    ok = wrong == 0 and completed == started and started > 0
    print("soak: every poll answered 52 values, every search completed" if ok else "soak: FAILED (see above)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

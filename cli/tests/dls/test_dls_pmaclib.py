"""dls-pmaclib, a client library used with real Turbo PMACs, against `pmacwd serve`.

Each test says what a host program sees and why it matters. The emulator runs as a separate
process, as an integrator would run it; the tests reach its control interface (load, faults,
INIT/) over TCP. Captures written along the way must replay as consistent under
`pmacwd replay` for the profile the emulator ran.
"""

import json
import os
import re
import socket
import subprocess
import tempfile
import time
import unittest

from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

PMACWD = os.environ.get("PMACWD", "target/release/pmacwd")
# dls-pmaclib waits this long for a reply; a tripped card never sends one.
CLIENT_TIMEOUT_S = 0.5
# The recording proxy calls a reply missing after this long a silence (< CLIENT_TIMEOUT_S, so
# the silence is on disk before the test goes on).
SILENCE_MS = 250
STATUS_REPLY = re.compile(r"^[0-9A-F]{12}\r\x06$")


class Process:
    """A pmacwd subcommand whose first stdout line names the addresses it listens on."""

    def __init__(self, *args):
        self.proc = subprocess.Popen(
            [PMACWD, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        self.banner = self.proc.stdout.readline()
        if not self.banner:
            raise RuntimeError(f"pmacwd {args[0]} did not start: {self.proc.stderr.read()}")
        self.addresses = re.findall(r"127\.0\.0\.1:(\d+)", self.banner)

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
        out, err = self.proc.communicate(timeout=10)
        return out, err


class Control:
    """The emulator's control interface: one line out, one line back."""

    def __init__(self, port):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=5)
        self.file = self.sock.makefile("rw", newline="\n")

    def __call__(self, line):
        self.file.write(line + "\n")
        self.file.flush()
        reply = self.file.readline().strip()
        assert reply.startswith("ok"), f"control `{line}` answered `{reply}`"
        return reply

    def close(self):
        self.file.close()
        self.sock.close()


def connect(port):
    pmac = PmacEthernetInterface(timeout=CLIENT_TIMEOUT_S)
    pmac.setConnectionParams("127.0.0.1", port)
    error = pmac.connect()
    assert error is None, f"connect failed: {error}"
    return pmac


def replay(path):
    """`pmacwd replay --format json`: exit code, whether each named profile explains the
    capture, the number of observations the explanation reproduces on the model, and stderr."""
    r = subprocess.run([PMACWD, "replay", path, "--format", "json"], capture_output=True, text=True)
    report = json.loads(r.stdout) if r.stdout.strip() else {}
    explains = {p["profile"]: p["explains"] for p in report.get("profiles", [])}
    checked = (report.get("explanation") or {}).get("observations_checked") or 0
    return r.returncode, explains, checked, r.stderr


class Session:
    """What a host program does with a card over one connection, and what it must see."""

    def __init__(self, test, pmac, control, step=None):
        self.t, self.pmac, self.control = test, pmac, control
        # Virtual time moves only when told; the wall clock moves by itself.
        self.step = step or (lambda cycles: time.sleep(cycles / 2250))

    def ok(self, command):
        reply, ok = self.pmac.sendCommand(command)
        self.t.assertTrue(ok, f"{command!r}: {reply}")
        return reply

    def run(self):
        t = self.t
        # The handshake already happened in connect(): `i6=1 i3=2 ver` answered `1.947\r\x06`.
        t.assertEqual(self.pmac.getPmacModelCode(), 603382)
        t.assertEqual(self.pmac.getPmacModel(), "Geo Brick (3U Turbo PMAC2)")
        # ??? on a healthy card: 12 hex digits; bit 12 of X:$6 is the PROM checksum running.
        t.assertRegex(self.ok("???"), STATUS_REPLY)
        self.step(300)
        # I-variables: write, read back, several on one line.
        t.assertEqual(self.ok("I130=1234"), "\x06")
        t.assertEqual(self.pmac.getIVars(100, [30, 40]), ["1234", "0"])
        t.assertEqual(self.ok("I8 I40 I41"), "2\r0\r0\r\x06")
        # The watchdog counter: reloaded by every background cycle, so near its reset value.
        counter = int(self.ok("RHY:$25")[:-2], 16)
        t.assertTrue(4000 <= counter <= 4096, counter)
        # I41 bit 0 locks the motor setup variables: the write is acknowledged and ignored.
        self.pmac.setVar("I41", 1)
        t.assertEqual(self.ok("I130=99"), "\x06")
        t.assertEqual(self.ok("I130"), "1234\r\x06")
        # SRM p.57: I41 does not stop an M-variable assignment. I130's storage is D:$002082 on
        # the emulator (specs/variables.yaml, i_variable_storage: no page gives the address).
        t.assertEqual(self.ok("M100->D:$002082"), "\x06")
        t.assertEqual(self.ok("M100=77"), "\x06")
        t.assertEqual(self.ok("I130 M100"), "77\r77\r\x06")
        # An M-variable reads the watchdog's lowest counter value since reset, as RHX:$25 does.
        lowest = int(self.ok("M125->X:$25,0,24,S M125")[:-2])
        t.assertTrue(0 < lowest <= 4096, lowest)
        self.pmac.setVar("I41", 0)
        # An unknown command: BEL ERR003 CR under I6 = 1, still a successful exchange.
        t.assertEqual(self.ok("ZZZ"), "\x07ERR003\r")
        # Starve the background: the counter runs out, the strobe stops, the timer trips, and
        # the card stops communicating. The client sees a timeout, not an answer.
        self.control("starve")
        self.step(5000)
        deadline = time.monotonic() + 10
        while True:
            reply, ok = self.pmac.sendCommand("???")
            if not ok:
                break
            t.assertLess(time.monotonic(), deadline, "the starved card never went silent")
            time.sleep(0.05)
        t.assertIn("I/O error", reply)
        t.assertIn("tripped=true", self.control("state"))
        # Only INIT/ (or power) brings it back (UM p.215); with the load healthy again.
        self.control("plc0 30")
        self.control("init")
        t.assertRegex(self.ok("???"), STATUS_REPLY)
        t.assertEqual(self.ok("I130"), "2000\r\x06", "INIT/ restores the saved I-variables: I130 as flash holds it, its factory default")
        self.step(100)
        t.assertRegex(self.ok("???"), STATUS_REPLY)


class DirectToTheEmulator(unittest.TestCase):
    def test_a_session_on_the_wall_clock_and_its_capture_replays_as_consistent(self):
        with tempfile.TemporaryDirectory() as tmp:
            capture = os.path.join(tmp, "serve.jsonl")
            serve = Process(
                "serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0", "--record", capture
            )
            port, control_port = serve.addresses
            control = Control(int(control_port))
            try:
                pmac = connect(int(port))
                try:
                    Session(self, pmac, control).run()
                finally:
                    pmac.disconnect()
            finally:
                control.close()
                serve.stop()
            code, explains, checked, err = replay(capture)
            self.assertEqual(err, "")
            self.assertEqual(code, 0)
            self.assertTrue(explains["um-215"], explains)
            self.assertGreaterEqual(checked, 15)
            # The capture is evidence, not only a log: Y:$25 read right after a background
            # cycle says 4096 (UM p.215), which rules out the 4095 reading (SRM p.57).
            self.assertFalse(explains["um-215-4095"], explains)


class ThroughTheRecordingProxy(unittest.TestCase):
    def test_a_session_in_virtual_time_through_pmacwd_record_replays_as_consistent(self):
        with tempfile.TemporaryDirectory() as tmp:
            own = os.path.join(tmp, "serve.jsonl")
            proxied = os.path.join(tmp, "record.jsonl")
            serve = Process(
                "serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0",
                "--virtual-time", "--record", own,
            )
            port, control_port = serve.addresses
            record = Process(
                "record", "--listen", "127.0.0.1:0", "--target", f"127.0.0.1:{port}",
                "--control-listen", "127.0.0.1:0", "--control-target", f"127.0.0.1:{control_port}",
                "--virtual-time", "--silence-ms", str(SILENCE_MS), "--sessions", "1", "--out", proxied,
            )
            proxy_port, proxy_control = record.addresses[0], record.addresses[2]
            control = Control(int(proxy_control))
            try:
                pmac = connect(int(proxy_port))
                try:
                    Session(self, pmac, control, step=lambda n: control(f"step {n}")).run()
                finally:
                    pmac.disconnect()
                # One session was asked for: the proxy closes the capture and exits by itself.
                out, err = record.proc.communicate(timeout=10)
                self.assertEqual(record.proc.returncode, 0, err)
                self.assertIn("recorded", out)
            finally:
                control.close()
                record.stop()
                serve.stop()
            for path in (proxied, own):
                code, explains, checked, err = replay(path)
                self.assertEqual((code, err), (0, ""), path)
                self.assertTrue(explains["um-215"], (path, explains))
                self.assertGreaterEqual(checked, 15, path)
                self.assertFalse(explains["um-215-4095"], path)


class AUserPlcThroughTheCardsCommandPath(unittest.TestCase):
    """A user PLC that waits on a countdown timer, writes an I-variable, jogs a motor and kills
    it once it reads the motor past 500 counts: what it does reaches the core as a host's
    commands would (SRM p.421), and the emulator's capture, which records them so, replays as
    consistent."""

    PLC = [
        "OPEN PLC 1 CLEAR",
        # SRM p.176: Isx11 counts down one a servo cycle; the PLC waits a pass a scan. Set
        # once: each scan after the first at the program's end starts again at its top.
        "IF(P2=0)",
        "P2=1",
        "I5111=200",
        "ENDIF",
        "WHILE(I5111>0)",
        "ENDWHILE",
        "IF(P1=0)",
        "P1=1",
        "I130=4321",
        'CMD"#1J/"',
        'CMD"#1J+"',
        "ENDIF",
        "IF(M162/(I108*32)>500)",
        "CMD^K",
        "DISABLE PLC 1",
        "ENDIF",
        "CLOSE",
    ]

    def test_its_commands_reach_the_core_and_the_capture_replays(self):
        with tempfile.TemporaryDirectory() as tmp:
            capture = os.path.join(tmp, "serve.jsonl")
            serve = Process(
                "serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0",
                "--virtual-time", "--record", capture,
            )
            port, control_port = serve.addresses
            control = Control(int(control_port))
            try:
                pmac = connect(int(port))
                session = Session(self, pmac, control)
                try:
                    for line in self.PLC + ["M162->D:$00008B", "I5=2", "ENABLE PLC 1"]:
                        self.assertEqual(session.ok(line), "\x06", line)
                    control("step 150")
                    self.assertEqual(session.ok("P1 I130"), "0\r2000\r\x06", "still waiting on I5111")
                    control("step 2000")
                    self.assertEqual(session.ok("P1 I130"), "1\r4321\r\x06")
                    status = session.ok("#1?")
                    x = int(status[:6], 16)
                    self.assertEqual(x & (3 << 18), 1 << 18, f"killed by the PLC: open loop, amplifier off ({status!r})")
                    position = float(session.ok("#1P")[:-2])
                    self.assertTrue(500 < position < 520, position)
                    control("step 500")
                    self.assertEqual(float(session.ok("#1P")[:-2]), position, "nothing moves after the kill")
                finally:
                    pmac.disconnect()
            finally:
                control.close()
                serve.stop()
            with open(capture) as f:
                recorded = f.read()
            for line in ("#1J/", "#1J+", "I130=4321"):
                self.assertIn(line, recorded)
            code, explains, checked, err = replay(capture)
            self.assertEqual((code, err), (0, ""))
            self.assertTrue(explains["um-215"], explains)
            self.assertGreaterEqual(checked, 5)


if __name__ == "__main__":
    unittest.main()

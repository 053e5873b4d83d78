"""The EPICS pmac driver's motor-record moves, replayed through dls-pmaclib against `pmacwd serve`.

The driver (DiamondLightSource/pmac, pmacApp/src/) needs an EPICS build; its command lines are
rebuilt here from its source, formatted as it formats them, and sent as it sends them, for an
axis whose motor record has MRES = 1 (scale_ = 1: one EGU is one count). Each status is read
the way the driver reads it:

- pmacAxis::setClosedLoop(true) (CNEN = 1): `#1 J/`.
- pmacAxis::move: `I<n>22=%f ` (VELO / (scale * 1000), counts/ms), `I<n>20=%f ` (|VELO / ACCL|
  * 1000, ms), then `#<n> J=%.2f` (absolute) or `#<n> J^%.2f` (relative).
- pmacAxis::moveVelocity (JOGF): the same I-variables, then `#<n> J+` or `#<n> J-`.
- pmacAxis::stop (STOP): `#<n> J/ M<n>40=1` while the amplifier is on, then, for a motor in a
  coordinate system, `&<cs>A Q7<n>=Q8<n>` as a command of its own.
- pmacAxis::home (HOMF): on a Geo Brick, `cid`, then `I70<n>2 I70<n>3 i<n>24 i<n>23 i<n>26`
  parsed with `%d %d $%x %lf %d`, then `#<n> HOME`.
- pmacAxis::setClosedLoop(false) (CNEN = 0): `#<n> K`.
- The fast poll (pmacAxis per axis): `#<n>P`, `#<n>F`, `i<n>24`, `#<n>?`.
  pmacHardwareTurbo::parseAxisStatus: `%6x%6x`; done when the second word's bit 0 (in
  position) is set, or the first word's bit 23 (activated) or bit 19 (amplifier enabled) is
  clear; homed from the second word's bit 10. pmacAxis::getAxisStatus: the motor record's
  position is P + F; moving = not done; DMOV = done.

The card runs on the wall clock (as against a beamline's IOC); the home flag is placed through
the emulator's control port.
"""

import os
import re
import socket
import subprocess
import time
import unittest

from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

PMACWD = os.environ.get("PMACWD", "target/release/pmacwd")
AXIS = 1
CS = 1
# The driver polls its fast list every 0.1 s or so (pmacController's moving poll period).
POLL_S = 0.05


def move_line(velo, accl, position, relative=False):
    """pmacAxis::move with scale_ = 1: VELO in counts/s, ACCL in s."""
    acceleration = velo / accl
    vel = "I%d22=%f " % (AXIS, velo / 1000.0)
    acc = "I%d20=%f " % (AXIS, abs(velo / acceleration) * 1000.0)
    return "%s%s#%d %s%.2f" % (vel, acc, AXIS, "J^" if relative else "J=", position)


class Axis:
    """What the driver makes of one fast poll of an axis."""

    def __init__(self, values):
        p, f, ix24, status = values
        self.position = float(p) + float(f)
        self.ix24 = int(ix24.lstrip("$"), 16)
        self.x, self.y = int(status[:6], 16), int(status[6:], 16)
        self.done = bool(self.y & 1) or not (self.x >> 23) & 1 or not (self.x >> 19) & 1
        self.homed = bool(self.y & (1 << 10))
        self.power = not (self.x >> 18) & 1


class EpicsMotorRecordMoves(unittest.TestCase):
    def setUp(self):
        self.proc = subprocess.Popen(
            [PMACWD, "serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        port, control = re.findall(r"127\.0\.0\.1:(\d+)", self.proc.stdout.readline())[:2]
        self.control_sock = socket.create_connection(("127.0.0.1", int(control)), timeout=5)
        self.control_file = self.control_sock.makefile("rw", newline="\n")
        self.pmac = PmacEthernetInterface(timeout=2.0)
        self.pmac.setConnectionParams("127.0.0.1", port)
        self.assertIsNone(self.pmac.connect())

    def tearDown(self):
        self.pmac.disconnect()
        self.control_file.close()
        self.control_sock.close()
        self.proc.terminate()
        self.proc.communicate(timeout=10)

    def control(self, line):
        self.control_file.write(line + "\n")
        self.control_file.flush()
        reply = self.control_file.readline().strip()
        self.assertTrue(reply.startswith("ok"), f"control `{line}` answered `{reply}`")

    def ask(self, line):
        reply, ok = self.pmac.sendCommand(line)
        self.assertTrue(ok, f"{line!r}: {reply!r}")
        self.assertTrue(reply.endswith("\x06"), f"{line!r} not acknowledged: {reply!r}")
        self.assertNotIn("\x07", reply, f"{line!r} answered an error: {reply!r}")
        return reply.rstrip("\x06").split("\r")[:-1]

    def poll(self):
        return Axis(self.ask(f" #{AXIS}P #{AXIS}F i{AXIS}24 #{AXIS}?"))

    def until_done(self, seconds):
        """Polls as the driver does until the axis is done; every poll on the way."""
        seen = []
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            a = self.poll()
            seen.append(a)
            if a.done:
                return seen
            time.sleep(POLL_S)
        self.fail(f"not done after {seconds} s: last position {seen[-1].position}, status {seen[-1].x:06X}{seen[-1].y:06X}")

    def test_a_move_arrives_and_the_motor_record_sees_it_done_at_its_target(self):
        self.assertEqual(self.ask("cid"), ["603382"])
        self.ask(f"#{AXIS} J/")  # CNEN = 1
        a = self.poll()
        self.assertTrue(a.done and a.power, "closed loop at rest")
        # VELO 2000 counts/s, ACCL 0.1 s: `I122=2.000000 I120=100.000000 #1 J=2000.00`.
        line = move_line(2000.0, 0.1, 2000.0)
        self.assertEqual(line, "I122=2.000000 I120=100.000000 #1 J=2000.00")
        start = time.monotonic()
        self.ask(line)
        seen = self.until_done(10.0)
        took = time.monotonic() - start
        self.assertFalse(seen[0].done, "the first poll after the move sees it moving (DMOV 0)")
        positions = [s.position for s in seen]
        self.assertEqual(positions, sorted(positions), "never backwards")
        self.assertTrue(any(0 < p < 2000 for p in positions), f"on its way: {positions}")
        self.assertEqual(seen[-1].position, 2000.0)
        self.assertTrue(seen[-1].power)
        # 2000 counts at 2 counts/ms with 100 ms of acceleration at each end: 1.1 s.
        self.assertGreater(took, 1.0)
        self.assertLess(took, 3.0)
        # A relative move back (TWR): `#1 J^-500.00`.
        self.ask(move_line(2000.0, 0.1, -500.0, relative=True))
        self.assertFalse(self.poll().done)
        self.assertEqual(self.until_done(10.0)[-1].position, 1500.0)

    def test_stop_ends_a_jog_and_the_motor_stays_where_it_stopped(self):
        self.ask(f"#{AXIS} J/")
        # JOGF at 5000 counts/s, ACCL 0.1 s.
        self.ask("I%d22=%f I%d20=%f #%d J+" % (AXIS, 5.0, AXIS, 100.0, AXIS))
        time.sleep(0.5)
        a = self.poll()
        self.assertFalse(a.done)
        self.assertGreater(a.position, 0.0)
        # pmacAxis::stop, the amplifier on; the axis is in C.S. 1 (second word bit 15).
        self.assertTrue(a.y & (1 << 15) and (a.y >> 20) + 1 == CS)
        self.ask(f"#{AXIS} J/ M{AXIS}40=1")
        self.ask(f"&{CS}A Q7{AXIS}=Q8{AXIS}")
        stopped = self.until_done(2.0)[-1].position
        time.sleep(0.3)
        a = self.poll()
        self.assertTrue(a.done)
        self.assertEqual(a.position, stopped, "at rest where it stopped")

    def test_home_searches_for_the_flag_and_reports_homed_at_zero(self):
        self.ask(f"#{AXIS} J/")
        self.control(f"home-flag {AXIS} 300")
        self.assertEqual(self.ask("cid"), ["603382"])
        flags = self.ask(f"I70{AXIS}2 I70{AXIS}3 i{AXIS}24 i{AXIS}23 i{AXIS}26")
        self.assertEqual(len(flags), 5)
        int(flags[0]), int(flags[1]), int(flags[2].lstrip("$"), 16), float(flags[3]), int(flags[4])
        self.assertFalse(self.poll().homed)
        self.ask(f"#{AXIS} HOME")
        a = self.poll()
        self.assertFalse(a.done, "searching")
        self.assertTrue(a.x & (1 << 10), "home search in progress")
        # Ixx23 = 32 counts/ms (its default): 300 counts in about 10 ms, then back to the flag.
        last = self.until_done(5.0)[-1]
        self.assertTrue(last.homed)
        self.assertEqual(last.position, 0.0)
        self.assertFalse(last.x & (1 << 10), "the search is over")

    def test_kill_ends_a_move_and_the_driver_sees_it_done_with_power_off(self):
        self.ask(f"#{AXIS} J/")
        self.ask(move_line(1000.0, 0.1, 100000.0))
        time.sleep(0.3)
        self.assertFalse(self.poll().done)
        self.ask(f"#{AXIS} K")  # CNEN = 0
        a = self.poll()
        self.assertTrue(a.done and not a.power)
        time.sleep(0.2)
        self.assertEqual(self.poll().position, a.position, "a killed motor does not move")


if __name__ == "__main__":
    unittest.main()

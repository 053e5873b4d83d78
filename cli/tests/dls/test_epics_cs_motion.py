"""The EPICS pmac driver's coordinate-system moves, replayed through dls-pmaclib against `pmacwd serve`.

The driver (DiamondLightSource/pmac, pmacApp/src/) moves a coordinate-system axis by running a
motion program (pmacCSController.cpp's header: "Demand value in EGUs is written to the relevant
Q Variable in Q71..79", the move time in Q70, then the program given at start-up is run). Its
command lines are rebuilt here from its source, formatted as it formats them, and sent as it
sends them, for C.S. 1 running program 10 with X on motor 1 and Y on motor 2 (1000 counts a
unit, so the driver's `scale_` turns a motor record position into EGUs):

- At start-up pmacController reads each motor's axis definition with `&1#<n>->,`
  (pmacHardwareTurbo::CS_AXIS_MAPPING).
- pmacController::makeCSDemandsConsistent: `&1Q7<a>=%f` for the other mapped axes (their
  demand where they stand), before each move.
- pmacCSAxis::move: `&1e` (pmacHardwareTurbo::getCSEnableCommand, "to make sure axes are
  enabled") as a line of its own, then `&1` + `&1Q70=%f ` (getCSVelocityCmd: the move time in
  ms, when the controller uses the C.S. velocity) + `I5187=%f` (getCSAccTimeCmd: Isx87, the
  acceleration time in ms) + `Q7<a>=%.12f` + ` B10R`.
- pmacCSController::processDeferredMoves: `&1` + ` I5187=%fQ7<a>=%.12f` per axis +
  ` Q70=%f B10R`: every deferred axis in one move.
- pmacCSAxis::stop: `&1A Q7<a>=Q8<a>`.
- The pre-fast poll: `&1??`, parsed `%6x%6x%6x` (pmacHardwareTurbo::parseCSStatus): done when
  first-word bit 0 (running program) is clear and second-word bit 17 (in position) set. The
  raw axes are polled as test_epics_motion.py polls them (`#<n>P #<n>F i<n>24 #<n>?`).

The program is written here from the driver's documented interface (TM from Q70, A..Z to
Q71..Q79), as DLS's PROG10_CS_motion.pmc is: LINEAR, ABS, FRAX over every axis, TM(Q70), the
nine axis moves, DWELL0.

The C.S. axes' readbacks, which the driver polls as `&1Q8<a>` (pmacCSAxis.cpp: "Use Q81 - Q89
for motor readback positions"), come from a position-reporting PLC that the beamline
downloads (pmacCSController.cpp: "The EPICS driver expects the position reporting PLC to
report the positions of these axes on Q81..89, in EGUs"). One is written here in the form of
DLS's (etc/bootstrap/lab.pmc: "A PLC(sx+15) needs to be made to do position reporting ...
As forward kinematic, but with Px = mx62/(Ix08*32)", `ADDRESS&3` and the jacks' positions
as `MRES*m362/(I308*32)+OFF`, with MRES and OFF in P(4800+n) and P(4900+n) as
motor_in_cs.template sets them): PLC 16 for C.S. 1, X = `P4801*M162/(I108*32)+P4901` into
Q87 and Y into Q88, with the Geo Brick's M-variable definitions `M162->D:$00008B` and
`M262->D:$00010B` (etc/bootstrap/BRICK_M_variables.pmc) and I5=2 (PLC program control, as
DLS's PMAC_CLIPPER_Startup.pmc sets it). The card runs it in its background; the readbacks
arrive at the targets only through it (disabled, they stay where they were).
"""

import os
import re
import subprocess
import time
import unittest

from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

PMACWD = os.environ.get("PMACWD", "target/release/pmacwd")
CS = 1
PROGRAM = 10
COUNTS_PER_UNIT = 1000.0
POLL_S = 0.05

DOWNLOAD = [
    "CLOSE",
    f"OPEN PROG {PROGRAM}",
    "CLEAR",
    "LINEAR",
    "ABS",
    "FRAX(A,B,C,U,V,W,X,Y,Z)",
    "TM(Q70)",
    "A(Q71)B(Q72)C(Q73)U(Q74)V(Q75)W(Q76)X(Q77)Y(Q78)Z(Q79)",
    "DWELL0",
    "CLOSE",
]

# Axis X is the driver's axis 7 (A is 1), Y its axis 8.
X, Y = 7, 8

# The position-reporting PLC: PLC(cs+15), MRES 1/1000 EGU a count, no offset.
REPORTING_PLC = CS + 15
REPORTING = [
    "M162->D:$00008B",
    "M262->D:$00010B",
    f"P4801={1 / COUNTS_PER_UNIT} P4802={1 / COUNTS_PER_UNIT} P4901=0 P4902=0",
    f"OPEN PLC {REPORTING_PLC}",
    "CLEAR",
    f"ADDRESS&{CS}",
    "Q87=P4801*M162/(I108*32)+P4901",
    "Q88=P4802*M262/(I208*32)+P4902",
    "CLOSE",
    "I5=2",
    f"ENABLE PLC {REPORTING_PLC}",
]


class EpicsCsMoves(unittest.TestCase):
    def setUp(self):
        self.proc = subprocess.Popen(
            [PMACWD, "serve", "--listen", "127.0.0.1:0", "--no-control"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        port = re.findall(r"127\.0\.0\.1:(\d+)", self.proc.stdout.readline())[0]
        self.pmac = PmacEthernetInterface(timeout=2.0)
        self.pmac.setConnectionParams("127.0.0.1", port)
        self.assertIsNone(self.pmac.connect())
        for line in DOWNLOAD + REPORTING:
            self.ask(line)
        self.ask(f"&{CS}#1->1000X")
        self.ask(f"&{CS}#2->1000Y")
        # The motor records' CNEN = 1.
        self.ask("#1 J/")
        self.ask("#2 J/")

    def tearDown(self):
        self.pmac.disconnect()
        self.proc.terminate()
        self.proc.communicate(timeout=10)

    def ask(self, line):
        reply, ok = self.pmac.sendCommand(line)
        self.assertTrue(ok, f"{line!r}: {reply!r}")
        self.assertTrue(reply.endswith("\x06"), f"{line!r} not acknowledged: {reply!r}")
        self.assertNotIn("\x07", reply, f"{line!r} answered an error: {reply!r}")
        return reply.rstrip("\x06").split("\r")[:-1]

    def cs_done(self):
        (words,) = self.ask(f"&{CS}??")
        first, second, _ = (int(words[i : i + 6], 16) for i in (0, 6, 12))
        return first & 1 == 0 and second & (1 << 17) != 0, first & 1 == 1

    def readbacks(self):
        """The C.S. axes' readbacks as pmacCSAxis polls them (`&1Q8<a>`), in EGUs."""
        x, y = self.ask(f" &{CS}Q8{X} &{CS}Q8{Y}")
        return float(x), float(y)

    def assertReadbacks(self, expected, why=None, delta=1e-9):
        """The readbacks, to the 1e-9 EGU of the PLC's floating-point arithmetic."""
        for got, want in zip(self.readbacks(), expected):
            self.assertAlmostEqual(got, want, delta=delta, msg=why)

    def positions(self):
        p1, _, _, _, p2, _, _, _ = self.ask(" #1P #1F i124 #1? #2P #2F i224 #2?")
        return float(p1), float(p2)

    def move(self, axis, egu, move_ms, acc_ms):
        """pmacCSAxis::move: makeCSDemandsConsistent, `&1e`, the move line."""
        other = Y if axis == X else X
        p = self.positions()[0 if other == X else 1] / COUNTS_PER_UNIT
        self.ask(f"&{CS}Q7{other}={p:f}")
        self.ask(f"&{CS}e")
        vel = f"&{CS}Q70={move_ms:f} "
        acc = f"I{CS + 50}87={acc_ms:f}"
        line = f"&{CS}{vel}{acc}Q7{axis}={egu:.12f} B{PROGRAM}R"
        self.ask(line)
        return line

    def until_done(self, seconds):
        seen = []
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            done, running = self.cs_done()
            seen.append((done, running, self.positions(), self.readbacks()))
            if done:
                return seen
            time.sleep(POLL_S)
        self.fail(f"not done after {seconds} s: {seen[-3:]}")

    def test_the_axis_mapping_reads_back_as_the_driver_reads_it_at_start_up(self):
        self.assertEqual(self.ask(f"&{CS}#1->,"), ["1000X"])
        self.assertEqual(self.ask(f"&{CS}#2->,"), ["1000Y"])
        self.assertEqual(self.ask(f"LIST PROG {PROGRAM}")[0], "LINEAR")

    def test_a_cs_move_runs_the_program_and_the_axes_arrive_where_it_says(self):
        self.assertEqual(self.cs_done(), (True, False))
        line = self.move(X, 2.0, 500.0, 100.0)
        self.assertEqual(line, "&1&1Q70=500.000000 I5187=100.000000Q77=2.000000000000 B10R")
        start = time.monotonic()
        seen = self.until_done(3.0)
        took = time.monotonic() - start
        self.assertTrue(seen[0][1], "the first poll sees the program running")
        xs = [p[0] for _, _, p, _ in seen]
        self.assertEqual(xs, sorted(xs), "X never goes back")
        self.assertTrue(any(0 < x < 2000 for x in xs), f"positions on the way: {xs}")
        # TM 500 ms plus TA 100 ms.
        self.assertGreater(took, 0.55, took)
        self.assertEqual(self.positions(), (2000.0, 0.0))
        # The readbacks followed the axis on its way (the PLC scans every background cycle)
        # and arrive at the target (the motor record's readback, RBV, is Q87).
        rx = [r[0] for _, _, _, r in seen]
        self.assertEqual(rx, sorted(rx), "the X readback never goes back")
        self.assertTrue(any(0 < x < 2 for x in rx), f"readbacks on the way: {rx}")
        self.assertReadbacks((2.0, 0.0))
        # And Y, with X's demand kept where it stands.
        self.move(Y, -1.5, 200.0, 50.0)
        self.until_done(3.0)
        self.assertEqual(self.positions(), (2000.0, -1500.0))
        self.assertReadbacks((2.0, -1.5))

    def test_the_readbacks_come_from_the_plc_and_stop_with_it(self):
        self.assertEqual(self.ask(f"LIST PLC {REPORTING_PLC}")[1], "Q87=P4801*M162/(I108*32)+P4901")
        self.move(X, 1.0, 200.0, 50.0)
        self.until_done(3.0)
        self.assertReadbacks((1.0, 0.0))
        self.ask(f"DISABLE PLC {REPORTING_PLC}")
        self.move(X, 3.0, 200.0, 50.0)
        self.until_done(3.0)
        self.assertEqual(self.positions(), (3000.0, 0.0))
        self.assertReadbacks((1.0, 0.0), "no PLC, no readback")
        self.ask(f"ENABLE PLC {REPORTING_PLC}")
        time.sleep(POLL_S)
        self.assertReadbacks((3.0, 0.0))

    def test_a_cs_move_after_a_motor_record_move_of_one_of_its_motors(self):
        # pmacAxis::move on motor 1 (test_epics_motion.py), done when in position; then the
        # C.S. move runs from where motor 1 stands.
        self.ask("I122=2.000000 I120=100.000000 #1 J=500.00")
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline:
            (status,) = self.ask("#1?")
            if int(status[6:], 16) & 1:
                break
            time.sleep(POLL_S)
        self.assertEqual(self.positions(), (500.0, 0.0))
        self.move(X, 1.5, 300.0, 50.0)
        seen = self.until_done(3.0)
        self.assertTrue(seen[0][1], "the program ran")
        self.assertEqual(self.positions(), (1500.0, 0.0))

    def test_a_deferred_move_moves_both_axes_together(self):
        self.ask(f"&{CS}e")
        deferred = f" I{CS + 50}87=100.000000Q7{X}={1.0:.12f} I{CS + 50}87=100.000000Q7{Y}={-1.0:.12f}"
        self.ask(f"&{CS}{deferred} Q70={800.0:f} B{PROGRAM}R")
        time.sleep(0.45)
        x, y = self.positions()
        self.assertAlmostEqual(x, -y, delta=1.0)
        self.assertTrue(200 < x < 800, x)
        self.until_done(3.0)
        self.assertEqual(self.positions(), (1000.0, -1000.0))

    def test_a_stop_stops_the_axis_and_nothing_moves_after(self):
        self.move(X, 20.0, 2000.0, 100.0)
        time.sleep(0.5)
        done, running = self.cs_done()
        self.assertTrue(running and not done)
        self.ask(f"&{CS}A Q7{X}=Q8{X}")
        self.until_done(1.0)
        stopped = self.positions()
        self.assertTrue(0 < stopped[0] < 20000, stopped)
        time.sleep(0.3)
        self.assertEqual(self.positions(), stopped)
        # The demand the stop line took from the readback is where the axis came to rest
        # (within the deceleration after `A`, which the readback still followed).
        (demand,) = self.ask(f"&{CS}Q7{X}")
        self.assertTrue(0 < float(demand) <= stopped[0] / COUNTS_PER_UNIT, (demand, stopped))
        # `P` reports to 1/32 count (SRM p.260), M162 in 1/(I108*32) counts.
        self.assertReadbacks((stopped[0] / COUNTS_PER_UNIT, 0.0), delta=1 / 32 / COUNTS_PER_UNIT)


if __name__ == "__main__":
    unittest.main()

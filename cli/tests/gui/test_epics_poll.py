"""The EPICS pmac driver's poll lists, replayed through dls-pmaclib against `pmacwd serve`.

The driver (DiamondLightSource/pmac, pmacApp/src/) needs an EPICS build, so its command lines
are rebuilt here from its source, as it builds them for a Geo Brick (cid 603382) with 8 axes,
and sent as it sends them; each answer is read the way the driver reads it:

- pmacController::setupBrokerVariables: fast `???`, M70-M73 (CPU load), M4038-M4040
  (trajectory); pre-fast M4034; medium `&n%` for the I68 + 1 coordinate systems, M5000-M5031
  (PLC status), M5180 + 100 p (program status), M32-M39 and M0-M15 (Geo Brick GPIO); slow I42,
  I8, I7002, M4037, M4041, M4042, M4049.
- pmacAxis (per axis): fast `#nP`, `#nF`, `i<n>24`, `#n?`; at start `I<n>13 I<n>14 I<n>30
  I<n>31 I<n>33`.
- pmacHardwareTurbo::setupCSStatus: pre-fast `&n??`.
- pmacController::mediumUpdate: `&n#m->,` (pmacHardwareTurbo CS_AXIS_MAPPING) for every axis
  with a coordinate system, here all 8 axes in C.S. 1, on every medium poll.
- pmacCommandStore::buildCommandString: keys joined with spaces after a leading space, at most
  PMAC_MAX_REQUESTS = 40 per line; pmacCommandStore::updateReply: the answer split at CR, one
  value per key in order.
- parseGlobalStatus `%6x`, parseAxisStatus `%6x%6x` and `%4x%4x%4x`, parseCSStatus
  `%6x%6x%6x`: hex words of those widths.
"""

import os
import re
import subprocess
import unittest

from dls_pmaclib.dls_pmacremote import PmacEthernetInterface

PMACWD = os.environ.get("PMACWD", "target/release/pmacwd")
AXES = 8
MAX_REQUESTS = 40  # pmacCommandStore.cpp PMAC_MAX_REQUESTS


def driver_lists(cs_count):
    axes = range(1, AXES + 1)
    prefast = ["M4034"] + [f"&{cs}??" for cs in range(1, cs_count + 1)]
    fast = ["???", "M70", "M71", "M72", "M73", "M4039", "M4040", "M4038"]
    for a in axes:
        fast += [f"#{a}P", f"#{a}F", f"i{a}24", f"#{a}?"]
    medium = [f"&{cs}%" for cs in range(1, cs_count + 1)]
    medium += [f"&1#{a}->," for a in axes]
    medium += [f"M{5000 + p}" for p in range(32)]
    medium += [f"M{p * 100 + 5180}" for p in range(16)]
    medium += [f"M{32 + g}" for g in range(8)] + [f"M{g}" for g in range(16)]
    slow = ["I42", "I8", "I7002", "M4037", "M4041", "M4042", "M4049"]
    startup = [f"I{a}13 I{a}14 I{a}30 I{a}31 I{a}33" for a in axes]
    return {"prefast": prefast, "fast": fast, "medium": medium, "slow": slow}, startup


def command_strings(keys):
    """pmacCommandStore::buildCommandString: ` k1 k2 ...`, 40 keys a line."""
    lines = []
    for i in range(0, len(keys), MAX_REQUESTS):
        lines.append(" " + " ".join(keys[i : i + MAX_REQUESTS]))
    return lines


NUMBER = re.compile(r"^-?\d+(\.\d+)?$")
HEX = re.compile(r"^\$[0-9A-F]+$")


def check_value(key, value):
    """What the driver's parser needs of each answer; a message when it does not fit."""
    if key == "???":
        ok = re.fullmatch(r"[0-9A-F]{12}", value)
    elif key.endswith("??"):
        ok = re.fullmatch(r"[0-9A-F]{18}", value)
    elif key.endswith("?"):
        ok = re.fullmatch(r"[0-9A-F]{12}", value)
    elif key.endswith("->,"):
        ok = re.fullmatch(r"[-+0-9.XYZABCUVWI]+", value)  # an axis definition, `0` for none
    elif re.fullmatch(r"i\d+24", key):
        ok = HEX.match(value)  # flag control, an address-type I-variable: hex under I9 = 2
    else:
        ok = NUMBER.match(value)
    return None if ok else f"`{key}` answered `{value}`"


class EpicsPollLists(unittest.TestCase):
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

    def test_every_poll_list_is_answered_value_for_key(self):
        self.assertEqual(self.ask("cid"), ["603382"], "the driver picks the Geo Brick lists from cid")
        # The driver counts coordinate systems as I68 + 1 on a Turbo PMAC.
        cs_count = int(self.ask("I68")[0]) + 1
        self.assertEqual(cs_count, 16)
        lists, startup = driver_lists(cs_count)
        for line in startup:
            self.assertEqual(len(self.ask(line)), 5, line)
        problems = []
        for name, keys in lists.items():
            for line in command_strings(keys):
                sent = line.split()
                got = self.ask(line)
                self.assertEqual(len(got), len(sent), f"{name}: {len(sent)} keys, {len(got)} values for {line!r}")
                problems += [p for k, v in zip(sent, got) if (p := check_value(k, v))]
        self.assertEqual(problems, [])

    def test_the_motor_commands_the_driver_sends_are_accepted(self):
        # Every command line the driver builds for a Turbo PMAC / Geo Brick, formatted as its
        # source formats it (DiamondLightSource/pmac, pmacApp/src), none left out.
        self.assertEqual(self.ask("cid"), ["603382"])
        self.assertRegex(self.ask("cpu")[0], r"^DSP563\d\d$", "pmacController::readDeviceType")
        axis, cs = 1, 1
        lines = [
            # pmacAxis::move: velocity and acceleration, then the jog to the target.
            f"I{axis}22=0.500000 I{axis}20=100.000000 #{axis} J=2000.00",
            f" i{axis}24=i{axis}24&$FDFFFF",
            # pmacAxis::home: the flag set, then the search.
            f" i{axis}24=i{axis}24|$20000",
            f"#{axis} HOME",
            # pmacAxis::moveVelocity: a jog at a velocity.
            f"I{axis}22=2.000000 I{axis}20=50.000000 #{axis} J+",
            # pmacAxis::stop, with and without the C.S. stop of a motor in one.
            f"#{axis} J/ M{axis}40=1",
            f"M{axis}40=1",
            f"&{cs}A Q7{axis}=Q8{axis}",
            f"#{axis} J/",
            f"#{axis} K",
            # pmacAxis::setPosition (Turbo): the kill and the position offsets, as expressions.
            f"#{axis}K M{axis}61=100*32*I{axis}08 M{axis}62=100*32*I{axis}08",
            # pmacController limits: the soft limits off and on.
            f"I{axis}13=0 I{axis}14=0",
            f"I{axis}14=-1000 I{axis}13=1",
            # pmacController feedrate: ` &n%v` with a fraction.
            f" &{cs}%100.000000",
            # pmacCSAxis / pmacCSController: a C.S. move and its stop.
            f"&{cs}Q70=1.500000 ",
            f"I{cs + 50}87=100.000000",
            f"&{cs}Q71=10.000000000000 B1R",
            f"&{cs}A Q71=Q81",
            f"&{cs}A",
            # pmacCsGroups: redefining the axes of a C.S., and its look-ahead.
            "undefine all",
            f"&{cs} #{axis}->X",
            f"&{cs} #2->Y",
            "DELETE ALL TEMPS",
            f"&{cs}DEFINE LOOKAHEAD 50,10",
            # pmacController kill all.
            "\x0b",
        ]
        for line in lines:
            self.ask(line)
        self.assertEqual(self.ask(f"&{cs}%"), ["100"])
        self.assertEqual(self.ask(f"&{cs}#{axis}->,"), ["X"], "the definition set above, read back")
        self.assertEqual(self.ask(f"&{cs}#3->,"), ["0"], "a motor without one")
        self.assertEqual(self.ask(f"I{axis}22"), ["2"], "the last jog speed written")
        self.assertEqual(self.ask(f"I{axis}22=0.25 I{axis}22"), ["0.25"], "a fraction is kept")
        self.assertEqual(self.ask(f"M{axis}61"), ["307200"], "100*32*I108 with I108 = 96, its default")
        # pmacCSController::listKinematic: the listing loop ends at an empty reply.
        self.assertEqual(self.ask(f"&{cs} list forward,0,1"), [])


if __name__ == "__main__":
    unittest.main()

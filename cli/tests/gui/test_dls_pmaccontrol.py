"""DLS's engineering GUI dls-pmaccontrol 3.2.3, unmodified, against `pmacwd serve`.

The GUI is built and driven as a user would drive it (its Connect, Global status and KILL ALL
buttons), in this process, under a virtual X server (run.sh). The test only watches: it wraps
the GUI's connection object so that every command line and its answer are kept, and it reads
the GUI's own widgets. Screenshots of each state go to $SCREENSHOTS.

What the GUI does, from its source (dls_pmac_control/__main__.py, commsThread.py):
- on Connect: `i6=1 i3=2 ver`, `cid`, `I10` (it divides by it), `i20 i21 i22 i23` (counts
  MACRO axes: `$0` is none);
- every 0.1 s one poll line `i65???&1??%#1?PVF m190 p99#2?PVF ...` and expects 4 + 6 x 8
  values back;
- KILL ALL sends <CTRL-K> (0x0B) as a command line.
"""

import os
import re
import socket
import subprocess
import sys
import time
import types
import unittest

from PyQt5.QtWidgets import QApplication, QMessageBox

from dls_pmac_control.__main__ import Controlform

PMACWD = os.environ.get("PMACWD", "target/release/pmacwd")
SCREENSHOTS = os.environ.get("SCREENSHOTS", "target/gui")
AXES = 8  # the emulated Geo Brick: 8 axes, no MACRO IC


class Emulator:
    """`pmacwd serve` on free loopback ports, with its control interface."""

    def __init__(self):
        self.proc = subprocess.Popen(
            [PMACWD, "serve", "--listen", "127.0.0.1:0", "--control", "127.0.0.1:0"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        banner = self.proc.stdout.readline()
        ports = re.findall(r"127\.0\.0\.1:(\d+)", banner)
        if len(ports) != 2:
            raise RuntimeError(f"pmacwd serve did not start: {banner!r} {self.proc.stderr.read()}")
        self.port, control_port = ports
        self.control_sock = socket.create_connection(("127.0.0.1", int(control_port)), timeout=5)
        self.control_file = self.control_sock.makefile("rw", newline="\n")

    def control(self, line):
        self.control_file.write(line + "\n")
        self.control_file.flush()
        reply = self.control_file.readline().strip()
        assert reply.startswith("ok"), f"control `{line}` answered `{reply}`"
        return reply

    def stop(self):
        self.control_file.close()
        self.control_sock.close()
        self.proc.terminate()
        self.proc.communicate(timeout=10)


def options(port):
    """The options the GUI's own command line gives (`-o tcpip -s 127.0.0.1 -p PORT -t 1`)."""
    return types.SimpleNamespace(
        verbose=False,
        protocol="tcpip",
        server="127.0.0.1",
        port=str(port),
        username="root",
        password="deltatau",
        defaultAxis=1,
        macroAxisStartIndex=0,
        nAxes=None,
        timeout=1.0,
    )


class Exchanges:
    """Every command line the GUI sends and what came back, kept by wrapping the connection's
    sendCommand (the GUI's own method still does the work)."""

    def __init__(self, pmac):
        self.log = []
        original = pmac.sendCommand

        def recorded(command, shouldWait=True):
            reply, ok = original(command, shouldWait)
            self.log.append((time.monotonic(), command, reply, ok))
            return reply, ok

        pmac.sendCommand = recorded

    def polls(self, since=0.0):
        return [(c, r, ok) for t, c, r, ok in self.log if t >= since and c.startswith("i65???")]


def pump(app, seconds):
    """Runs the GUI's event loop for a while (its poll thread posts events to it)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        time.sleep(0.02)


def pump_until(app, condition, seconds, what):
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        if condition():
            return
        time.sleep(0.02)
    raise AssertionError(f"not within {seconds} s: {what}")


def shot(widget, name):
    os.makedirs(SCREENSHOTS, exist_ok=True)
    path = os.path.join(SCREENSHOTS, name)
    assert widget.grab().save(path), f"could not save {path}"
    return path


def values(reply):
    return reply.rstrip("\x06\r").split("\r")


class DlsPmacControlAgainstTheEmulator(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.app = QApplication.instance() or QApplication(sys.argv)
        # A message box is modal and would wait for a click forever: record it and fail.
        cls.messages = []
        QMessageBox.information = lambda parent, title, text, *a: cls.messages.append((title, text))

    def setUp(self):
        self.emulator = Emulator()
        self.form = Controlform(options(self.emulator.port))
        # As the GUI's main() shows it, tall enough for all 8 rows of the motor table.
        self.form.resize(700, 1000)
        self.form.show()
        self.form.splitter.moveSplitter(400, 1)
        self.form.remoteConnect()
        self.assertEqual(self.messages, [], "the GUI reported an error while connecting")
        self.exchanges = Exchanges(self.form.pmac)

    def tearDown(self):
        self.form.die()
        self.form.close()
        pump(self.app, 0.3)
        self.emulator.stop()

    def first_good_poll(self, since=0.0):
        pump_until(
            self.app,
            lambda: any(ok and r.endswith("\x06") for _, r, ok in self.exchanges.polls(since)),
            10,
            "a poll line answered",
        )
        return next((c, r) for c, r, ok in self.exchanges.polls(since) if ok and r.endswith("\x06"))

    def test_connect_poll_and_positions(self):
        # Connecting read I10 (no division by zero) and found 8 axes from I20..I23 = $0.
        self.assertEqual(self.form.table.rowCount(), AXES)
        self.assertAlmostEqual(self.form.servoCycleTime, 8388608.0 / 3713707, places=9)
        self.assertIn("Geo Brick", self.form.windowTitle())
        command, reply = self.first_good_poll()
        # The poll line as the GUI built it, answered with every value it asks for.
        self.assertTrue(command.startswith("i65???&1??%#1?PVF m190 p99#2?PVF"), command)
        v = values(reply)
        self.assertEqual(len(v), 4 + 6 * AXES, v)
        self.assertNotIn("\x07", reply, "no error in the poll reply")
        self.assertRegex(v[1], r"^[0-9A-F]{12}$")
        self.assertRegex(v[2], r"^[0-9A-F]{18}$")
        pump(self.app, 0.5)
        # The main window's table shows each motor's position, velocity and following error.
        for row in range(AXES):
            self.assertEqual(self.form.table.item(row, 0).text(), "0.0", f"position of motor {row + 1}")
            self.assertEqual(self.form.table.item(row, 2).text(), "0.0", f"following error of motor {row + 1}")
        self.assertEqual(self.form.lblPosition.text(), "0.0")
        self.assertEqual(self.form.lblIdentity.text(), "Identity not set", "I65 = 0")
        print("screenshot:", shot(self.form, "main-window.png"))

    def test_global_status_window_shows_what_question_marks_say(self):
        self.form.GlobalStatusScreen.show()
        self.first_good_poll()
        # Stop the GUI's polling (its own button) and let it handle what already came, so that
        # the window shows the last poll's `???`: the status changes while the card runs (the
        # background checksum sets and clears "PROM Checksum Active").
        self.form.btnPollingStatus.click()
        pump(self.app, 1.0)
        _, reply, _ = [p for p in self.exchanges.polls() if p[2] and p[1].endswith("\x06")][-1]
        status = int(values(reply)[1], 16)
        screen = self.form.GlobalStatusScreen
        on = screen.greenLedOn.cacheKey()
        lit = [bit for bit in range(48) if screen.lstLeds[bit].pixmap().cacheKey() == on]
        self.assertEqual(lit, [bit for bit in range(48) if status >> bit & 1], f"??? = {values(reply)[1]}")
        print("screenshot:", shot(screen, "global-status.png"))

    def amplifiers(self, since):
        """Each motor's amplifier-enable bit (first word bit 19, SRM p.282) in the first poll
        answered after `since`."""
        _, reply = self.first_good_poll(since)
        v = values(reply)[4:]
        return [bool(int(v[6 * m], 16) >> 24 & (1 << 19)) for m in range(AXES)]

    def test_kill_all_disables_every_motor(self):
        # Close every loop first (J/ on a killed motor closes its loop, UM p.217): the
        # amplifiers come on, as the GUI's status window shows.
        self.form.statusScreen.show()
        for m in range(1, AXES + 1):
            reply, ok = self.form.pmac.sendCommand(f"#{m}J/")
            self.assertEqual((reply, ok), ("\x06", True))
        self.assertEqual(self.amplifiers(time.monotonic()), [True] * AXES, "J/ closed every loop")
        pump(self.app, 0.5)
        print("screenshot:", shot(self.form.statusScreen, "motor1-status-loop-closed.png"))
        # KILL ALL: the GUI sends <CTRL-K> (UM p.217, row 11; UM p.319: open loop, amplifier off).
        self.form.btnKillAll.click()
        kill = [(c, r, ok) for _, c, r, ok in self.exchanges.log if c == "\x0b"]
        self.assertEqual(kill, [("\x0b", "\x06", True)], "CTRL-K sent and acknowledged")
        since = time.monotonic()
        self.assertEqual(self.amplifiers(since), [False] * AXES, "every amplifier off after KILL ALL")
        _, reply = self.first_good_poll(since)
        for m in range(AXES):
            word = int(values(reply)[4 + 6 * m], 16)
            self.assertEqual(word >> 24 & (1 << 18), 1 << 18, f"motor {m + 1}: loop not open after KILL ALL")
        pump(self.app, 0.5)
        print("screenshot:", shot(self.form.statusScreen, "motor1-status-after-kill-all.png"))
        print("screenshot:", shot(self.form, "main-window-after-kill-all.png"))

    def motor1(self, since):
        """Motor 1's status words, position and velocity in the first poll answered after `since`."""
        _, reply = self.first_good_poll(since)
        status, position, velocity = values(reply)[4:7]
        return int(status[:6], 16), int(status[6:], 16), float(position), float(velocity)

    def test_holding_jog_pos_moves_the_motor_on_screen_and_home_completes(self):
        # The loop closed first (J/ on a killed motor closes it, as the EPICS driver's CNEN does).
        reply, ok = self.form.pmac.sendCommand("#1J/")
        self.assertEqual((reply, ok), ("\x06", True))
        # "jog inc" off (checked by default, the buttons then jog by a distance), then hold
        # "jog +" for 2 s: the GUI sends J+ when pressed and J/ when released.
        self.form.chkJogInc.setChecked(False)
        pressed = time.monotonic()
        self.form.btnJogPos.pressed.emit()
        pump(self.app, 2.0)
        x, _, position, velocity = self.motor1(time.monotonic())
        self.assertGreater(position, 10_000.0, "32 counts/ms (Ixx22) for most of 2 s")
        self.assertGreater(velocity, 0.0)
        self.assertEqual(x & (1 << 13), 0, "desired velocity not zero while jogging")
        pump(self.app, 0.3)
        self.assertGreater(float(self.form.lblPosition.text()), 10_000.0, "the jog ribbon shows it")
        # At the jog speed, `V` is what a card answers: counts per servo cycle to a tenth (SRM
        # p.402: "21.9 ; Turbo PMAC responds with 21.9 cts/cycle (*8,388,608/3,713,707 = 49.5
        # cts/msec)"): 32 counts/ms x 0.4427 ms = 14.17, so 14.2. The GUI multiplies it by
        # 8388608/I10 ("On Turbo PMAC velocity is returned in counts per servo cycle so you
        # have to use the servo cycle time to convert it to cts/msec", dls_pmac_control
        # __main__.py) and shows 32.1: counts/ms, under its own label "cts/s"; the extra
        # tenth is V's rounding, as on a card.
        self.assertEqual(velocity, 14.2)
        i10 = float(self.form.pmac.sendCommand("I10")[0].rstrip("\x06").strip())
        shown = str(round(velocity * 8388608.0 / i10, 1))
        self.assertEqual((shown, self.form.lblVelo.text(), self.form.table.item(0, 1).text()), ("32.1", "32.1", "32.1"))
        print("screenshot:", shot(self.form, "main-window-jogging.png"))
        self.form.btnJogPos.released.emit()
        sent = [c for t, c, _, _ in self.exchanges.log if t >= pressed and c.startswith("#1J")]
        self.assertEqual(sent, ["#1J+", "#1J/"], "what the ribbon sent")
        # J/ decelerates at the jog rate (Ixx19, 0.15625 counts/ms²: about 113 ms, the core's
        # longest stop); then at rest, in position.
        pump(self.app, 0.5)
        x, y, stopped, velocity = self.motor1(time.monotonic())
        self.assertEqual((velocity, x & (1 << 13), y & 1), (0.0, 1 << 13, 1), "at rest, in position")
        pump(self.app, 0.3)
        self.assertAlmostEqual(float(self.form.lblPosition.text()), stopped, delta=0.1, msg="the ribbon shows where it stopped, to a tenth")
        # Home: the flag placed 1000 counts past where it stopped, in the search direction
        # (Ixx23 = +32 counts/ms).
        self.emulator.control(f"home-flag 1 {int(stopped) + 1000}")
        self.form.btnHome.clicked.emit()
        self.assertIn("#1HM", [c for _, c, _, _ in self.exchanges.log], "the ribbon's home command")
        pump_until(
            self.app,
            lambda: self.motor1(time.monotonic())[1] & (1 << 10),
            10,
            "home complete (second word bit 10)",
        )
        x, y, position, velocity = self.motor1(time.monotonic())
        self.assertEqual((position, velocity, y & 1), (0.0, 0.0, 1), "homed at 0, in position")
        pump(self.app, 0.3)
        self.assertEqual(float(self.form.lblPosition.text()), 0.0)
        print("screenshot:", shot(self.form, "main-window-homed.png"))

    def test_a_watchdog_trip_is_lost_communication_and_init_brings_it_back(self):
        self.first_good_poll()
        # Starve the background: I40 = 0 trips after ~4096 servo cycles (UM p.215), ~2 s.
        self.emulator.control("starve")
        pump_until(self.app, lambda: "tripped=true" in self.emulator.control("state"), 15, "the watchdog trip")
        since = time.monotonic()
        pump_until(
            self.app,
            lambda: any(not ok for _, _, ok in self.exchanges.polls(since)),
            10,
            "a poll the tripped card does not answer",
        )
        failed = [r for _, r, ok in self.exchanges.polls(since) if not ok]
        self.assertIn("I/O error", failed[0], "the GUI's connection reports lost communication")
        # What a user sees: `???` typed into the GUI's command line gets the I/O error.
        self.form.lneSend.setText("???")
        self.form.btnSend.click()
        pump(self.app, 0.3)
        self.assertIn("I/O error during comm with PMAC", self.form.txtShell.toPlainText())
        print("screenshot:", shot(self.form, "main-window-tripped.png"))
        # INIT/ resets the card (UM p.215): the GUI's next polls are answered again. The
        # starving load goes first, or the card would trip again 2 s after INIT/.
        self.emulator.control("load plc0_units=0")
        self.emulator.control("init")
        _, reply = self.first_good_poll(time.monotonic())
        self.assertEqual(len(values(reply)), 4 + 6 * AXES)
        self.form.lneSend.setText("???")
        self.form.btnSend.click()
        pump(self.app, 0.5)
        self.assertRegex(self.form.txtShell.toPlainText().splitlines()[-1], r"^[0-9A-F]{12}\s*$")
        print("screenshot:", shot(self.form, "main-window-after-init.png"))


if __name__ == "__main__":
    unittest.main()

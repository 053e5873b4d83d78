#!/usr/bin/env python3
"""Writes the SYNTHETIC host logs of specs/captures/ (run from that folder).

A small simulation of the watchdog as UM p.215 describes it (I40 = 0: reload 4096; the
counter falls by one each servo cycle at 2.25 kHz; a background cycle reloads it and moves
the checksum engine on), polled by a host every 0.5 s: X:$0, ???, Y:$25, X:$25. These are
not recordings of a card; `pmacwd replay` judges them like any host log.
"""
import random

SERVO_HZ, RELOAD, POLL_CYCLES = 2250, 4096, 1125


class Card:
    def __init__(self, cpu):
        self.cpu, self.x0 = cpu, 0
        self.restart()

    def restart(self):
        self.counter = self.lowest = RELOAD
        self.firmware_area, self.rti_reentry, self.tripped, self.x0 = True, False, False, 0

    def run(self, cycles, background_every=None, starved=False):
        """`cycles` servo cycles; a background cycle every 9..13 unless starved."""
        since = 0
        for _ in range(cycles):
            if self.tripped:
                return
            self.x0 = (self.x0 + 1) % (1 << 24)
            self.counter = max(self.counter - 1, 0)
            self.lowest = min(self.lowest, self.counter)
            if starved:
                self.rti_reentry = True
                self.stale = getattr(self, "stale", 0) + 1 if self.counter == 0 else 0
                if self.stale > 45:  # hardware delay at 25 Hz: 2250 / 50 cycles
                    self.tripped = True
                continue
            since += 1
            if since >= (background_every or random.randint(9, 13)):
                self.counter, since = RELOAD, 0
                self.firmware_area = not self.firmware_area

    def status(self):
        x = (0x1000 if self.firmware_area else 0) | (0x400000 if self.rti_reentry else 0)
        x |= 0x200000 if self.cpu & 2 else 0
        y = 0x200000 if self.cpu & 1 else 0
        return f"{x:06X}{y:06X}"


def stamp(t):
    return f"{int(t // 3600):02d}:{int(t // 60) % 60:02d}:{t % 60:06.3f}"


def poll(out, card, t):
    for cmd, reply in [
        ("RHX:$0", f"{card.x0:06X}"),
        ("???", card.status()),
        ("RHY:$25", f"{card.counter:06X}"),
        ("RHX:$25", f"{card.lowest:06X}"),
    ]:
        out.append(f"{stamp(t)} > {cmd}")
        out.append(f"{stamp(t)} < {'(timeout)' if card.tripped else reply}")
        t += 0.001


def session(path, seed, cpu, comment, body):
    """A log that starts with `$$$` at 10:00:00, then whatever `body(card, out, t)` adds."""
    random.seed(seed)
    card, t = Card(cpu=cpu), 36000.0
    out = ["# SYNTHETIC host log (specs/captures/synthetic.py): " + comment[0]] + ["# " + c for c in comment[1:]]
    out += [f"{stamp(t)} > $$$", f"{stamp(t)} <"]
    body(card, out, t)
    open(path, "w").write("\n".join(out) + "\n")


def healthy(card, out, t, polls=120):
    for _ in range(polls):
        t += 0.5
        card.run(POLL_CYCLES)
        poll(out, card, t)


def starvation(card, out, t):
    for _ in range(6):
        t += 0.5
        card.run(POLL_CYCLES)
        poll(out, card, t)
    out += [f"{stamp(t + 0.1)} > ENABLE PLC 0", f"{stamp(t + 0.1)} <"]
    for _ in range(6):
        t += 0.5
        card.run(POLL_CYCLES, starved=True)
        poll(out, card, t)


def recovery(card, out, t):
    for _ in range(4):
        t += 0.5
        card.run(POLL_CYCLES)
        poll(out, card, t)
    card.tripped = True
    for _ in range(3):
        t += 0.5
        poll(out, card, t)
    card.restart()
    t += 0.5
    card.run(700)  # INIT/ pressed 700 servo cycles before the next poll
    poll(out, card, t)
    for _ in range(3):
        t += 0.5
        card.run(POLL_CYCLES)
        poll(out, card, t)


def spread(card, out, t, seconds=2):
    """`???` every 0.1 s, X:$0 once a second: the commands between two reads are spread over
    the second, and bit 12 flips between polls 0.1 s apart."""
    for i in range(seconds * 10):
        t += 0.1
        card.run(225)
        if i % 10 == 0:
            out += [f"{stamp(t)} > RHX:$0", f"{stamp(t)} < {card.x0:06X}"]
        out += [f"{stamp(t)} > ???", f"{stamp(t)} < {card.status()}"]


def impossible(card, out, t):
    for i in range(6):
        t += 0.5
        card.run(POLL_CYCLES)
        if i == 4:
            card.lowest += 5
        poll(out, card, t)


if __name__ == "__main__":
    session("healthy-dsp56321.log", 1, 3, [
        "a healthy Geo Brick with a DSP56321,",
        "polled every 0.5 s after `$$$`. replay: explained; CPU type read from bits 21 of ???."], healthy)
    session("starvation-trip.log", 2, 0, [
        "PLC 0 is enabled and takes more than",
        "an RTI period; the background stops, Y:$25 runs down, and the card falls silent.",
        "replay: explained, with the diagnosis."], starvation)
    session("recovery-by-init.log", 3, 0, [
        "a card that fell silent and came back",
        "after INIT/ at the front panel; the host sees only X:$0 start again from a small value.",
        "replay: explained; the explanation names the trip and the reset between the polls."], recovery)
    session("status-10hz-x0-each-second.log", 5, 0, [
        "`???` at 10 Hz, X:$0 read once a",
        "second: bit 12 flips between polls 0.1 s apart. replay: explained once every exchange is",
        "placed at its own host time (at the reads' instants it is not)."], spread)
    session("x25-rising.log", 4, 0, [
        "X:$25, the lowest value of the",
        "watchdog counter since reset (SRM p.57), goes up from one poll to the next with no reset",
        "in between. replay: no correct card explains it, under any reading."], impossible)

#!/usr/bin/env python3
"""A small Turbo PMAC simulator, in the shape a simulator author writes one (Diamond's SimPMAC:
a dict of variables, a loop answering lines), for `pmacwd probe` to test (cli/tests/probe.rs).

Written from the manuals, not from the emulator: the Ethernet protocol of port 1025 as
docs/emulator.md gives it (an 8-byte header, VR_DOWNLOAD 0x40 with VR_PMAC_GETRESPONSE 0xBF
and the line; the answer framed as I3 = 2 (SRM p.37-38) and I6 = 1 (PMAC2 SRM p.25) say), and
the watchdog registers of specs/variables.yaml.

    python3 sim.py [--port N] [--faults x25,i41,ranges] [--ranges error|modulo]

Prints `listening on 127.0.0.1:PORT` once ready. As written first it has the faults a first
version usually has, each marked `FAULT` below: X:$25 follows Y:$25 instead of holding its
minimum (x25), I41 locks nothing (i41), and an I-variable takes any value written (ranges).
`--faults` keeps only those named (`--faults ""`: none, the mended simulator; docs/probe.md).
`--ranges modulo` (without the `ranges` fault) takes UM p.243's reading of an out-of-range
assignment, rolled over into the range without an error, instead of ERR003.
"""

import argparse
import socket
import sys
import threading
import time

VR_DOWNLOAD = 0x40
VR_PMAC_GETRESPONSE = 0xBF
VR_PMAC_FLUSH = 0xB3
ACK, BEL, CR = b"\x06", b"\x07", b"\r"

# SRM p.43: I10 is the servo interrupt time in 1/8,388,608 ms; 3713707 is about 2.26 kHz.
I10 = 3713707
SERVO_HZ = 8_388_608_000 / I10
# Servo cycles between two ends of the background cycle: the watchdog counter Y:$25 counts
# down each servo cycle and a background cycle reloads it (SRM p.57, UM p.215).
BACKGROUND_CYCLES = 3

# What the card holds after power-up and `$$$` (the values "saved"): I3 = 2 (SRM p.37) and
# I6 = 1 (PMAC2 SRM p.25), ACK-ended lines and error numbers, what host drivers set; the
# defaults I8 = 2 (SRM p.42), I40 = 0 and I41 = 0 (SRM p.57).
SAVED = {3: 2, 6: 1, 8: 2, 10: I10, 40: 0, 41: 0}
# The firmware defaults `$$$***` puts in use (UM p.243): I3's is 1 (SRM p.37); this simulator
# keeps its framing (I3 = 2) so that a host driver goes on reading it.
FACTORY = {3: 2, 6: 1, 8: 2, 10: I10, 40: 0, 41: 0}
# The ranges of the variables with one (SRM p.37, PMAC2 SRM p.25, SRM p.42, SRM p.57); the
# others take any integer.
RANGES = {3: (0, 3), 6: (0, 3), 8: (0, 255), 40: (0, 65535), 41: (0, 15)}
# SRM p.57: I41's four bits and the I-variable ranges each one locks.
LOCKS = [(1, 100, 4899), (2, 5100, 6699), (4, 6800, 7999), (8, 8000, 8191)]


class Card:
    def __init__(self, faults, ranges="error"):
        self.faults = faults
        self.ranges = ranges
        self.lock = threading.Lock()
        self.ivars = dict(SAVED)
        self.reset()

    def reset(self, values=None):
        self.ivars = dict(values or SAVED)
        self.t0 = time.monotonic()
        self.seen = 0  # servo cycles accounted for since t0
        self.reload = self.reload_value()
        self.y25 = self.reload
        self.x25 = self.reload

    def reload_value(self):
        # UM p.215: I40 = 0 counts 4096 servo cycles.
        return self.ivars[40] or 4096

    def cycles(self):
        return int((time.monotonic() - self.t0) * SERVO_HZ)

    def advance(self):
        """Runs the servo cycles up to now: Y:$25 down one each, reloaded at each end of a
        background cycle; X:$25 the lowest it reached."""
        now = self.cycles()
        c = self.seen
        while c < now:
            if now - c > 4 * BACKGROUND_CYCLES and self.reload == self.reload_value():
                # Steady: a whole sawtooth passes, and its lowest point.
                c = now - now % BACKGROUND_CYCLES
                self.y25 = self.reload
                self.x25 = min(self.x25, self.reload - (BACKGROUND_CYCLES - 1))
                continue
            c += 1
            if c % BACKGROUND_CYCLES == 0:
                self.reload = self.reload_value()
                self.y25 = self.reload
            else:
                self.y25 -= 1
            self.x25 = min(self.x25, self.y25)
        self.seen = now

    def x0(self):
        # The servo cycle counter (M-FILE M100->X:$000000,0,24,U), from the last reset.
        return self.cycles() & 0xFFFFFF

    def status(self):
        # SRM p.289: the global status words; nothing of this card is in error.
        return 0, 0

    def read_hex(self, addr):
        self.advance()
        if addr == "X:$0":
            return self.x0()
        if addr == "Y:$25":
            return self.y25 & 0xFFFFFF
        if addr == "X:$25":
            # FAULT (x25): the counter as it is, not its lowest value (UM p.240).
            return (self.y25 if "x25" in self.faults else self.x25) & 0xFFFFFF
        if addr == "X:$6":
            return self.status()[0]
        if addr == "Y:$6":
            return self.status()[1]
        if addr == "X:$1080":
            return 0x3A7F21  # the running checksum: this card's own
        if addr == "X:$1090":
            return 0x001234
        return 0

    def write_i(self, n, value):
        """None if the write is refused (ERR003), else True."""
        # FAULT (ranges): any value is taken.
        lo, hi = RANGES.get(n, (-(2**47), 2**47 - 1))
        if "ranges" not in self.faults and not lo <= value <= hi:
            if self.ranges == "modulo":
                # UM p.243 ("Limited Range"): no error, the value rolled over into the range by
                # modulo arithmetic (I3=5 gives 1 of 0..3).
                value = lo + (value - lo) % (hi - lo + 1)
            else:
                # Refused, nothing changed: the model's reading of the ranges (SRM p.42,
                # p.57), the default of the reading out_of_range_assignment (docs/probe.md).
                return None
        # FAULT (i41): I41 locks nothing.
        locked = any(self.ivars[41] & bit and first <= n <= last for bit, first, last in LOCKS)
        if "i41" not in self.faults and locked:
            return True  # SRM p.57: ignored, and no error
        self.advance()
        self.ivars[n] = value
        return True

    def command(self, word):
        """The answer to one command: bytes of data, b"" for none, or None for ERR003."""
        w = word.upper()
        if w == "???":
            x, y = self.status()
            return b"%06X%06X" % (x, y)
        if w[:2] == "RH" and w[2:3] in ("X", "Y") and w[3:5] == ":$":
            try:
                address = int(w[5:], 16)
            except ValueError:
                return None
            return b"%06X" % self.read_hex("%s:$%X" % (w[2], address))
        if w == "$$$":
            # UM p.243: the saved values back in use; the counters start over (UM p.240).
            self.reset(SAVED)
            return b""
        if w == "$$$***":
            self.reset(FACTORY)
            return b""
        if w == "CHECKSUM" or w == "CHKS":
            return b"00C0FFEE"
        if w.startswith("#") and w.endswith("?") and w[1:-1].isdigit():
            return b"000000000000"  # every motor killed: bit 19, amplifier enabled, clear (SRM p.282)
        if w.startswith("#") and w.endswith("K") and w[1:-1].isdigit():
            return b""
        if w.startswith("I"):
            name, eq, value = w[1:].partition("=")
            if not name.isdigit() or int(name) > 8191:
                return None  # Turbo PMAC has I0..I8191
            n = int(name)
            if not eq:
                self.advance()
                return str(self.ivars.get(n, 0)).encode()
            try:
                v = int(value)
            except ValueError:
                return None
            return b"" if self.write_i(n, v) else None
        return None

    def line(self, text):
        out = b""
        with self.lock:
            for word in text.split():
                answer = self.command(word)
                if answer is None:
                    return out + BEL + b"ERR003" + CR
                if answer:
                    out += answer + CR
        return out + ACK


def serve(conn, card):
    with conn:
        while True:
            head = b""
            while len(head) < 8:
                chunk = conn.recv(8 - len(head))
                if not chunk:
                    return
                head += chunk
            request_type, request, length = head[0], head[1], int.from_bytes(head[6:8], "big")
            data = b""
            while len(data) < length:
                chunk = conn.recv(length - len(data))
                if not chunk:
                    return
                data += chunk
            if request_type == VR_DOWNLOAD and request == VR_PMAC_GETRESPONSE:
                conn.sendall(card.line(data.decode("ascii", "replace").strip("\r\n\0")))
            elif request_type == VR_DOWNLOAD and request == VR_PMAC_FLUSH:
                conn.sendall(b"\x40")
            else:
                return


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--port", type=int, default=1025)
    p.add_argument("--faults", default="x25,i41,ranges")
    p.add_argument("--ranges", choices=["error", "modulo"], default="error")
    a = p.parse_args()
    card = Card(set(f for f in a.faults.split(",") if f), a.ranges)
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    listener.bind(("127.0.0.1", a.port))
    listener.listen(4)
    print("listening on 127.0.0.1:%d" % listener.getsockname()[1], flush=True)
    while True:
        conn, _ = listener.accept()
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        threading.Thread(target=serve, args=(conn, card), daemon=True).start()


if __name__ == "__main__":
    sys.exit(main())

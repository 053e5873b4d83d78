#!/usr/bin/env python3
"""The host side of `emulator-session.pcap`: polls `pmacwd serve` on 127.0.0.1:1025 as the
pmac driver and dls-pmaclib do (a FLUSH, then a GETRESPONSE with the command line), starves the
card's background through the control port so that it trips and falls silent, and brings it back
with INIT/. Run it while `pmacwd serve --configuration host-log` and
`tcpdump -i lo -w emulator-session.pcap --time-stamp-precision=micro 'tcp port 1025'` run
(README.md in this folder)."""
import socket, struct, subprocess, time

def request(sock, code, rtype=0x40, data=b"", length=None):
    n = len(data) if length is None else length
    sock.sendall(struct.pack(">BBHHH", rtype, code, 0, 0, n) + data)

def answer(sock, timeout=0.5):
    """The card's bytes up to its ACK or an error's CR; what came if it falls silent."""
    sock.settimeout(timeout)
    got = b""
    try:
        while True:
            b = sock.recv(1)
            if not b:
                break
            got += b
            if b == b"\x06" or (b == b"\r" and b"\x07" in got):
                break
    except socket.timeout:
        pass
    return got

def line(sock, text):
    request(sock, 0xB3)  # FLUSH: answered with CTRL-X
    answer(sock, 0.2)
    request(sock, 0xBF, data=text.encode() + b"\r")
    return answer(sock)

def control(*cmds):
    subprocess.run(["pmacwd", "control", *cmds], check=True, stdout=subprocess.DEVNULL)

s = socket.create_connection(("127.0.0.1", 1025))
for cmd in ["I8", "I10", "I40", "I41", "cid", "ver", "cpu"]:
    line(s, cmd)
line(s, "I130=5 I131=2")
for i in range(12):
    line(s, "RHX:$0 ??? RHY:$25 RHX:$25")
    line(s, "#1P #2P")
    time.sleep(0.1)
control("starve")
for i in range(20):
    line(s, "RHX:$0 ??? RHY:$25 RHX:$25")
    time.sleep(0.1)
control("init")
time.sleep(0.2)
for i in range(8):
    line(s, "RHX:$0 ??? RHY:$25 RHX:$25")
    time.sleep(0.1)
s.close()

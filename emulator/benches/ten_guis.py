"""Ten dls-pmaccontrol-like clients polling `pmacwd serve` at 10 Hz for 10 s: the server's CPU
time (user + system from /proc/PID/stat, Linux) as a share of one core. The clients run in
this process, so their own cost is not counted. Each sends the GUI's 52-value poll line
(dls_pmac_control/commsThread.py) and checks that 52 values come back.

    python3 emulator/benches/ten_guis.py target/release/pmacwd
"""
import os, re, socket, struct, subprocess, sys, threading, time
pm = sys.argv[1]
p = subprocess.Popen([pm, "serve", "--listen", "127.0.0.1:0", "--no-control"], stdout=subprocess.PIPE, text=True)
port = int(re.findall(r"127\.0\.0\.1:(\d+)", p.stdout.readline())[0])
line = "i65???&1??%" + "".join(f"#{m}?PVF m{m}90 p99" for m in range(1, 9))
req = struct.pack("8B", 0x40, 0xBF, 0, 0, 0, 0, 0, len(line)) + line.encode()
def cpu():
    f = open(f"/proc/{p.pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")
counts = []
def gui():
    s = socket.create_connection(("127.0.0.1", port)); s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    start = time.monotonic(); n = 0
    while time.monotonic() - start < 10:
        s.sendall(req); r = b""
        while not r.endswith(b"\x06"): r += s.recv(4096)
        assert r.count(b"\r") == 52
        n += 1
        time.sleep(max(0, start + n * 0.1 - time.monotonic()))
    counts.append(n)
time.sleep(0.5)
c0 = cpu(); t0 = time.monotonic()
ts = [threading.Thread(target=gui) for _ in range(10)]
[t.start() for t in ts]; [t.join() for t in ts]
c1 = cpu(); t1 = time.monotonic()
print(f"pmacwd serve, 10 clients x poll line at 10 Hz: {sum(counts)} polls in {t1-t0:.1f} s, server CPU {c1-c0:.2f} s = {100*(c1-c0)/(t1-t0):.2f}% of one core")
p.terminate()

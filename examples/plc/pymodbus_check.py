"""Drives `gonio simulate station` through the registers of docs/plc-interface.md with
pymodbus, a Modbus stack gonio did not write. Usage: pymodbus_check.py HOST PORT.
Prints one line per check; exits 1 on the first failure."""
import sys
import time

from pymodbus.client import ModbusTcpClient

HOST, PORT = sys.argv[1], int(sys.argv[2])
UNIT = 1
# Holding registers (written by the client)
H_COMMAND, H_SEQUENCE, H_ARG0, H_ARG1, H_HEARTBEAT = 0, 1, 2, 4, 6
# Input registers (written by the PLC)
I_STATUS, STATUS_REGS, LATCH_RING, LATCH_LEN = 0, 22, 100, 128
BUSY, DONE, FAULT, ESTOP, WATCHDOG, PART_PRESENT, TRIGGERING = 1, 2, 4, 8, 16, 32, 64
MOVE_SERVO, MOVE_FOCUS, RESET_FAULT, TRIGGER = 1, 4, 9, 11


def fail(msg):
    print("FAIL", msg)
    sys.exit(1)


def u32(w):
    return (w[0] << 16) | w[1]


def i32(w):
    v = u32(w)
    return v - (1 << 32) if v >= 1 << 31 else v


def u64(w):
    return (w[0] << 48) | (w[1] << 32) | (w[2] << 16) | w[3]


def words(v):
    v &= 0xFFFFFFFF
    return [v >> 16, v & 0xFFFF]


c = ModbusTcpClient(HOST, port=PORT, timeout=2)
if not c.connect():
    fail(f"cannot connect to {HOST}:{PORT}")
beat = 0


def status():
    global beat
    beat = (beat + 1) & 0xFFFF
    c.write_register(H_HEARTBEAT, beat, device_id=UNIT)
    r = c.read_input_registers(I_STATUS, count=STATUS_REGS, device_id=UNIT)
    if r.isError():
        fail(f"read status: {r}")
    w = r.registers
    return {
        "word": w[0], "ack": w[1], "fault": w[2], "heartbeat": w[3],
        "time_s": u64(w[4:8]) * 1e-6, "angle_deg": i32(w[8:10]) / 10000.0,
        "focus_um": i32(w[10:12]) / 1000.0, "rod_um": i32(w[12:14]) / 1000.0,
        "trigger_count": u32(w[14:16]), "part": u32(w[16:18]),
    }


seq = status()["ack"]


def command(cmd, arg0=0, arg1=0, timeout_s=5.0):
    global seq, beat
    seq = (seq + 1) & 0xFFFF or 1
    beat = (beat + 1) & 0xFFFF
    r = c.write_registers(H_COMMAND, [cmd, seq] + words(arg0) + words(arg1) + [beat], device_id=UNIT)
    if r.isError():
        fail(f"write command {cmd}: {r}")
    t0 = time.time()
    while time.time() - t0 < timeout_s:
        s = status()
        if s["word"] & FAULT:
            fail(f"command {cmd}: fault {s['fault']}")
        if s["ack"] == seq and s["word"] & DONE and not s["word"] & BUSY:
            return s
        time.sleep(0.01)
    fail(f"command {cmd} not done in {timeout_s} s")


s = status()
if not (s["word"] & PART_PRESENT and s["part"] == 1):
    fail(f"part 1 present expected: {s}")
print(f"ok status: part {s['part']} present, PLC time {s['time_s']:.3f} s")
h0 = s["heartbeat"]
time.sleep(0.1)
if status()["heartbeat"] == h0:
    fail("the PLC's heartbeat does not move")
print("ok heartbeat moves")
command(RESET_FAULT)
s = command(MOVE_FOCUS, 12345)  # 12.345 µm in nm
if abs(s["focus_um"] - 12.345) > 1e-9:
    fail(f"focus at {s['focus_um']} µm, 12.345 commanded")
print(f"ok focus moved to {s['focus_um']:.3f} µm")
s = command(MOVE_SERVO, 1234567)  # 123.4567°
if abs(s["angle_deg"] - 123.4567) > 1e-9:
    fail(f"servo at {s['angle_deg']}°, 123.4567 commanded")
print(f"ok servo moved to {s['angle_deg']:.4f}°")
command(TRIGGER, 100000)  # 100 fps
time.sleep(0.3)
s = status()
n = s["trigger_count"]
if not (15 <= n <= 60):
    fail(f"{n} triggers in 0.3 s at 100 fps")
r = c.read_input_registers(LATCH_RING, count=8 * 10, device_id=UNIT)
if r.isError():
    fail(f"read latch ring: {r}")
w = r.registers
prev_t = None
for k in range(10):
    e = w[8 * k: 8 * k + 8]
    count, t_us, ang = u32(e[0:2]), u64(e[2:6]), i32(e[6:8]) / 10000.0
    if count != k + 1:
        fail(f"latch entry {k} holds trigger {count}")
    if abs(ang - 123.4567) > 1e-9:
        fail(f"latched angle {ang}° with the servo standing at 123.4567°")
    if prev_t is not None and abs((t_us - prev_t) - 10000) > 2:
        fail(f"latches {t_us - prev_t} µs apart at 100 fps")
    prev_t = t_us
print(f"ok {n} triggers latched, 10 ms apart, at 123.4567°")
command(TRIGGER, 0)
# The watchdog: no heartbeat for 2.5 s latches fault 1.
time.sleep(2.5)
r = c.read_input_registers(I_STATUS, count=STATUS_REGS, device_id=UNIT)
w = r.registers
if not (w[0] & WATCHDOG and w[0] & FAULT and w[2] == 1):
    fail(f"watchdog expected after 2.5 s of silence: word {w[0]:#x}, fault {w[2]}")
print("ok watchdog latched after 2.5 s without a heartbeat")
command(RESET_FAULT)
if status()["word"] & FAULT:
    fail("reset fault did not clear the fault")
print("ok fault reset")
c.close()
print("all checks passed")

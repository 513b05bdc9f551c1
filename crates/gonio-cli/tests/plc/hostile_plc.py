"""A hostile PLC for gonio's device tests, on pymodbus (a Modbus stack gonio did not write).

Serves the registers of docs/plc-interface.md with the default map (holding 0-6: command,
sequence, arg0, arg1, heartbeat; input 0-21: the status block) with part 1 present and the
PLC's heartbeat running, acknowledges every command, and misbehaves as asked:

  --stuck-on CMD   from the first command CMD on, every command is acknowledged and stays busy
  --slow CMD=S     command CMD is done S seconds after it was taken (the others at once)
  --simulated      sets the status word's simulated bit (bit 7), as `gonio simulate station`

Prints "hostile PLC on HOST:PORT" once it listens (port 0: any free port), then one line per
command taken: "command CMD seq SEQ arg0 A t_s T". Runs until killed.
Usage: hostile_plc.py [--port P] [--stuck-on CMD] [--slow CMD=S]... [--simulated]
"""
import argparse
import asyncio
import math
import sys
import time

from pymodbus.server import ModbusTcpServer
from pymodbus.simulator import DataType, SimData, SimDevice

BUSY, DONE, PART_PRESENT, TRIGGERING, SIMULATED = 1, 2, 32, 64, 128
H_COMMAND, H_SEQUENCE, H_ARG0 = 0, 1, 2
TRIGGER = 11

p = argparse.ArgumentParser()
p.add_argument("--port", type=int, default=0)
p.add_argument("--stuck-on", type=int, default=None)
p.add_argument("--slow", action="append", default=[])
p.add_argument("--simulated", action="store_true")
args = p.parse_args()
slow = {int(k): float(v) for k, v in (s.split("=") for s in args.slow)}

T0 = time.monotonic()
state = {"seq": 0, "ack": 0, "done_at": 0.0, "stuck": False, "fps": 0, "part": 1}


def now():
    return time.monotonic() - T0


def words32(v):
    v &= 0xFFFFFFFF
    return [v >> 16, v & 0xFFFF]


def take(cmd, seq, arg0):
    t = now()
    state["seq"] = seq
    state["ack"] = seq
    if state["stuck"] or cmd == args.stuck_on:
        state["stuck"] = True
        state["done_at"] = math.inf
    else:
        state["done_at"] = t + slow.get(cmd, 0.0)
    if cmd == TRIGGER:
        state["fps"] = arg0
    print(f"command {cmd} seq {seq} arg0 {arg0} t_s {t:.3f}", flush=True)


async def action(fc, start, address, count, registers, values):
    if fc in (6, 16) and values is not None:
        # The registers after this write (holding block, from address 0).
        regs = list(registers)
        for i, v in enumerate(values):
            regs[address - start + i] = int(v)
        first, last = address, address + len(values) - 1
        if first <= H_SEQUENCE <= last and regs[H_SEQUENCE] != state["seq"]:
            arg0 = (regs[H_ARG0] << 16) | regs[H_ARG0 + 1]
            if arg0 >= 1 << 31:
                arg0 -= 1 << 32
            take(regs[H_COMMAND], regs[H_SEQUENCE], arg0)
    elif fc == 4:
        t = now()
        busy = t < state["done_at"]
        word = PART_PRESENT
        word |= BUSY if busy else DONE
        if state["fps"] > 0:
            word |= TRIGGERING
        if args.simulated:
            word |= SIMULATED
        us = int(t * 1e6)
        status = [word, state["ack"], 0, int(t * 100) & 0xFFFF]
        status += [(us >> 48) & 0xFFFF, (us >> 32) & 0xFFFF, (us >> 16) & 0xFFFF, us & 0xFFFF]
        status += [0, 0] * 4  # servo angle, focus, rod, trigger count
        status += words32(state["part"])  # part number
        status += [0, 0, 0, 0]  # sample count, servo speed
        registers[0:22] = status
    return None


async def main():
    device = SimDevice(
        id=0,
        simdata=(
            [SimData(0, values=False, datatype=DataType.BITS)],
            [SimData(0, values=False, datatype=DataType.BITS)],
            [SimData(0, count=16, values=0, datatype=DataType.REGISTERS)],
            [SimData(0, count=22, values=0, datatype=DataType.REGISTERS)],
        ),
        action=action,
    )
    server = ModbusTcpServer(device, address=("127.0.0.1", args.port))
    await server.serve_forever(background=True)
    host, port = server.transport.sockets[0].getsockname()[:2]
    print(f"hostile PLC on {host}:{port}", flush=True)
    await server.serving


try:
    asyncio.run(main())
except KeyboardInterrupt:
    sys.exit(0)

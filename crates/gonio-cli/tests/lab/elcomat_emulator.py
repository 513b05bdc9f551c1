#!/usr/bin/env python3
"""An ELCOMAT-type autocollimator emulated on a pseudo-terminal, independent of gonio.

Opens a pty pair (the `pty` module), prints the slave's path on the first line of standard
output, and answers every request line (`a` or `r` ended by CR LF) with the next line of the
answers file, ended by CR, as the instrument does. Lines of the answers file:

    4 003 +1.234 -0.210     sent as is (any text: good readings, other status codes)
    RAW:0a0d41ff            these bytes (hex) and a CR: garbage on the line
    SILENT                  no answer to this request
    HANGUP                  close the pty: the adapter is pulled

After the last line the instrument is silent. The emulator ends after --max-s seconds, on
HANGUP, or when its standard input closes (the test that started it has gone).

    elcomat_emulator.py --answers FILE [--skip N] [--max-s S] [--transcript FILE]
"""

import argparse
import os
import pty
import select
import sys
import threading
import time
import tty


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--answers", required=True)
    ap.add_argument("--skip", type=int, default=0, help="start at this answer (0-based)")
    ap.add_argument("--max-s", type=float, default=120.0)
    ap.add_argument("--transcript")
    a = ap.parse_args()
    with open(a.answers, encoding="utf-8") as f:
        answers = [line.rstrip("\n") for line in f][a.skip:]
    master, slave = pty.openpty()
    tty.setraw(slave)
    print(os.ttyname(slave), flush=True)
    stop = threading.Event()

    def watch_stdin():
        sys.stdin.read()
        stop.set()

    threading.Thread(target=watch_stdin, daemon=True).start()
    transcript = open(a.transcript, "a", encoding="utf-8") if a.transcript else None
    end = time.monotonic() + a.max_s
    pending = b""
    sent = 0
    while not stop.is_set() and time.monotonic() < end:
        r, _, _ = select.select([master], [], [], 0.1)
        if not r:
            continue
        try:
            got = os.read(master, 256)
        except OSError:
            continue
        pending += got
        while b"\n" in pending:
            request, pending = pending.split(b"\n", 1)
            request = request.rstrip(b"\r")
            if request not in (b"a", b"r"):
                continue
            answer = answers.pop(0) if answers else "SILENT"
            if transcript:
                transcript.write(f"{request.decode()} -> {answer}\n")
                transcript.flush()
            if answer == "SILENT":
                continue
            if answer == "HANGUP":
                os.close(master)
                os.close(slave)
                return
            if answer.startswith("RAW:"):
                data = bytes.fromhex(answer[4:])
            else:
                data = answer.encode()
            os.write(master, data + b"\r")
            sent += 1
    print(f"sent {sent}", file=sys.stderr)


if __name__ == "__main__":
    main()

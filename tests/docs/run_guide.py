#!/usr/bin/env python3
"""docs.getting_started: runs every command of docs/getting-started.md against the emulated
robot, in the guide's order, from an empty folder with only the installed scaratwin on the PATH.

  run_guide.py GUIDE PREFIX WORK_DIR [--long]

PREFIX is an installed scaratwin (`cmake --install ... --prefix PREFIX`; the test installs this
build there first). The guide's fenced blocks say how each is run (the word after `sh`):

  guide        run, each line in one bash session (`set -euo pipefail`), so exports carry on
  guide-start  a program the reader leaves running in a terminal of its own: started in the
               background, and the next block waits for it to say it is ready
  guide-board  needs the physical board: not run; each file of the installed data folder it
               names must exist, and a firmware image it flashes must be Intel HEX that fits
               the ATmega328P's application flash (32 KiB less the 512 B bootloader)
  guide-long   runs only with --long (minutes: the calibration); without it, listed as not run
  guide-setup  the install: done by the test itself before the guide runs (this build into
               PREFIX with `cmake --install`), so not run again

The guide's paths in /usr/share/scaratwin are read as PREFIX/share/scaratwin, and the
simulator serves its page on a free port instead of 8080 (`scaratwin sim` gets --http-port). A block with no recognised word fails the test, so
a command cannot slip into the guide untested.
"""
import os
import re
import shlex
import socket
import subprocess
import sys
import time

guide, prefix, work = sys.argv[1:4]
long_mode = "--long" in sys.argv[4:]
data = os.path.join(prefix, "share", "scaratwin")
KINDS = {"guide", "guide-start", "guide-board", "guide-long", "guide-setup"}
READY = {"scaratwin robot": "pty: ", "scaratwin sim": "listening on",
         "scaratwin hub": "its port's statements at"}


def fail(msg):
    sys.exit(f"docs.getting_started: {msg}")


def blocks(text):
    out = []
    for m in re.finditer(r"^```([^\n]*)\n(.*?)^```", text, re.S | re.M):
        info = m.group(1).split()
        lineno = text.count("\n", 0, m.start()) + 1
        out.append((info, m.group(2), lineno))
    return out


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


with open(guide, encoding="utf-8") as f:
    text = f.read()
port = free_port()
desk = os.path.join(work, "desk")
home = os.path.join(work, "home")
subprocess.run(["rm", "-rf", desk, home], check=True)
os.makedirs(desk)
os.makedirs(home)
env = {"PATH": os.path.join(prefix, "bin") + ":/usr/bin:/bin", "HOME": home,
       "LANG": "C.UTF-8"}
for k in ("ASAN_OPTIONS", "UBSAN_OPTIONS", "LSAN_OPTIONS"):
    if k in os.environ:
        env[k] = os.environ[k]


def localise(cmd):
    cmd = cmd.replace("/usr/share/scaratwin", data)
    if cmd == "scaratwin sim" or cmd.startswith("scaratwin sim "):
        cmd += f" --http-port {port}"
    return cmd


def check_board_block(body, lineno):
    for line in body.splitlines():
        for word in shlex.split(line, comments=True):
            for path in re.findall(r"/usr/share/scaratwin/[^\s:]+", word):
                local = localise(path)
                if not os.path.isfile(local):
                    fail(f"line {lineno}: {path} is not installed ({local})")
                if local.endswith(".hex"):
                    check_hex(local, lineno)
                print(f"  (board) {path}: installed")


def check_hex(path, lineno):
    top = 0
    with open(path, encoding="ascii") as f:
        for n, rec in enumerate(f, 1):
            rec = rec.strip()
            if not rec.startswith(":"):
                fail(f"{path}:{n}: not an Intel HEX record")
            raw = bytes.fromhex(rec[1:])
            if sum(raw) & 0xFF:
                fail(f"{path}:{n}: checksum error")
            if raw[3] == 0:
                top = max(top, (raw[1] << 8 | raw[2]) + raw[0])
    if not 0 < top <= 32768 - 512:
        fail(f"line {lineno}: {path} ends at {top} B, beyond the Uno's 32,256 B")
    print(f"  (board) {os.path.basename(path)}: Intel HEX, {top} B of 32,256 B")


script = ["set -euo pipefail", f"cd {shlex.quote(desk)}"]
started = []
count = 0
for info, body, lineno in blocks(text):
    if not info or info[0] not in ("sh", "bash", "console"):
        continue
    kind = info[1] if len(info) > 1 else ""
    if kind not in KINDS:
        fail(f"line {lineno}: a shell block without its test word (one of {sorted(KINDS)})")
    if kind == "guide-board":
        check_board_block(body, lineno)
        count += 1
        continue
    if kind == "guide-setup":
        print(f"  done by the test (installed to {prefix}): {body.strip()}")
        continue
    if kind == "guide-long" and not long_mode:
        print(f"  not run (long; run_guide.py --long): {body.strip()}")
        continue
    for line in body.splitlines():
        cmd = line.split(" #")[0].strip()
        if not cmd or cmd.startswith("#"):
            continue
        cmd = localise(cmd)
        count += 1
        if kind == "guide-start":
            name = next((k for k in READY if cmd.startswith(k)), None)
            if name is None:
                fail(f"line {lineno}: no readiness line known for `{cmd}`")
            log = os.path.join(work, f"started{len(started)}.log")
            started.append(log)
            script.append(f"echo {shlex.quote('$ ' + cmd + ' &')}")
            script.append(f"{cmd} >{shlex.quote(log)} 2>&1 &")
            script.append(f"pids+=($!)")
            script.append(
                f"for i in $(seq 600); do grep -q {shlex.quote(READY[name])} {shlex.quote(log)}"
                f" && break; kill -0 $! || {{ cat {shlex.quote(log)}; exit 1; }}; sleep 0.1; done")
            script.append(f"grep -q {shlex.quote(READY[name])} {shlex.quote(log)}")
        else:
            script.append(f"echo {shlex.quote('$ ' + cmd)}")
            script.append(cmd)
script.insert(1, "pids=(); trap 'kill ${pids[@]} 2>/dev/null; wait' EXIT")
script_path = os.path.join(work, "guide.sh")
with open(script_path, "w", encoding="utf-8") as f:
    f.write("\n".join(script) + "\n")
print(f"{count} commands from {guide}; script {script_path}")
t0 = time.monotonic()
rc = subprocess.run(["bash", script_path], env=env).returncode
for log in started:
    with open(log, encoding="utf-8", errors="replace") as f:
        tail = f.read()[-1500:]
    print(f"--- {log} (tail)\n{tail}")
if rc != 0:
    fail(f"a command of the guide failed (exit status {rc}); see above")
print(f"the guide ran in {time.monotonic() - t0:.0f} s")

#!/usr/bin/env python3
"""docs.wiring_svg: the wiring drawing in docs/ is the one the firmware's pin table gives, and
the pin table fits the CNC shield v3 it is drawn on.

  check_wiring.py GENERATOR board.h docs/wiring.svg WORK_DIR

1. regenerates the drawing from board.h and compares it byte for byte with the committed one
   (regenerate with: python3 firmware/tools/wiring_svg.py firmware/src/board.h docs/wiring.svg);
2. checks each signal's row against two facts that do not come from the generator: the
   ATmega328P -> Arduino Uno pin map (the Uno's schematic) and the shield's hard-wired driver
   and endstop sockets (the robot puts Z in socket X, J2 in Y, J3 in Z; board.h's header).
"""
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

generator, board_h, committed, work = sys.argv[1:5]
os.makedirs(work, exist_ok=True)
fresh = os.path.join(work, "wiring.svg")
subprocess.run([sys.executable, generator, board_h, fresh], check=True)
with open(fresh, encoding="utf-8") as f:
    fresh_text = f.read()
with open(committed, encoding="utf-8") as f:
    committed_text = f.read()
if fresh_text != committed_text:
    sys.exit(f"{committed} is not what {board_h} gives (see {fresh}); regenerate it: "
             f"python3 firmware/tools/wiring_svg.py firmware/src/board.h docs/wiring.svg")

# the Uno's schematic: ATmega328P port bit -> header pin
UNO = {f"PD{i}": f"D{i}" for i in range(8)}
UNO.update({f"PB{i}": f"D{8 + i}" for i in range(6)})
UNO.update({f"PC{i}": f"A{i}" for i in range(6)})
# the CNC shield v3's PCB: the sockets the robot uses
SHIELD = {"STEP_Z": "D2", "DIR_Z": "D5", "STEP_J2": "D3", "DIR_J2": "D6", "STEP_J3": "D4",
          "DIR_J3": "D7", "ENABLE": "D8", "ENDSTOP_Z": "D9", "ENDSTOP_J2": "D10",
          "ENDSTOP_J3": "D11"}
SIGNALS = set(SHIELD) | {"SERVO_GRIP", "SERVO_WRIST", "JOG_Z_POS", "JOG_Z_NEG", "JOG_J2_POS",
                         "JOG_J2_NEG", "JOG_J3_POS", "JOG_J3_NEG"}

ns = {"svg": "http://www.w3.org/2000/svg"}
root = ET.fromstring(committed_text)
rows = {}
for g in root.iter("{http://www.w3.org/2000/svg}g"):
    gid = g.get("id", "")
    if not gid.startswith("pin-"):
        continue
    texts = {t.get("class"): t.text for t in g.findall("svg:text", ns)}
    rows[gid[4:]] = texts
problems = []
if set(rows) != SIGNALS:
    problems.append(f"rows drawn: {sorted(rows)}; expected {sorted(SIGNALS)}")
used = {}
for signal, texts in sorted(rows.items()):
    pin, port = texts.get("pin"), texts.get("port")
    if UNO.get(port) != pin:
        problems.append(f"{signal}: drawn as {pin} ({port}); the Uno has {port} on {UNO.get(port)}")
    if signal in SHIELD and pin != SHIELD[signal]:
        problems.append(f"{signal}: on {pin}; the shield wires its socket to {SHIELD[signal]}")
    if pin in used:
        problems.append(f"{signal} and {used[pin]} share {pin}")
    used[pin] = signal
if problems:
    sys.exit("wiring: " + "\n  ".join(problems))
print(f"wiring: {len(rows)} signals drawn, each on its Uno pin and shield socket; "
      f"{committed} is up to date")

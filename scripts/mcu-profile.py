#!/usr/bin/env python3
"""Instruction profile of the firmware on the emulated Cortex-M4 (docs/benchmarks.md,
"Profiling the MCU code").

Reads a QEMU trace written with `-d in_asm,exec,nochain` (host-sim writes one per emulator
under `-icount` when `VT_QEMU_TRACE=PREFIX` is set: `PREFIX.bench10`, `PREFIX.perception-bench`,
...) and counts the guest instructions executed per function: every executed translation block
adds its instruction count to the function QEMU names it by. With `--window SYMBOL` only the
instructions between each entry into SYMBOL and the return to its caller count (callees and
interrupts included, as the firmware's own cycle counts include them), given per call.
`--lines N` maps the N hottest blocks to source lines (llvm-addr2line, inlining expanded).

    VT_QEMU_TRACE=/tmp/qt cargo run --release -p host-sim -- pil-bench --out /tmp/bench
    python3 scripts/mcu-profile.py /tmp/qt.bench10 firmware/target/thumbv7em-none-eabihf/release/vt-firmware-qemu \
        --window 4Core10high_level --lines 10
"""

import argparse
import collections
import shutil
import subprocess
import sys


def tool(name):
    for cand in (name, name + "-14", name + "-15", name + "-16"):
        if shutil.which(cand):
            return cand
    sys.exit(f"mcu-profile: {name} not found (apt-get install llvm)")


def entry_address(elf, symbol):
    out = subprocess.run([tool("llvm-nm"), elf], capture_output=True, text=True, check=True).stdout
    hits = [line.split() for line in out.splitlines() if symbol in line and len(line.split()) == 3]
    hits = [h for h in hits if h[1] in "tT"]
    if len(hits) != 1:
        names = ", ".join(h[2] for h in hits[:5]) or "none"
        print(f"mcu-profile: --window {symbol!r} matches {len(hits)} functions in {elf} ({names})", file=sys.stderr)
        sys.exit(2)
    return int(hits[0][0], 16) & ~1, hits[0][2]


def profile(trace, window):
    tb_len, tb_sym = {}, {}
    per_fn, per_tb = collections.Counter(), collections.Counter()
    windows, inside, caller, prev = 0, False, None, None
    cur_sym, cur_pc, n = None, None, 0
    with open(trace, errors="replace") as f:
        for line in f:
            if line.startswith("IN:"):
                cur_sym, cur_pc, n = line[3:].strip(), None, 0
            elif cur_sym is not None and line.startswith("0x"):
                if cur_pc is None:
                    cur_pc = int(line.split(":", 1)[0], 16)
                n += 1
            elif cur_sym is not None and not line.strip():
                if cur_pc is not None:
                    tb_len[cur_pc], tb_sym[cur_pc] = n, cur_sym
                cur_sym = None
            elif line.startswith("Trace"):
                # Trace <cpu>: <host ptr> [<cs_base>/<pc>/<flags>/<cflags>] <symbol>
                pc = int(line.split("[", 1)[1].split("/")[1], 16)
                sym = tb_sym.get(pc, "?")
                if window is not None:
                    entry, name = window
                    if not inside and pc == entry:
                        inside, caller, windows = True, prev, windows + 1
                    if inside and sym == caller and sym != name:
                        inside = False
                    if not inside:
                        prev = sym
                        continue
                per_fn[sym] += tb_len.get(pc, 0)
                per_tb[pc] += tb_len.get(pc, 0)
                prev = sym
    return per_fn, per_tb, windows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("trace", help="QEMU log written with -d in_asm,exec,nochain")
    ap.add_argument("elf", help="the firmware ELF the trace ran")
    ap.add_argument("--window", metavar="SYMBOL", help="count only inside calls of this function (a unique substring of its symbol)")
    ap.add_argument("--top", type=int, default=25, help="functions to list (25)")
    ap.add_argument("--lines", type=int, default=0, metavar="N", help="map the N hottest blocks to source lines")
    a = ap.parse_args()
    for path in (a.trace, a.elf):
        try:
            open(path, "rb").close()
        except OSError as e:
            print(f"mcu-profile: {path}: {e.strerror}", file=sys.stderr)
            sys.exit(2)
    window = entry_address(a.elf, a.window) if a.window else None
    per_fn, per_tb, windows = profile(a.trace, window)
    total = sum(per_fn.values())
    if total == 0:
        sys.exit(f"mcu-profile: no executed blocks in {a.trace}" + (f" inside {a.window}" if a.window else ""))
    div = max(windows, 1)
    unit = f"per call of {window[1]} ({windows} calls)" if window else "in the whole trace"
    print(f"{total / div:.0f} instructions {unit}")
    for sym, c in per_fn.most_common(a.top):
        print(f"{c / div:10.0f} {100 * c / total:5.1f} %  {sym}")
    if a.lines:
        a2l = tool("llvm-addr2line")
        print(f"\nhottest blocks ({unit}):")
        for pc, c in per_tb.most_common(a.lines):
            out = subprocess.run([a2l, "-e", a.elf, "-f", "-i", "-C", hex(pc)], capture_output=True, text=True).stdout.split("\n")
            where = " <- ".join(f"{out[i]} {out[i + 1].rsplit('/', 1)[-1]}" for i in range(0, min(len(out) - 1, 4), 2))
            print(f"{c / div:8.0f}  {pc:#x}  {where}")


if __name__ == "__main__":
    main()

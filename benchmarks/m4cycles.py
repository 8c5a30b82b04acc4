"""An ESTIMATE of Cortex-M4F cycles per step: the real -Os firmware's step run instruction by instruction
in Unicorn, each instruction charged its cycle count from the Cortex-M4 Technical Reference Manual's
tables (section 3.3, and the FPU's section 7.2).

It is a model, not a measurement: zero-wait-state memory, no flash prefetch stalls, branch refills
charged 2 cycles (the TRM gives 1-3), a load or store after another one charged 1 (pipelined) instead
of 2, hardware divides charged 7 (2-12), IT instructions 1. Real silicon with flash wait states is
slower; the figure is for comparing code, not for scheduling a flight controller.

Unicorn has no Cortex-M FPU switch, so the Thumb-2 code runs on an A-profile core with VFP enabled:
the step uses no M-profile system instructions, and the encodings of everything it uses are the same.
"""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.harness.build import run

OBJDUMP = "arm-none-eabi-objdump"
READELF = "arm-none-eabi-readelf"
_RETURN = 0x0FFF_FF00  # where the step "returns" to: the emulation stops there
_RAM, _RAM_SIZE = 0x2000_0000, 0x0010_0000
BRANCH_REFILL = 2
DIVIDE = 7
_FP_LONG = {"vdiv": 14, "vsqrt": 14}
_FP_MAC = ("vmla", "vmls", "vnmla", "vnmls", "vfma", "vfms", "vfnma", "vfnms")


@dataclass(frozen=True)
class Instruction:
    size: int
    mnemonic: str   # without condition and width suffixes, lower case
    operands: str


def available() -> bool:
    try:
        import unicorn  # noqa: F401
    except ImportError:
        return False
    return True


def disassemble(elf: Path) -> dict[int, Instruction]:
    table: dict[int, Instruction] = {}
    line = re.compile(r"^\s*([0-9a-f]+):\s+((?:[0-9a-f]{4}\s?){1,2})\s+(\S+)\s*(.*)$")
    for text in run([OBJDUMP, "-d", "-w", str(elf)]).stdout.splitlines():
        match = line.match(text)
        if match:
            halfwords = match.group(2).split()
            table[int(match.group(1), 16)] = Instruction(2 * len(halfwords), match.group(3).lower(), match.group(4))
    return table


def _base(mnemonic: str) -> str:
    """``vldr.32`` -> ``vldr``; ``addeq.w`` -> ``add`` is not attempted: conditions are charged alike."""
    return mnemonic.split(".")[0]


def _register_count(operands: str) -> int:
    braces = re.search(r"\{([^}]*)\}", operands)
    if not braces:
        return 1
    count = 0
    for part in braces.group(1).split(","):
        bounds = re.findall(r"\d+", part)
        count += int(bounds[1]) - int(bounds[0]) + 1 if "-" in part and len(bounds) == 2 else 1
    return count


def cost(ins: Instruction, previous: Instruction | None) -> int:
    """Cycles of one instruction, branch refill excluded (charged when a branch is seen taken)."""
    m = _base(ins.mnemonic)
    for name, cycles in _FP_LONG.items():
        if m.startswith(name):
            return cycles
    if m.startswith(_FP_MAC):
        return 3
    if m in ("vpush", "vpop", "vldmia", "vstmia", "vldmdb", "vstmdb", "push", "pop", "ldmia", "stmia", "ldm",
             "stm", "stmdb", "ldmdb") or m.startswith(("ldm", "stm")):
        return 1 + _register_count(ins.operands)
    if m.startswith(("sdiv", "udiv")):
        return DIVIDE
    if m.startswith(("ldr", "str", "vldr", "vstr")):
        pipelined = previous is not None and _base(previous.mnemonic).startswith(("ldr", "str", "vldr", "vstr"))
        return 1 if pipelined else 2
    if m.startswith("vmov") and ins.operands.count(",") == 2:
        return 2  # two core registers to or from the FPU
    return 1


def is_branch(ins: Instruction) -> bool:
    m = _base(ins.mnemonic)
    return (m[:1] == "b" and not m.startswith(("bic", "bfi", "bfc"))) or m.startswith(("cbz", "cbnz")) or (
        m.startswith(("pop", "ldm")) and "pc" in ins.operands) or (m.startswith("ldr") and ins.operands.startswith("pc"))


def _load(emu, elf: Path) -> None:
    from unicorn import UC_PROT_ALL

    data = elf.read_bytes()
    for text in run([READELF, "-lW", str(elf)]).stdout.splitlines():
        parts = text.split()
        if parts[:1] == ["LOAD"]:
            offset, vaddr, filesz, memsz = (int(parts[i], 16) for i in (1, 2, 4, 5))
            start, end = vaddr & ~0xFFF, (vaddr + memsz + 0xFFF) & ~0xFFF
            try:
                emu.mem_map(start, end - start, UC_PROT_ALL)
            except Exception:  # noqa: BLE001 - a page shared with the previous segment is already mapped
                pass
            emu.mem_write(vaddr, data[offset:offset + filesz])


def symbol_address(elf: Path, name: str) -> int:
    for text in run(["arm-none-eabi-nm", str(elf)]).stdout.splitlines():
        parts = text.split()
        if len(parts) == 3 and parts[2] == name:
            return int(parts[0], 16) & ~1
    raise KeyError(name)


@dataclass(frozen=True)
class CycleEstimate:
    mean_cycles: float
    max_cycles: int
    steps: int
    outputs: np.ndarray  # the emulated step's outputs, for checking that it really ran


def estimate(elf: Path, prefix: str, inputs: np.ndarray, n_state: int, n_out: int) -> CycleEstimate:
    from unicorn import UC_ARCH_ARM, UC_HOOK_CODE, UC_MODE_THUMB, UC_PROT_ALL, Uc
    from unicorn.arm_const import (UC_ARM_REG_C1_C0_2, UC_ARM_REG_FPEXC, UC_ARM_REG_LR, UC_ARM_REG_R0,
                                   UC_ARM_REG_R1, UC_ARM_REG_R2, UC_ARM_REG_SP)

    code = disassemble(elf)
    emu = Uc(UC_ARCH_ARM, UC_MODE_THUMB)
    emu.reg_write(UC_ARM_REG_C1_C0_2, emu.reg_read(UC_ARM_REG_C1_C0_2) | (0xF << 20))  # CP10, CP11 on
    emu.reg_write(UC_ARM_REG_FPEXC, 0x4000_0000)
    _load(emu, elf)
    emu.mem_map(_RAM, _RAM_SIZE, UC_PROT_ALL)
    emu.mem_map(_RETURN & ~0xFFF, 0x1000, UC_PROT_ALL)
    state, inp, out = _RAM + 0x1000, _RAM + 0x2000, _RAM + 0x3000
    counter = {"cycles": 0, "previous": None}

    def hook(uc, address, size, user):  # noqa: ANN001 - Unicorn's callback signature
        ins = code.get(address)
        if ins is None:
            return
        prev = counter["previous"]
        if prev is not None and is_branch(prev[1]) and address != prev[0] + prev[1].size:
            counter["cycles"] += BRANCH_REFILL
        counter["cycles"] += cost(ins, prev[1] if prev else None)
        counter["previous"] = (address, ins)

    emu.hook_add(UC_HOOK_CODE, hook)
    step, init = symbol_address(elf, f"{prefix}step"), symbol_address(elf, f"{prefix}init")
    _call(emu, init, (state,), UC_ARM_REG_R0, UC_ARM_REG_R1, UC_ARM_REG_R2, UC_ARM_REG_SP, UC_ARM_REG_LR)
    per_step, outputs = [], []
    for row in inputs:
        emu.mem_write(inp, struct.pack(f"<{len(row)}f", *row))
        counter["cycles"], counter["previous"] = 0, None
        _call(emu, step, (state, inp, out), UC_ARM_REG_R0, UC_ARM_REG_R1, UC_ARM_REG_R2, UC_ARM_REG_SP, UC_ARM_REG_LR)
        per_step.append(counter["cycles"])
        outputs.append(struct.unpack(f"<{n_out}f", emu.mem_read(out, 4 * n_out)))
    return CycleEstimate(float(np.mean(per_step)), int(max(per_step)), len(per_step), np.array(outputs))


def _call(emu, address: int, args: tuple[int, ...], r0, r1, r2, sp, lr) -> None:  # noqa: ANN001
    for register, value in zip((r0, r1, r2), args):
        emu.reg_write(register, value)
    emu.reg_write(sp, _RAM + _RAM_SIZE - 16)
    emu.reg_write(lr, _RETURN | 1)
    emu.emu_start(address | 1, _RETURN, count=200_000)

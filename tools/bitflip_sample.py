"""Bit flips in flight logs, replayed: `python -m tools.bitflip_sample AIRFRAME LOG... [--per-log N]`.

Each log gets N copies with 5-20 random bit flips each (seeded), and each copy is replayed through
`dobwind replay AIRFRAME COPY -o est.csv` in its own process, classed as tools/campaign_sample.py classes
a case (traceback, hang, multi-line error, noisy success, stray temporary, absurd trusted wind). Issue #37
found 64-71 trusted rows of absurd wind per flipped PX4 ULog. The logs are read where they are and the
copies live in a temporary folder: nothing derived from them is kept.
"""
from __future__ import annotations

import argparse
import random
import sys
import tempfile
from pathlib import Path

from tools.campaign_sample import Case, Outcome, cli, run_all, table

FLIPS = (5, 20)


def flipped(data: bytes, rng: random.Random, skip: int = 16) -> bytes:
    """``data`` with 5-20 single-bit flips, none in its first ``skip`` bytes (the magic: a file that no
    longer claims its format is refused up front, which the campaign's other classes cover)."""
    out = bytearray(data)
    for _ in range(rng.randint(*FLIPS)):
        k = rng.randrange(min(skip, len(out) - 1), len(out))
        out[k] ^= 1 << rng.randrange(8)
    return bytes(out)


def bitflip_cases(airframe: str, logs: list[Path], folder: Path, per_log: int, seed: int) -> list[Case]:
    rng = random.Random(seed)
    cases = []
    for i, log in enumerate(logs):
        data = log.read_bytes()
        for j in range(per_log):
            copy = folder / f"flip{i}_{j}{log.suffix}"
            copy.write_bytes(flipped(data, rng))
            estimate = folder / f"flip{i}_{j}_est.csv"
            cases.append(Case(f"replay {log.name} flipped #{j}", cli("replay", airframe, str(copy), "-o", str(estimate)),
                              str(estimate)))
    return cases


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("airframe")
    parser.add_argument("logs", nargs="+", type=Path)
    parser.add_argument("--per-log", type=int, default=10)
    parser.add_argument("--seed", type=int, default=37)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="dobwind-bitflip-") as work:
        outcomes: list[Outcome] = run_all(bitflip_cases(args.airframe, args.logs, Path(work), args.per_log, args.seed),
                                          Path(work))
    print(table(outcomes))
    bad = [o for o in outcomes if o.problems]
    for o in bad:
        print(f"BAD {o.case}: exit {o.exit_code}, {', '.join(o.problems)}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

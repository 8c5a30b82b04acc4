"""Acceptance record for a behaviour-frozen refactor (issue #34): run BEFORE and AFTER, compare the JSON.

Usage: python tools/acceptance.py OUT.json [--map layout-map.txt] [--source DIR] [--only wheel]
       python tools/acceptance.py --compare BEFORE.json AFTER.json   (exit 1 and the differences if unequal)

Records, deterministically:
- `dobwind --help` and every `dobwind <cmd> --help` (the text, byte for byte);
- the `--json` of `check`, `verify` (host compiler only: --precision both, no --flags) and `analyze` on every
  shipped airframe (airframes/*.toml);
- the sha256 of every file `dobwind demo -o DIR` writes and of every file under generated_c/;
- the wheel's file list (`pip wheel --no-deps`), each path passed through the old->new map (--map) and with
  the modules that leave the package (benchmarks, development tools) removed, so BEFORE and AFTER compare.

What is run-dependent and normalised (each said where it is done): the temporary folders a run writes to
(replaced by <TMP>), and wall-clock timings in verify's JSON (keys named *time*/*seconds*/*elapsed*).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = ROOT / ".venv" / "bin"
COMMANDS = ("check", "generate", "verify", "analyze", "fit", "replay", "simulate", "profile", "report",
            "demo", "inspect", "init")
# Keys whose values are wall-clock measurements: they differ run to run, so they are dropped.
TIMING_KEY = re.compile(r"(time|seconds|elapsed|duration)", re.IGNORECASE)


def run(argv: list[str], cwd: Path) -> tuple[int, str, str]:
    done = subprocess.run(argv, cwd=cwd, capture_output=True, text=True)
    return done.returncode, done.stdout, done.stderr


def normalise(text: str, tmp: Path) -> str:
    """The temporary folder of this run is run-dependent: replace it by a fixed token."""
    return text.replace(str(tmp.resolve()), "<TMP>").replace(str(tmp), "<TMP>")


def drop_timings(obj):
    if isinstance(obj, dict):
        return {k: ("<timing>" if TIMING_KEY.search(k) and isinstance(v, (int, float)) else drop_timings(v))
                for k, v in obj.items()}
    if isinstance(obj, list):
        return [drop_timings(v) for v in obj]
    return obj


def helps(tmp: Path) -> dict[str, list]:
    out = {}
    for cmd in ("",) + COMMANDS:
        argv = [str(BIN / "dobwind")] + ([cmd] if cmd else []) + ["--help"]
        code, stdout, stderr = run(argv, tmp)
        out[cmd or "dobwind"] = [code, stdout, stderr]
    return out


def json_outputs(tmp: Path) -> dict[str, list]:
    out = {}
    for airframe in sorted((ROOT / "airframes").glob("*.toml")):
        for cmd in ("check", "verify", "analyze"):
            code, stdout, stderr = run([str(BIN / "dobwind"), cmd, str(airframe), "--json"], tmp)
            try:
                body = drop_timings(json.loads(normalise(stdout, tmp).replace(str(ROOT), "<ROOT>")))
            except json.JSONDecodeError:
                body = normalise(stdout, tmp)
            out[f"{cmd} {airframe.name}"] = [code, body, normalise(stderr, tmp).replace(str(ROOT), "<ROOT>")]
    return out


def hashes(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


# The demo's text names its staging folder (.dobwind-tmp-PID-RANDOM-demo, dobwind/io/outputs.py) and
# says how long it took: both differ run to run and are replaced by fixed tokens.
DEMO_RUN_DEPENDENT = ((re.compile(r"\.dobwind-tmp-\d+-[\w-]+?-demo"), ".dobwind-tmp-<ID>-demo"),
                      (re.compile(r"in \d+(\.\d+)? s\b"), "in <T> s"), (re.compile(r"took \d+(\.\d+)? s\b"), "took <T> s"))


def demo_text(text: str) -> str:
    for pattern, token in DEMO_RUN_DEPENDENT:
        text = pattern.sub(token, text)
    return text


def demo(tmp: Path) -> dict:
    out = tmp / "demo"
    code, stdout, stderr = run([str(BIN / "dobwind"), "demo", "-o", str(out)], tmp)
    return {"exit": code, "stdout": demo_text(normalise(stdout, tmp)), "files": hashes(out)}


def read_map(path: Path | None) -> tuple[dict[str, str], set[str]]:
    """`old/path -> new/path` lines (a folder maps everything under it; a path mapped outside the package
    leaves the wheel) and `+ path` lines: files the move adds (new subpackages' __init__.py), which are
    left out of the AFTER list so that the two lists compare."""
    if path is None:
        return {}, set()
    lines = [line.strip() for line in path.read_text().splitlines() if not line.startswith(("#", "name "))]
    pairs = [line.split("->") for line in lines if "->" in line]
    return {old.strip(): new.strip() for old, new in pairs}, {line[1:].strip() for line in lines if line.startswith("+")}


def map_path(repo: str, mapping: dict[str, str]) -> str:
    if repo in mapping:
        return mapping[repo]
    for old, new in mapping.items():
        if repo.startswith(old + "/"):
            return new + repo[len(old):]
    return repo


def wheel_path(name: str, mapping: dict[str, str], added: set[str]) -> str | None:
    """A wheel member in the repository's terms (dobwind/harness/x.py is harness/x.py), mapped."""
    repo = name
    for pkg in ("model", "codegen", "harness", "airframes"):
        if name.startswith(f"dobwind/{pkg}/"):
            repo = name[len("dobwind/"):]
    if repo in added:
        return None
    new = map_path(repo, mapping)
    if not (new.startswith("dobwind/") or new.split("/")[0] in ("model", "codegen", "harness", "airframes")):
        return None  # moved out of the package (benchmarks/, tools/): not in the wheel any more
    return new


def wheel(tmp: Path, source: Path, mapping: dict[str, str], added: set[str]) -> list[str]:
    dest = tmp / "wheel"
    # setuptools builds in place and never cleans build/lib: modules of an earlier layout left there would
    # be packed again, so the stale build folder (ignored by git) goes first.
    shutil.rmtree(source / "build", ignore_errors=True)
    code, _, stderr = run([str(BIN / "pip"), "wheel", "--no-deps", "-q", "-w",
                           str(dest), str(source)], tmp)
    if code:
        return [f"pip wheel failed: {stderr}"]
    (whl,) = dest.glob("*.whl")
    names = [n for n in zipfile.ZipFile(whl).namelist() if ".dist-info/" not in n]
    return sorted(p for p in (wheel_path(n, mapping, added) for n in names) if p is not None)


def differences(before: object, after: object, where: str = "") -> list[str]:
    if isinstance(before, dict) and isinstance(after, dict):
        out = [f"{where}/{k}: only in {'BEFORE' if k in before else 'AFTER'}" for k in sorted(set(before) ^ set(after))]
        return out + [d for k in sorted(set(before) & set(after)) for d in differences(before[k], after[k], f"{where}/{k}")]
    if isinstance(before, list) and isinstance(after, list) and all(isinstance(x, str) for x in before + after) \
            and len(before) != len(after):
        return [f"{where}: {x} only in BEFORE" for x in sorted(set(before) - set(after))] + \
               [f"{where}: {x} only in AFTER" for x in sorted(set(after) - set(before))]
    return [] if before == after else [f"{where}: differs"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("output", nargs="?")
    parser.add_argument("--map", type=Path, help="old -> new path map (docs/architecture.md, issue #34)")
    parser.add_argument("--source", type=Path, default=ROOT, help="build the wheel from this checkout")
    parser.add_argument("--only", choices=("wheel",), help="record only the wheel's file list")
    parser.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"))
    args = parser.parse_args()
    if args.compare:
        before, after = (json.loads(Path(p).read_text()) for p in args.compare)
        found = differences(before, after)
        print("\n".join(found) if found else "identical")
        return 1 if found else 0
    mapping, added = read_map(args.map)
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        record = {"wheel": wheel(tmp, args.source.resolve(), mapping, added)}
        if args.only is None:
            record.update({"help": helps(tmp), "json": json_outputs(tmp), "demo": demo(tmp),
                           "generated_c": hashes(ROOT / "generated_c")})
    Path(args.output).write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

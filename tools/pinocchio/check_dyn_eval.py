#!/usr/bin/env python3
"""Cross-check centaur-dynamics' `dyn_eval` example against Pinocchio.

For each input it runs the Rust tool (or any command honouring the dyn_eval
contract, see README.md) and compares every quantity with a reference:

* default: Pinocchio evaluated now, on the same input;
* --reference fixture: the "output" stored in a fixture file (no Pinocchio
  needed, only numpy).

Inputs are dyn_eval input files, fixture files (their "input" is used), or,
with --random URDF, freshly drawn random cases.

Error metric, per quantity and per case (b = reference, a = tool):

    rel = ||a - b||_inf / max(||b||_inf, 1e-12)

taken over the flattened quantity (M: all nv*nv entries; frames: all
translations together, all rotation matrices together). The report shows the
max over cases, per quantity and per input; the exit code is 1 if any value
exceeds --tol (default 1e-9) or the tool fails / prints malformed output.

Examples (from the repository root):
    python tools/pinocchio/check_dyn_eval.py dynamics/tests/fixtures/pinocchio/*.json
    python tools/pinocchio/check_dyn_eval.py --random assets/solo12/solo12.urdf --floating-base --n 20
    python tools/pinocchio/check_dyn_eval.py --cos-sin --random assets/minitaur/minitaur.urdf --floating-base
    # self-test, Pinocchio against Pinocchio:
    python tools/pinocchio/check_dyn_eval.py --cmd "python tools/pinocchio/gen_fixtures.py --eval" \\
        dynamics/tests/fixtures/pinocchio/*.json
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

import pinref

DEFAULT_CMD = "cargo run --release -q -p centaur-dynamics --example dyn_eval --"
DEFAULT_TOL = 1e-9


def load_job(path: Path) -> tuple[str, dict, dict | None]:
    """(label, dyn_eval input, stored output or None) of an input/fixture file."""
    doc = json.loads(path.read_text())
    if "input" in doc and "cases" not in doc:      # a fixture
        return path.stem, doc["input"], doc.get("output")
    return path.stem, doc, None


def run_tool(cmd: str, inp: dict, timeout: float) -> dict:
    """Write inp to a temp file, run `cmd <file>` in the repo root, parse stdout."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", prefix="dyn_eval_",
                                     delete=False) as fh:
        json.dump(inp, fh)
        tmp = fh.name
    try:
        proc = subprocess.run(shlex.split(cmd) + [tmp], cwd=pinref.REPO_ROOT,
                              capture_output=True, text=True, timeout=timeout)
    finally:
        Path(tmp).unlink(missing_ok=True)
    if proc.returncode != 0:
        raise RuntimeError(f"command failed with exit code {proc.returncode}:\n"
                           f"{proc.stderr.strip()[-4000:]}")
    try:
        return json.loads(proc.stdout)
    except json.JSONDecodeError as err:
        raise RuntimeError(f"tool output is not JSON ({err}); first 500 chars:\n"
                           f"{proc.stdout[:500]}") from err


def compare(got: dict, ref: dict, tol: float) -> tuple[dict[str, float], bool]:
    """Max over cases of each quantity's relative error (inf on malformed output), and
    whether any case fails its bar: `tol`, except for ddq on an ill-conditioned mass
    matrix, where forward dynamics amplifies rounding by cond(M) and the bar is
    max(tol, 1e-15 * cond(M)) (iCub's cond(M) reaches 2.5e9)."""
    worst = {q: 0.0 for q in pinref.QUANTITIES}
    gcases, rcases = got.get("cases"), ref["cases"]
    if not isinstance(gcases, list) or len(gcases) != len(rcases):
        return {q: math.inf for q in worst}, True
    bad = False
    for g, r in zip(gcases, rcases):
        eig = np.linalg.eigvalsh(np.asarray(r["M"], dtype=float))
        cond = eig.max() / eig.min() if eig.min() > 0 else math.inf
        for q, e in pinref.case_errors(g, r).items():
            worst[q] = max(worst[q], e)
            bar = max(tol, 1e-15 * cond) if q == "ddq" else tol
            bad |= not (e <= bar)
    return worst, bad


def fmt(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:.1e}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="*", type=Path,
                    help="dyn_eval input files or fixture files")
    ap.add_argument("--cmd", default=DEFAULT_CMD,
                    help=f"tool command; the input path is appended (default: {DEFAULT_CMD!r})")
    ap.add_argument("--reference", choices=("pinocchio", "fixture"), default="pinocchio",
                    help="compare with Pinocchio now (default) or with the fixture's stored output")
    ap.add_argument("--random", metavar="URDF", action="append", default=[],
                    help="also check N fresh random cases of this URDF (repeatable)")
    ap.add_argument("--floating-base", action="store_true", help="for --random")
    ap.add_argument("--n", type=int, default=20, help="cases per --random URDF")
    ap.add_argument("--seed", type=int, default=1, help="seed for --random")
    ap.add_argument("--save", type=Path, help="write the --random input(s) here (dir)")
    ap.add_argument("--tol", type=float, default=DEFAULT_TOL)
    ap.add_argument("--cos-sin", action="store_true",
                    help='set "continuous_as_cos_sin" in every input: the tool loads continuous '
                         "joints as (cos, sin) joints, as Pinocchio does (q keeps angles)")
    ap.add_argument("--timeout", type=float, default=3600.0,
                    help="seconds per tool run (the first cargo run may compile)")
    args = ap.parse_args()

    jobs = [load_job(p) for p in args.files]
    for k, urdf in enumerate(args.random):
        # A path valid from the current directory wins; otherwise it is taken
        # relative to the repository root, like the paths inside input files.
        if Path(urdf).exists():
            urdf = str(Path(urdf).resolve())
        rm = pinref.load_robot(urdf, args.floating_base)
        inp = pinref.make_input(rm, urdf, pinref.random_cases(rm, args.n, args.seed + k))
        label = f"{Path(urdf).stem} (random)"
        if args.save:
            args.save.mkdir(parents=True, exist_ok=True)
            (args.save / f"{Path(urdf).stem}_random.json").write_text(pinref.dumps(inp) + "\n")
        jobs.append((label, inp, None))
    if not jobs:
        ap.error("nothing to check: give files and/or --random URDF")

    rows, failed = [], False
    for label, inp, stored in jobs:
        if args.reference == "fixture":
            if stored is None:
                print(f"{label}: no stored output to compare with", file=sys.stderr)
                failed = True
                continue
            ref = stored
        else:
            ref = pinref.evaluate_input(inp)
        if args.cos_sin:
            inp = {**inp, "continuous_as_cos_sin": True}
            label = f"{label} (cos, sin)"
        try:
            got = run_tool(args.cmd, inp, args.timeout)
        except (RuntimeError, subprocess.TimeoutExpired, OSError) as err:
            print(f"{label}: {err}", file=sys.stderr)
            rows.append((label, len(inp["cases"]), {q: math.inf for q in pinref.QUANTITIES}, True))
            failed = True
            continue
        rows.append((label, len(inp["cases"]), *compare(got, ref, args.tol)))

    # Report: one row per input, one column per quantity, then the overall max.
    header = ["robot", "cases", *pinref.QUANTITIES, "status"]
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    overall = {q: 0.0 for q in pinref.QUANTITIES}
    for label, n, errs, bad in rows:
        failed |= bad
        for q, e in errs.items():
            overall[q] = max(overall[q], e)
        cells = [label, str(n), *(fmt(errs[q]) for q in pinref.QUANTITIES),
                 "FAIL" if bad else "ok"]
        print("| " + " | ".join(cells) + " |")
    print()
    print("max relative error per quantity: " +
          ", ".join(f"{q} {fmt(e)}" for q, e in overall.items()))
    print(f"tolerance {args.tol:g} (ddq: max(tol, 1e-15 cond(M))): {'FAIL' if failed else 'ok'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

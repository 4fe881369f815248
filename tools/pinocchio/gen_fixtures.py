#!/usr/bin/env python3
"""Generate Pinocchio golden fixtures for centaur-dynamics.

Default mode writes dynamics/tests/fixtures/pinocchio/<robot>.json for every
robot in pinref.ROBOTS (or those named with --robot):

    {"provenance": {...}, "input": <dyn_eval input>, "output": <dyn_eval output>}

where "input" is exactly what `cargo run -p centaur-dynamics --example dyn_eval
-- cases.json` reads and "output" is what it must print (see README.md).

--eval FILE is a stand-in for the Rust tool: it reads a dyn_eval input (or a
fixture, using its "input") and prints Pinocchio's dyn_eval output on stdout.
check_dyn_eval.py uses it to test itself Pinocchio-against-Pinocchio.

Run from anywhere, with the venv that has `pin` (see requirements.txt):
    /work/venv/py/bin/python tools/pinocchio/gen_fixtures.py
    /work/venv/py/bin/python tools/pinocchio/gen_fixtures.py --robot minitaur --cases 6
    /work/venv/py/bin/python tools/pinocchio/gen_fixtures.py --eval cases.json
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import sys
import zlib
from pathlib import Path

import numpy as np

import pinref

FIXTURE_DIR = pinref.REPO_ROOT / "dynamics" / "tests" / "fixtures" / "pinocchio"
DEFAULT_SEED = 20240917
DEFAULT_CASES = 6


def robot_seed(base_seed: int, robot: str) -> int:
    """Per-robot seed: the base seed offset by a stable hash of the name."""
    return base_seed + zlib.crc32(robot.encode()) % 100_000


def self_check(rm: pinref.RobotModel, inp: dict, out: dict) -> None:
    """Cheap consistency checks on what we are about to freeze."""
    pin = pinref._pin()
    for case_in, case_out in zip(inp["cases"], out["cases"]):
        M = np.array(case_out["M"])
        assert np.array_equal(M, M.T), "M not symmetric"
        assert np.all(np.linalg.eigvalsh(M) > 0), "M not positive definite"
        # Forward and inverse dynamics must agree: M ddq + nle = tau.
        resid = M @ np.array(case_out["ddq"]) + np.array(case_out["nle"]) - np.array(case_in["tau"])
        assert np.abs(resid).max() <= 1e-9 * max(1.0, np.abs(case_in["tau"]).max()), resid
        if rm.floating_base:
            # The root link's placement is exactly the base part of q.
            f = case_out["frames"][rm.root_link]
            q = case_in["q"]
            R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
            assert np.allclose(f["translation"], q[:3], rtol=0, atol=1e-14)
            assert np.allclose(f["rotation"], R, rtol=0, atol=1e-14)


def provenance(generator: str, urdf: Path, seed: int, **extra) -> dict:
    """The provenance block every fixture starts with; `extra` keys follow the common ones."""
    pin = pinref._pin()
    return {
        "generator": generator,
        "pinocchio": pin.__version__,
        "numpy": np.__version__,
        "date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        **extra,
        "urdf_sha256": pinref.sha256_of(urdf),
        "seed": seed,
    }


def generate(robot: str, n_cases: int, base_seed: int, out_dir: Path) -> Path:
    pin = pinref._pin()
    urdf_rel, floating = pinref.ROBOTS[robot]
    rm = pinref.load_robot(urdf_rel, floating)
    seed = robot_seed(base_seed, robot)
    cases = pinref.random_cases(rm, n_cases, seed)
    inp = pinref.make_input(rm, urdf_rel, cases)
    out = pinref.evaluate_input(inp)
    self_check(rm, inp, out)

    doc = {
        "provenance": {
            **provenance("tools/pinocchio/gen_fixtures.py", rm.urdf, seed),
            "notes": (f"Pinocchio model: nq={rm.model.nq} (continuous joints as cos/sin), "
                      f"nv={rm.model.nv}, {len(rm.joints)} 1-dof joints, "
                      f"{len(rm.links)} links. q uses one angle per continuous joint. "
                      "tau = rnea(q, v, a') for an independent a' ~ N(0,1)."),
        },
        "input": inp,
        "output": out,
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{robot}.json"
    path.write_text(pinref.dumps(doc) + "\n")
    print(f"{path.relative_to(pinref.REPO_ROOT) if path.is_relative_to(pinref.REPO_ROOT) else path}: "
          f"nq={rm.model.nq} nv={rm.model.nv} joints={len(rm.joints)} "
          f"links={len(rm.links)} cases={n_cases} seed={seed}")
    return path


def eval_mode(path: str) -> int:
    """Print Pinocchio's dyn_eval output for a dyn_eval input (or fixture)."""
    doc = json.loads(Path(path).read_text())
    inp = doc["input"] if "input" in doc and "cases" not in doc else doc
    sys.stdout.write(pinref.dumps(pinref.evaluate_input(inp)) + "\n")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", action="append", choices=sorted(pinref.ROBOTS),
                    help="robot to generate (repeatable; default: all)")
    ap.add_argument("--cases", type=int, default=DEFAULT_CASES, help="cases per robot")
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED,
                    help="base seed (each robot offsets it by a hash of its name)")
    ap.add_argument("--out-dir", type=Path, default=FIXTURE_DIR)
    ap.add_argument("--eval", metavar="FILE",
                    help="stand-in for dyn_eval: print Pinocchio's output for FILE")
    args = ap.parse_args()

    if args.eval:
        return eval_mode(args.eval)
    for robot in args.robot or list(pinref.ROBOTS):
        generate(robot, args.cases, args.seed, args.out_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())

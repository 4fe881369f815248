#!/usr/bin/env python3
"""The corpus of 44 published robots that centaur-dynamics must load (issue: "every
published URDF that Pinocchio loads").

One list, CORPUS, drives three commands (run from anywhere with the venv of
requirements.txt, which has `pin`, `example-robot-data` and `pybullet`):

    python tools/pinocchio/corpus.py copy       # copy the URDFs into assets/corpus/, verify sha256
    python tools/pinocchio/corpus.py fixtures   # Pinocchio fixtures into dynamics/tests/fixtures/pinocchio/corpus/
    python tools/pinocchio/corpus.py list       # the list, one line per robot

The files are copied byte for byte (no meshes: the dynamics never reads them).
Each fixture is a dyn_eval input plus Pinocchio's output for it, as
gen_fixtures.py writes them, with the corpus entry's provenance; where
Pinocchio's mass matrix is singular in a case (condition number above 1e10:
massless leaves, point masses on a joint axis) the case's "ddq" is null,
because forward dynamics is undefined there; the provenance records every
case's condition number ("cond_M").
"""

from __future__ import annotations

import argparse
import hashlib
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import gen_fixtures
import pinref

CORPUS_DIR = pinref.REPO_ROOT / "assets" / "corpus"
FIXTURE_DIR = pinref.REPO_ROOT / "dynamics" / "tests" / "fixtures" / "pinocchio" / "corpus"
CASES = 3
SINGULAR_COND = 1e10


def _site_packages() -> Path:
    import pybullet_data  # noqa: PLC0415
    return Path(pybullet_data.__file__).resolve().parents[1]


@dataclass(frozen=True)
class Entry:
    name: str
    package: str          # "example-robot-data" or "pybullet_data"
    path: str             # inside the package's robots folder / pybullet_data
    floating_base: bool
    # True for the few published files the default policy refuses (a body with mass
    # whose inertia clearly violates a rigid body's conditions): loaded with
    # UrdfOptions::accept_nonphysical_inertia, as Pinocchio loads them.
    accept_nonphysical_inertia: bool = False

    def installed(self) -> Path:
        sp = _site_packages()
        if self.package == "example-robot-data":
            return sp / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / self.path
        return sp / "pybullet_data" / self.path

    def asset(self) -> Path:
        return CORPUS_DIR / self.package / self.path

    def asset_rel(self) -> str:
        return str(self.asset().relative_to(pinref.REPO_ROOT))


E, P = "example-robot-data", "pybullet_data"
# Left out for their licences (assets/corpus/PROVENANCE.md): example-robot-data's tiago.urdf
# (its header says CC BY-NC-ND 3.0; TIAGo Pro's file is Apache-2.0 and stands for TIAGo),
# centauro.urdf and pybullet's racecar.urdf (no licence upstream), hextilt_flying_arm_5.urdf
# (upstream licence "TODO"). They load all the same.
CORPUS = [
    # quadrupeds
    Entry("go1", E, "go1_description/urdf/go1.urdf", True),
    Entry("go2", E, "go2_description/urdf/go2.urdf", True),
    Entry("a1", E, "a1_description/urdf/a1.urdf", True),
    Entry("b1", E, "b1_description/urdf/b1.urdf", True),
    Entry("laikago", E, "laikago_description/urdf/laikago.urdf", True),
    Entry("anymal_b", E, "anymal_b_simple_description/robots/anymal.urdf", True),
    Entry("anymal_b_kinova", E, "anymal_b_simple_description/robots/anymal-kinova.urdf", True),
    Entry("anymal_c", E, "anymal_c_simple_description/urdf/anymal.urdf", True),
    Entry("hyq", E, "hyq_description/robots/hyq_no_sensors.urdf", True),
    Entry("solo", E, "solo_description/robots/solo.urdf", True),
    Entry("quadruped", E, "quadruped_description/urdf/quadruped.urdf", True),
    Entry("aliengo", P, "aliengo/aliengo.urdf", True),
    Entry("spirit40", P, "quadruped/spirit40.urdf", True),
    Entry("vision60", P, "quadruped/vision60.urdf", True),
    Entry("laikago_toes", P, "laikago/laikago_toes_zup.urdf", True),
    # bipeds and humanoids
    Entry("bolt", E, "bolt_description/robots/bolt.urdf", True),
    Entry("icub", E, "icub_description/robots/icub.urdf", True),
    Entry("icub_reduced", E, "icub_description/robots/icub_reduced.urdf", True),
    Entry("romeo", E, "romeo_description/urdf/romeo.urdf", True),
    Entry("g1", E, "g1_description/urdf/g1_29dof_rev_1_0.urdf", True),
    Entry("alexander_lower_body", E, "alexander_description/urdf/alexander_v1.lowerBodyOnly.urdf", True),
    Entry("human", E, "human_description/robots/human.urdf", True),
    Entry("simple_humanoid", E, "simple_humanoid_description/urdf/simple_humanoid.urdf", True),
    # mobile manipulators, wheeled and flying robots
    Entry("tiago_pro", E, "tiago_pro_description/robots/tiago_pro.urdf", True),
    Entry("pr2", E, "pr2_description/urdf/pr2.urdf", True),
    Entry("r2d2", P, "r2d2.urdf", True),
    Entry("iris", E, "iris_description/robots/iris.urdf", True),
    # arms and hands (fixed base)
    Entry("baxter", E, "baxter_description/urdf/baxter.urdf", False),
    Entry("allegro_right_hand", E, "allegro_hand_description/urdf/allegro_right_hand.urdf", False),
    Entry("panda", E, "panda_description/urdf/panda.urdf", False),
    Entry("panda_pybullet", P, "franka_panda/panda.urdf", False),
    Entry("kuka_iiwa", P, "kuka_iiwa/model.urdf", False),
    Entry("ur10", E, "ur_description/urdf/ur10_robot.urdf", False),
    Entry("kinova", E, "kinova_description/robots/kinova.urdf", False),
    Entry("xarm7", E, "xarm_description/urdf/xarm7.urdf", False),
    Entry("z1", E, "z1_description/urdf/z1.urdf", False),
    Entry("so100", E, "so_arm_description/urdf/so100.urdf", False),
    Entry("finger_edu", E, "finger_edu_description/robots/finger_edu.urdf", False),
    Entry("double_pendulum", E, "double_pendulum_description/urdf/double_pendulum_continuous.urdf", False),
    Entry("cartpole", P, "cartpole.urdf", False),
    # refused by the default policy, loaded as given on request
    Entry("romeo_small", E, "romeo_description/urdf/romeo_small.urdf", True, True),
    Entry("romeo_laas_small", E, "romeo_description/urdf/romeo_laas_small.urdf", True, True),
    Entry("mini_cheetah", P, "mini_cheetah/mini_cheetah.urdf", True, True),
    Entry("xarm6", P, "xarm/xarm6_robot.urdf", False, True),
]


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def package_version(package: str) -> str:
    from importlib.metadata import version  # noqa: PLC0415
    return "example-robot-data " + version("example-robot-data") if package == E \
        else "pybullet_data (pybullet " + version("pybullet") + ")"


def cmd_copy(_args) -> int:
    for e in CORPUS:
        src, dst = e.installed(), e.asset()
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dst)
        assert sha256(src) == sha256(dst)
        print(f"{e.asset_rel()}  {dst.stat().st_size:>7} bytes  sha256 {sha256(dst)[:16]}…")
    return 0


def make_fixture(e: Entry, seed_base: int) -> Path:
    rm = pinref.load_robot(e.asset(), e.floating_base)
    seed = gen_fixtures.robot_seed(seed_base, "corpus/" + e.name)
    cases = pinref.random_cases(rm, CASES, seed)
    inp = pinref.make_input(rm, e.asset_rel(), cases)
    if e.accept_nonphysical_inertia:
        inp["accept_nonphysical_inertia"] = True
    out = pinref.evaluate_input(inp)
    singular = 0
    conds = []
    for case_out in out["cases"]:
        M = np.array(case_out["M"])
        eig = np.linalg.eigvalsh(M)
        conds.append(float(eig.max() / eig.min()) if eig.min() > 0 else None)
        if eig.min() <= eig.max() / SINGULAR_COND:
            case_out["ddq"] = None
            singular += 1
    doc = {
        "provenance": {
            **gen_fixtures.provenance("tools/pinocchio/corpus.py fixtures", e.asset(), seed,
                                      robot=e.name, source=package_version(e.package),
                                      source_path=e.path),
            # Condition number of M per case (null: singular): ddq can only agree to about
            # cond(M) times the rounding error, which the golden test allows for.
            "cond_M": conds,
            "notes": (f"Pinocchio model: nq={rm.model.nq}, nv={rm.model.nv}, {len(rm.joints)} 1-dof joints, "
                      f"{len(rm.links)} links; {singular} of {CASES} cases with a singular mass matrix "
                      f"(ddq null). q uses one angle per continuous joint."),
        },
        "input": inp,
        "output": out,
    }
    FIXTURE_DIR.mkdir(parents=True, exist_ok=True)
    path = FIXTURE_DIR / f"{e.name}.json"
    path.write_text(pinref.dumps(doc) + "\n")
    print(f"{path.relative_to(pinref.REPO_ROOT)}: nq={rm.model.nq} nv={rm.model.nv} "
          f"links={len(rm.links)} singular={singular} {path.stat().st_size} bytes")
    return path


def cmd_fixtures(args) -> int:
    for e in CORPUS:
        if args.robot and e.name not in args.robot:
            continue
        if sha256(e.asset()) != sha256(e.installed()):
            print(f"{e.name}: {e.asset_rel()} differs from the installed file; run `copy` first",
                  file=sys.stderr)
            return 1
        make_fixture(e, args.seed)
    return 0


def cmd_list(_args) -> int:
    for e in CORPUS:
        flag = "  (accept_nonphysical_inertia)" if e.accept_nonphysical_inertia else ""
        print(f"{e.name:22s} {e.package:20s} {e.path}{flag}")
    return 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="cmd", required=True)
    sub.add_parser("copy").set_defaults(fn=cmd_copy)
    f = sub.add_parser("fixtures")
    f.add_argument("--robot", action="append", help="only this robot (repeatable)")
    f.add_argument("--seed", type=int, default=gen_fixtures.DEFAULT_SEED)
    f.set_defaults(fn=cmd_fixtures)
    sub.add_parser("list").set_defaults(fn=cmd_list)
    args = ap.parse_args()
    return args.fn(args)


if __name__ == "__main__":
    sys.exit(main())

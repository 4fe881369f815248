"""Pinocchio reference evaluation for Centaur's `dyn_eval` cross-check contract.

Shared by gen_fixtures.py (writes golden fixtures), check_dyn_eval.py (compares
the Rust tool with Pinocchio) and bench_side_by_side.py (robot list).

Conventions of the contract (they are Pinocchio's, except for continuous joints):

* Floating base: q = [x, y, z, qx, qy, qz, qw, joints...] is the placement of
  the URDF root link in the world (scalar-last unit quaternion);
  v = [linear, angular] velocity of the root link expressed in the root-link
  frame, then the joint rates; the base part of a generalized force is the
  wrench on the root link expressed in the root-link frame.
* Gravity is (0, 0, -9.81).
* Every 1-dof joint (revolute, continuous, prismatic) takes ONE entry in q.
  Pinocchio stores a continuous joint as (cos, sin): `to_pinocchio_q` converts.
* Vectors follow the caller's `joint_names` order, which need not be
  Pinocchio's; outputs are permuted back to that order.

Pinocchio is imported lazily so that the JSON helpers and the error metric can
be used (e.g. comparing against stored fixtures) without it installed.
"""

from __future__ import annotations

import hashlib
import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# tools/pinocchio/pinref.py -> repository root is two levels up.
REPO_ROOT = Path(__file__).resolve().parents[2]

# Robots covered by the golden fixtures and the side-by-side benchmark.
# name -> (URDF path relative to the repo root, floating base?)
ROBOTS = {
    "solo12": ("assets/solo12/solo12.urdf", True),
    "talos_reduced": ("assets/talos/talos_reduced.urdf", True),
    "ur5_robot": ("assets/ur5/ur5_robot.urdf", False),
    "minitaur": ("assets/minitaur/minitaur.urdf", True),
}

# Quantities of a dyn_eval output case, in the order reports list them.
QUANTITIES = ("tau", "nle", "M", "ddq", "com", "total_mass",
              "frames.translation", "frames.rotation")


def _pin():
    """Import Pinocchio on first use (only the evaluating paths need it)."""
    import pinocchio  # noqa: PLC0415  (deliberately lazy)
    return pinocchio


def resolve_path(path: str | Path) -> Path:
    """Resolve a URDF path: absolute as is, relative to the repository root."""
    p = Path(path)
    return p if p.is_absolute() else (REPO_ROOT / p)


def sha256_of(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


# --------------------------------------------------------------------------
# URDF facts that Pinocchio's model does not keep faithfully
# --------------------------------------------------------------------------

@dataclass
class UrdfJoint:
    name: str
    kind: str                       # revolute, continuous, prismatic, fixed, ...
    lower: float | None = None      # None when the attribute is absent
    upper: float | None = None

    def finite_range(self) -> tuple[float, float] | None:
        """The sampling range for q, or None if the joint is unlimited.

        urdfdom defaults a missing lower/upper to 0, so Pinocchio reports
        [0, 0] for e.g. the Minitaur's knees; we read the XML instead and call
        a joint limited only if both bounds are given and lower < upper.
        """
        if self.kind == "continuous" or self.lower is None or self.upper is None:
            return None
        if not (math.isfinite(self.lower) and math.isfinite(self.upper)):
            return None
        if self.lower >= self.upper:
            return None
        return (self.lower, self.upper)


def parse_urdf(path: Path) -> tuple[list[str], dict[str, UrdfJoint], str]:
    """Return (link names in document order, joints by name, root link)."""
    root = ET.parse(path).getroot()
    links = [el.get("name") for el in root.findall("link")]
    joints: dict[str, UrdfJoint] = {}
    children = set()
    for el in root.findall("joint"):
        child = el.find("child")
        if child is not None:
            children.add(child.get("link"))
        lim = el.find("limit")
        lower = upper = None
        if lim is not None:
            if lim.get("lower") is not None:
                lower = float(lim.get("lower"))
            if lim.get("upper") is not None:
                upper = float(lim.get("upper"))
        joints[el.get("name")] = UrdfJoint(el.get("name"), el.get("type"), lower, upper)
    roots = [l for l in links if l not in children]
    if len(roots) != 1:
        raise ValueError(f"{path}: expected one root link, found {roots}")
    return links, joints, roots[0]


# --------------------------------------------------------------------------
# Model wrapper
# --------------------------------------------------------------------------

@dataclass
class JointSlot:
    """Where one 1-dof joint lives in Pinocchio's q and v."""
    name: str
    idx_q: int
    idx_v: int
    continuous: bool                # True: Pinocchio stores (cos, sin) at idx_q


@dataclass
class RobotModel:
    urdf: Path
    floating_base: bool
    model: object                   # pinocchio.Model
    data: object                    # pinocchio.Data
    joints: list[JointSlot]         # Pinocchio joint order, universe/free flyer skipped
    links: list[str]                # URDF link names, document order
    urdf_joints: dict[str, UrdfJoint]
    root_link: str                  # the URDF link no joint has as child
    n_base_q: int = field(init=False)
    n_base_v: int = field(init=False)

    def __post_init__(self):
        self.n_base_q = 7 if self.floating_base else 0
        self.n_base_v = 6 if self.floating_base else 0

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.joints]

    @property
    def nq_contract(self) -> int:
        """Length of q in the contract (one entry per 1-dof joint)."""
        return self.n_base_q + len(self.joints)

    @property
    def nv(self) -> int:
        return self.model.nv


def load_robot(urdf: str | Path, floating_base: bool) -> RobotModel:
    """Build the Pinocchio model of a URDF, as pin.buildModelFromUrdf does."""
    pin = _pin()
    path = resolve_path(urdf)
    if floating_base:
        model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    else:
        model = pin.buildModelFromUrdf(str(path))
    links, urdf_joints, root_link = parse_urdf(path)

    first = 2 if floating_base else 1   # skip the universe (and the free flyer)
    if floating_base and model.joints[1].shortname() != "JointModelFreeFlyer":
        raise ValueError(f"{path}: joint 1 is not the free flyer")
    joints = []
    for jid in range(first, model.njoints):
        jm = model.joints[jid]
        name = model.names[jid]
        if jm.nv != 1:
            raise ValueError(f"{path}: joint {name!r} ({jm.shortname()}) is not 1-dof; "
                             "the dyn_eval contract only covers 1-dof joints")
        # Pinocchio's "unbounded" revolute joints (JointModelRUB*) use (cos, sin).
        continuous = jm.nq == 2
        joints.append(JointSlot(name, jm.idx_q, jm.idx_v, continuous))
        if name in urdf_joints:
            kind = urdf_joints[name].kind
            if continuous != (kind == "continuous"):
                raise ValueError(f"{path}: joint {name!r} is {kind} in the URDF but "
                                 f"{jm.shortname()} in Pinocchio")

    # Every URDF link must be a BODY frame (fixed-joint children become frames).
    for link in links:
        if not model.existFrame(link, pin.FrameType.BODY):
            raise ValueError(f"{path}: link {link!r} has no BODY frame in Pinocchio")

    return RobotModel(path, floating_base, model, model.createData(), joints, links,
                      urdf_joints, root_link)


# --------------------------------------------------------------------------
# Contract <-> Pinocchio vectors
# --------------------------------------------------------------------------

def joint_permutation(rm: RobotModel, joint_names: list[str]) -> list[JointSlot]:
    """Slots of the caller's joint_names, checking they are exactly the model's."""
    by_name = {j.name: j for j in rm.joints}
    if sorted(joint_names) != sorted(by_name):
        missing = sorted(set(by_name) - set(joint_names))
        extra = sorted(set(joint_names) - set(by_name))
        raise ValueError(f"joint_names do not match the model's 1-dof joints "
                         f"(missing {missing}, unknown {extra})")
    return [by_name[n] for n in joint_names]


def v_index(rm: RobotModel, slots: list[JointSlot]) -> np.ndarray:
    """Pinocchio v index of each contract v entry (base first)."""
    return np.array(list(range(rm.n_base_v)) + [s.idx_v for s in slots], dtype=int)


def to_pinocchio_q(rm: RobotModel, slots: list[JointSlot], q) -> np.ndarray:
    """Contract q (one angle per continuous joint) -> Pinocchio q."""
    q = np.asarray(q, dtype=float)
    if q.shape != (rm.n_base_q + len(slots),):
        raise ValueError(f"q has {q.size} entries, expected {rm.n_base_q + len(slots)}")
    out = np.zeros(rm.model.nq)
    out[:rm.n_base_q] = q[:rm.n_base_q]
    for k, s in enumerate(slots):
        x = q[rm.n_base_q + k]
        if s.continuous:
            out[s.idx_q] = math.cos(x)
            out[s.idx_q + 1] = math.sin(x)
        else:
            out[s.idx_q] = x
    return out


def to_pinocchio_v(rm: RobotModel, slots: list[JointSlot], v) -> np.ndarray:
    """Contract v/a/tau (caller's joint order) -> Pinocchio's v order."""
    v = np.asarray(v, dtype=float)
    if v.shape != (rm.nv,):
        raise ValueError(f"vector has {v.size} entries, expected nv = {rm.nv}")
    out = np.zeros(rm.nv)
    out[v_index(rm, slots)] = v
    return out


# --------------------------------------------------------------------------
# Evaluation
# --------------------------------------------------------------------------

def evaluate_case(rm: RobotModel, slots: list[JointSlot], frames: list[str], case: dict) -> dict:
    """Pinocchio's answer to one dyn_eval case, in the caller's joint order."""
    pin = _pin()
    m, d = rm.model, rm.data
    q = to_pinocchio_q(rm, slots, case["q"])
    v = to_pinocchio_v(rm, slots, case["v"])
    a = to_pinocchio_v(rm, slots, case["a"])
    tau = to_pinocchio_v(rm, slots, case["tau"])
    back = v_index(rm, slots)          # contract index -> Pinocchio index

    tau_id = pin.rnea(m, d, q, v, a).copy()
    nle = pin.rnea(m, d, q, v, np.zeros(rm.nv)).copy()
    M = pin.crba(m, d, q).copy()
    M = np.triu(M) + np.triu(M, 1).T   # C++ fills the upper triangle only
    ddq = pin.aba(m, d, q, v, tau).copy()
    com = pin.centerOfMass(m, d, q).copy()   # joints 1.. only, like total mass
    total_mass = pin.computeTotalMass(m)     # excludes inertia welded to universe

    pin.framesForwardKinematics(m, d, q)
    placements = {}
    for link in frames:
        fid = m.getFrameId(link, pin.FrameType.BODY)
        if fid >= m.nframes:
            raise ValueError(f"no BODY frame named {link!r}")
        oMf = d.oMf[fid]
        placements[link] = {"translation": oMf.translation.tolist(),
                            "rotation": oMf.rotation.tolist()}

    return {
        "tau": tau_id[back].tolist(),
        "nle": nle[back].tolist(),
        "M": M[np.ix_(back, back)].tolist(),
        "ddq": ddq[back].tolist(),
        "com": com.tolist(),
        "total_mass": float(total_mass),
        "frames": placements,
    }


def evaluate_input(inp: dict) -> dict:
    """Pinocchio's full dyn_eval output for a dyn_eval input document."""
    rm = load_robot(inp["urdf"], bool(inp["floating_base"]))
    slots = joint_permutation(rm, list(inp["joint_names"]))
    frames = list(inp.get("frames", []))
    return {"cases": [evaluate_case(rm, slots, frames, c) for c in inp["cases"]]}


# --------------------------------------------------------------------------
# Random cases
# --------------------------------------------------------------------------

def random_cases(rm: RobotModel, n: int, seed: int) -> list[dict]:
    """n reproducible random cases in Pinocchio's joint order.

    q: joints uniform within finite URDF limits, else in [-pi, pi]; base
       position uniform in [-1, 1]^3, orientation a uniformly random unit
       quaternion (either sign of qw).
    v, a ~ N(0, 1) per entry (m/s, rad/s, m/s^2, rad/s^2).
    tau = rnea(q, v, a_tau) with an independent a_tau ~ N(0, 1): a generic
       generalized force whose forward dynamics has O(1) entries on every dof,
       so that light links (e.g. the Minitaur's 50 g lower legs) do not give
       ddq entries orders of magnitude apart, which an inf-norm relative error
       would compare poorly.
    """
    pin = _pin()
    rng = np.random.default_rng(seed)
    slots = rm.joints
    cases = []
    for _ in range(n):
        q = []
        if rm.floating_base:
            quat = rng.standard_normal(4)
            quat /= np.linalg.norm(quat)
            q += rng.uniform(-1.0, 1.0, 3).tolist() + quat.tolist()
        for s in slots:
            rng_lim = rm.urdf_joints[s.name].finite_range() if s.name in rm.urdf_joints else None
            lo, hi = rng_lim if rng_lim is not None else (-math.pi, math.pi)
            q.append(float(rng.uniform(lo, hi)))
        v = rng.standard_normal(rm.nv)
        a = rng.standard_normal(rm.nv)
        a_tau = rng.standard_normal(rm.nv)
        # Slots are in Pinocchio order, so contract v order == Pinocchio v order.
        qp = to_pinocchio_q(rm, slots, q)
        tau = pin.rnea(rm.model, rm.data, qp, v, a_tau).copy()
        cases.append({"q": q, "v": v.tolist(), "a": a.tolist(), "tau": tau.tolist()})
    return cases


def make_input(rm: RobotModel, urdf_field: str, cases: list[dict]) -> dict:
    """A dyn_eval input document (Pinocchio joint order, every URDF link)."""
    return {
        "urdf": urdf_field,
        "floating_base": rm.floating_base,
        "joint_names": rm.joint_names,
        "frames": list(rm.links),
        "cases": cases,
    }


# --------------------------------------------------------------------------
# Comparison
# --------------------------------------------------------------------------

def rel_err(a, b) -> float:
    """||a - b||_inf / max(||b||_inf, 1e-12); b is the reference (Pinocchio).

    Shape mismatches and non-finite values count as an infinite error.
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.shape != b.shape:
        return math.inf
    if a.size == 0:
        return 0.0
    diff = np.abs(a - b)
    if not np.all(np.isfinite(diff)):
        return math.inf
    return float(diff.max() / max(float(np.abs(b).max()), 1e-12))


def case_errors(got: dict, ref: dict) -> dict[str, float]:
    """Relative error of every quantity of one case (see rel_err)."""
    errs = {}
    for key in ("tau", "nle", "M", "ddq", "com", "total_mass"):
        if key == "ddq" and ref.get("ddq") is None:
            # Forward dynamics is undefined on a singular mass matrix (corpus fixtures
            # store null there): only require the tool not to claim a value.
            errs[key] = 0.0 if got.get("ddq") is None else math.inf
            continue
        errs[key] = rel_err(got[key], ref[key]) if key in got and got[key] is not None else math.inf
    gf, rf = got.get("frames", {}), ref.get("frames", {})
    if set(gf) != set(rf):
        errs["frames.translation"] = errs["frames.rotation"] = math.inf
    else:
        names = sorted(rf)
        for part in ("translation", "rotation"):
            try:
                a = [gf[n][part] for n in names]
            except (KeyError, TypeError):
                errs[f"frames.{part}"] = math.inf
                continue
            b = [rf[n][part] for n in names]
            errs[f"frames.{part}"] = rel_err(a, b)
    return errs


# --------------------------------------------------------------------------
# JSON output: full precision, numeric arrays kept on one line
# --------------------------------------------------------------------------

def _is_flat(x) -> bool:
    return isinstance(x, list) and all(not isinstance(e, (list, dict)) for e in x)


def _is_matrix(x) -> bool:
    return isinstance(x, list) and len(x) > 0 and all(_is_flat(e) for e in x)


def dumps(obj, indent: int = 0) -> str:
    """JSON text: floats as repr (shortest exact round-trip), vectors on one
    line, matrices one row per line, objects indented. Output is standard JSON."""
    pad, pad1 = " " * indent, " " * (indent + 1)
    if isinstance(obj, dict):
        if not obj:
            return "{}"
        items = [f"{pad1}{json.dumps(k)}: {dumps(v, indent + 1)}" for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if _is_flat(obj):
        return "[" + ", ".join(json.dumps(e) for e in obj) + "]"
    if _is_matrix(obj):
        rows = [pad1 + dumps(r) for r in obj]
        return "[\n" + ",\n".join(rows) + "\n" + pad + "]"
    if isinstance(obj, list):
        items = [pad1 + dumps(e, indent + 1) for e in obj]
        return "[\n" + ",\n".join(items) + "\n" + pad + "]"
    if isinstance(obj, float) and not math.isfinite(obj):
        raise ValueError("non-finite float in output")
    return json.dumps(obj)

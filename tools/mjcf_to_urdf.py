#!/usr/bin/env python3
"""Convert Gymnasium's MuJoCo locomotion models (MJCF) into URDF + a JSON sidecar.

Usage (from the repository root):

    python tools/mjcf_to_urdf.py [--src DIR] [--out assets/mujoco]

The MJCF files are compiled with the `mujoco` Python package, so every number
written (masses, inertias, frames, axes, ranges) is MuJoCo's *compiled* value:
`inertiafromgeom`, geom densities, `settotalmass`, `fromto`, `axisangle`, degree to
radian conversion and axis normalisation have all been applied by MuJoCo itself.

Conversion rules (see assets/mujoco/README.md for the full discussion):

* Every MuJoCo body becomes a URDF link of the same name whose frame *is* the MuJoCo
  body frame.  Unnamed bodies are named `<first joint>_body` (or `body<id>`).
* The joints of a body are reproduced in MJCF definition order.  Hinge k gets its
  URDF origin at its anchor (`jnt_pos`); the displacement back from the anchor is
  carried into the next joint's origin, and a final fixed joint `<body>__fixed`
  brings the chain back onto the MuJoCo body frame when it is needed.  Intermediate
  links are massless and named `<body>__<joint>`.
* `ref` (qpos0) is folded into the joint origin so that the URDF joint value equals
  MuJoCo's qpos (slide: origin shifted by -ref*axis; hinge: origin rotated by -ref).
* Free root (ant, humanoid): the torso is the URDF root link; the free joint is left
  to the loader.  Planar root (walker2d, hopper, half_cheetah): link `world`, then
  prismatic rootx -> prismatic rootz -> revolute rooty -> torso.
* Inertials are MuJoCo's body_mass / body_ipos / full inertia tensor (body_inertia
  rotated by body_iquat) in the body frame.
* Each geom becomes a <collision> and a <visual> named after the geom.
* Limits: radians / metres from jnt_range; effort = |gear| * max|ctrlrange|; joints
  without a range get <limit effort=.. velocity=..> with no lower/upper.

Numbers are written with Python's repr(), the shortest decimal string that
round-trips to the identical float64 (never more than 17 significant digits).
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import json
import math
import os
import shutil
import sys
import tempfile
from xml.sax.saxutils import quoteattr

import mujoco
import numpy as np

# (output name, source file, Gymnasium env id, Gymnasium default frame_skip)
MODELS = [
    ("ant", "ant.xml", "Ant-v5", 5),
    ("walker2d", "walker2d_v5.xml", "Walker2d-v5", 4),
    ("hopper", "hopper.xml", "Hopper-v5", 4),
    ("half_cheetah", "half_cheetah.xml", "HalfCheetah-v5", 5),
    ("humanoid", "humanoid.xml", "Humanoid-v5", 5),
]
LICENSE_FILE = "LICENSE-gymnasium.txt"

# MuJoCo has no joint velocity limit; URDF requires the attribute.  This value is
# a placeholder that the Centaur loaders must not read as a physical constraint.
VELOCITY_PLACEHOLDER = 1000.0

JNT_NAMES = {
    mujoco.mjtJoint.mjJNT_FREE: "free",
    mujoco.mjtJoint.mjJNT_BALL: "ball",
    mujoco.mjtJoint.mjJNT_SLIDE: "slide",
    mujoco.mjtJoint.mjJNT_HINGE: "hinge",
}
GEOM_NAMES = {
    mujoco.mjtGeom.mjGEOM_PLANE: "plane",
    mujoco.mjtGeom.mjGEOM_HFIELD: "hfield",
    mujoco.mjtGeom.mjGEOM_SPHERE: "sphere",
    mujoco.mjtGeom.mjGEOM_CAPSULE: "capsule",
    mujoco.mjtGeom.mjGEOM_ELLIPSOID: "ellipsoid",
    mujoco.mjtGeom.mjGEOM_CYLINDER: "cylinder",
    mujoco.mjtGeom.mjGEOM_BOX: "box",
    mujoco.mjtGeom.mjGEOM_MESH: "mesh",
}
INTEGRATOR_NAMES = {
    mujoco.mjtIntegrator.mjINT_EULER: "Euler",
    mujoco.mjtIntegrator.mjINT_RK4: "RK4",
    mujoco.mjtIntegrator.mjINT_IMPLICIT: "implicit",
    mujoco.mjtIntegrator.mjINT_IMPLICITFAST: "implicitfast",
}


# --------------------------------------------------------------------------- maths

def num(x) -> str:
    """Shortest round-trip decimal form of a float64 (negative zero printed as 0)."""
    x = float(x)
    if x == 0.0:
        return "0"
    if not math.isfinite(x):
        raise ValueError(f"non-finite number {x}")
    s = repr(x)
    if s.endswith(".0"):
        s = s[:-2]
    return s


def nums(v) -> str:
    return " ".join(num(x) for x in v)


def f32(x) -> float:
    """A float32 field (MuJoCo stores rgba as float) as the shortest decimal that
    round-trips in float32, e.g. 0.8 rather than 0.800000011920929."""
    return float(str(np.float32(x)))


def rgba_str(v) -> str:
    return " ".join(num(f32(x)) for x in v)


def quat_to_mat(q) -> np.ndarray:
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, np.asarray(q, dtype=float))
    return out.reshape(3, 3)


def axis_angle_mat(axis, angle: float) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_axisAngle2Quat(q, np.asarray(axis, dtype=float), float(angle))
    return quat_to_mat(q)


def rz(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def ry(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def rx(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rpy_to_mat(rpy) -> np.ndarray:
    """URDF convention: R = Rz(yaw) @ Ry(pitch) @ Rx(roll)."""
    r, p, y = rpy
    return rz(y) @ ry(p) @ rx(r)


def mat_to_rpy(R: np.ndarray) -> tuple[float, float, float]:
    """Inverse of rpy_to_mat, well conditioned also at pitch = +-90 degrees.

    yaw is read from the first column; then M = Rz(-yaw) R = Ry(pitch) Rx(roll),
    whose second row is (0, cos roll, -sin roll) and first column
    (cos pitch, 0, -sin pitch).  At gimbal lock the first column has no x/y part
    and yaw = atan2(0, 0) = 0, which is as valid as any other choice.
    """
    R = np.asarray(R, dtype=float)
    yaw = math.atan2(R[1, 0], R[0, 0])
    if abs(R[1, 0]) < 1e-300 and abs(R[0, 0]) < 1e-300:
        yaw = 0.0
    M = rz(-yaw) @ R
    roll = math.atan2(-M[1, 2], M[1, 1])
    pitch = math.atan2(-M[2, 0], M[0, 0])
    rpy = tuple(0.0 if v == 0.0 else v for v in (roll, pitch, yaw))
    err = np.abs(rpy_to_mat(rpy) - R).max()
    if err > 1e-14:
        raise AssertionError(f"rpy round trip error {err}")
    return rpy


class Tf:
    """Rigid transform x_parent = R x_child + t."""

    def __init__(self, R=None, t=None):
        self.R = np.eye(3) if R is None else np.array(R, dtype=float)
        self.t = np.zeros(3) if t is None else np.array(t, dtype=float)

    def __matmul__(self, other: "Tf") -> "Tf":
        return Tf(self.R @ other.R, self.R @ other.t + self.t)

    def is_identity(self) -> bool:
        return bool(np.all(self.R == np.eye(3)) and np.all(self.t == 0.0))


# --------------------------------------------------------------------------- model

def compile_model(path: str) -> mujoco.MjModel:
    """Compile an MJCF file.  MuJoCo writes MUJOCO_LOG.TXT into the working
    directory on warnings (half_cheetah's deprecated settotalmass), so compile
    from a throw-away directory."""
    path = os.path.abspath(path)
    old = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:
        os.chdir(tmp)
        try:
            return mujoco.MjModel.from_xml_path(path)
        finally:
            os.chdir(old)


def name_of(m, objtype, i) -> str:
    return mujoco.mj_id2name(m, objtype, i) or ""


def body_link_names(m) -> list[str]:
    names = []
    used = set()
    for b in range(m.nbody):
        n = name_of(m, mujoco.mjtObj.mjOBJ_BODY, b)
        if b == 0:
            n = "world"
        if not n:
            if m.body_jntnum[b] > 0:
                j = m.body_jntadr[b]
                n = f"{name_of(m, mujoco.mjtObj.mjOBJ_JOINT, j)}_body"
            else:
                n = f"body{b}"
        if n in used:
            n = f"{n}_{b}"
        used.add(n)
        names.append(n)
    return names


def geom_names(m) -> list[str]:
    out = []
    for g in range(m.ngeom):
        n = name_of(m, mujoco.mjtObj.mjOBJ_GEOM, g)
        out.append(n if n else f"geom{g}")
    return out


def root_kind(m) -> str:
    """'free' for a floating torso, 'planar' for the rootx/rootz/rooty chain."""
    tops = [b for b in range(1, m.nbody) if m.body_parentid[b] == 0]
    if len(tops) != 1:
        raise ValueError("expected exactly one body attached to the world")
    b = tops[0]
    if b != 1:
        raise ValueError("the torso is expected to be body 1")
    types = [int(m.jnt_type[j]) for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b])]
    if types == [mujoco.mjtJoint.mjJNT_FREE]:
        return "free"
    if types == [mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_SLIDE, mujoco.mjtJoint.mjJNT_HINGE]:
        j = m.body_jntadr[b]
        axes = [m.jnt_axis[j + k].tolist() for k in range(3)]
        if axes != [[1, 0, 0], [0, 0, 1], [0, 1, 0]]:
            raise ValueError(f"unexpected planar root axes {axes}")
        return "planar"
    raise ValueError(f"unsupported root joints {types}")


def actuator_effort(m) -> dict[int, float]:
    """joint id -> |gear| * max|ctrlrange| summed over the motors acting on it."""
    eff: dict[int, float] = {}
    for a in range(m.nu):
        if m.actuator_trntype[a] != mujoco.mjtTrn.mjTRN_JOINT:
            raise ValueError("only joint transmissions are supported")
        if not m.actuator_ctrllimited[a]:
            raise ValueError("unlimited ctrl: effort not defined")
        j = int(m.actuator_trnid[a, 0])
        e = abs(float(m.actuator_gear[a, 0])) * float(np.abs(m.actuator_ctrlrange[a]).max())
        if m.actuator_forcelimited[a]:
            e = min(e, float(np.abs(m.actuator_forcerange[a]).max()))
        eff[j] = eff.get(j, 0.0) + e
    return eff


# --------------------------------------------------------------------------- URDF

def origin_xml(tf: Tf, indent: str) -> str:
    rpy = mat_to_rpy(tf.R)
    return f'{indent}<origin xyz="{nums(tf.t)}" rpy="{nums(rpy)}"/>\n'


def geometry_xml(m, g: int, indent: str) -> str:
    t = int(m.geom_type[g])
    s = m.geom_size[g]
    if t == mujoco.mjtGeom.mjGEOM_SPHERE:
        return f'{indent}<geometry><sphere radius="{num(s[0])}"/></geometry>\n'
    if t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        # MuJoCo: radius size[0], half-length of the cylinder part size[1], axis = geom z.
        return f'{indent}<geometry><capsule radius="{num(s[0])}" length="{num(2.0 * s[1])}"/></geometry>\n'
    if t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return f'{indent}<geometry><cylinder radius="{num(s[0])}" length="{num(2.0 * s[1])}"/></geometry>\n'
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        return f'{indent}<geometry><box size="{nums(2.0 * s[:3])}"/></geometry>\n'
    # URDF has no ellipsoid, plane (on a moving body), height field; meshes would
    # need the mesh files.  None occurs in the five Gymnasium models.
    raise NotImplementedError(f"geom {g}: type {GEOM_NAMES.get(t, t)} has no URDF equivalent")


def body_inertia_tensor(m, b: int) -> np.ndarray:
    """Full inertia tensor about the CoM in the body frame: R diag(I) R^T with R from
    body_iquat.  Off-diagonal entries below 1e-15 x the largest moment are pure
    rounding residue of the rotation (a few ulps) and are written as exact zeros."""
    R = quat_to_mat(m.body_iquat[b])
    I = R @ np.diag(m.body_inertia[b]) @ R.T
    I = 0.5 * (I + I.T)
    tiny = 1e-15 * float(np.max(m.body_inertia[b]))
    for i in range(3):
        for k in range(3):
            if i != k and abs(I[i, k]) < tiny:
                I[i, k] = 0.0
    return I


def inertial_xml(m, b: int, indent: str) -> str:
    mass = float(m.body_mass[b])
    I = body_inertia_tensor(m, b)
    i2 = indent + "  "
    return (
        f"{indent}<inertial>\n"
        f'{i2}<origin xyz="{nums(m.body_ipos[b])}" rpy="0 0 0"/>\n'
        f'{i2}<mass value="{num(mass)}"/>\n'
        f'{i2}<inertia ixx="{num(I[0, 0])}" ixy="{num(I[0, 1])}" ixz="{num(I[0, 2])}" '
        f'iyy="{num(I[1, 1])}" iyz="{num(I[1, 2])}" izz="{num(I[2, 2])}"/>\n'
        f"{indent}</inertial>\n"
    )


def link_xml(m, b, link, gnames, body_geoms) -> str:
    out = [f"  <link name={quoteattr(link)}>\n"]
    if b is not None and m.body_mass[b] > 0:
        out.append(inertial_xml(m, b, "    "))
    if b is not None:
        for g in body_geoms.get(b, []):
            tf = Tf(quat_to_mat(m.geom_quat[g]), m.geom_pos[g])
            geo = geometry_xml(m, g, "      ")
            out.append(f"    <visual name={quoteattr(gnames[g])}>\n")
            out.append(origin_xml(tf, "      "))
            out.append(geo)
            out.append(f'      <material name={quoteattr(gnames[g] + "_material")}>'
                       f'<color rgba="{rgba_str(m.geom_rgba[g])}"/></material>\n')
            out.append("    </visual>\n")
            out.append(f"    <collision name={quoteattr(gnames[g])}>\n")
            out.append(origin_xml(tf, "      "))
            out.append(geo)
            out.append("    </collision>\n")
    out.append("  </link>\n")
    return "".join(out)


def joint_xml(name, jtype, parent, child, tf, axis=None, limit=None, dynamics=None) -> str:
    out = [f"  <joint name={quoteattr(name)} type={quoteattr(jtype)}>\n"]
    out.append(origin_xml(tf, "    "))
    out.append(f"    <parent link={quoteattr(parent)}/>\n")
    out.append(f"    <child link={quoteattr(child)}/>\n")
    if axis is not None:
        out.append(f'    <axis xyz="{nums(axis)}"/>\n')
    if limit is not None:
        lower, upper, effort = limit
        lu = "" if lower is None else f'lower="{num(lower)}" upper="{num(upper)}" '
        out.append(f'    <limit {lu}effort="{num(effort)}" velocity="{num(VELOCITY_PLACEHOLDER)}"/>\n')
    if dynamics is not None:
        damping, friction = dynamics
        fr = f' friction="{num(friction)}"' if friction != 0.0 else ""
        out.append(f'    <dynamics damping="{num(damping)}"{fr}/>\n')
    out.append("  </joint>\n")
    return "".join(out)


def build_urdf(m, robot: str, source: str, sha: str):
    """Return (urdf text, structure dict used for the sidecar)."""
    kind = root_kind(m)
    links = body_link_names(m)
    gnames = geom_names(m)
    effort = actuator_effort(m)
    body_geoms: dict[int, list[int]] = {}
    for g in range(m.ngeom):
        body_geoms.setdefault(int(m.geom_bodyid[g]), []).append(g)
    for g in body_geoms.get(0, []):
        if m.geom_type[g] != mujoco.mjtGeom.mjGEOM_PLANE:
            raise NotImplementedError("only planes may be attached to the world body")

    parts = [
        '<?xml version="1.0"?>\n',
        f"<!-- Generated by tools/mjcf_to_urdf.py from {source} (gymnasium 1.4.0, MIT licence;\n"
        f"     sha256 {sha}), compiled with mujoco {mujoco.__version__}. Do not edit by hand.\n"
        f"     Joint values equal MuJoCo qpos. Armature, joint springs, contact parameters,\n"
        f"     actuators and the initial state are in {robot}.mujoco.json. -->\n",
        f"<robot name={quoteattr(robot)} version=\"1.1\">\n",
    ]
    urdf_joint_of: dict[int, str] = {}   # MuJoCo joint id -> URDF joint name
    intermediate: list[str] = []

    if kind == "planar":
        parts.append('  <link name="world"/>\n')

    for b in range(1, m.nbody):
        link = links[b]
        parent = links[m.body_parentid[b]]
        jadr, jnum = int(m.body_jntadr[b]), int(m.body_jntnum[b])
        if kind == "free" and b == 1:
            # Root link: the loader adds the free-flyer; body pos/quat is the initial pose.
            parts.append(link_xml(m, b, link, gnames, body_geoms))
            urdf_joint_of[jadr] = None
            continue
        pending = Tf(quat_to_mat(m.body_quat[b]), m.body_pos[b])
        prev = parent
        pieces = []
        for k in range(jnum):
            j = jadr + k
            jname = name_of(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            jt = int(m.jnt_type[j])
            axis = np.array(m.jnt_axis[j], dtype=float)
            ref = float(m.qpos0[m.jnt_qposadr[j]])
            if jt == mujoco.mjtJoint.mjJNT_HINGE:
                anchor = np.array(m.jnt_pos[j], dtype=float)
                origin = pending @ Tf(None, anchor)
                if ref != 0.0:
                    origin = origin @ Tf(axis_angle_mat(axis, -ref), None)
                after = Tf(None, -anchor)
                utype = "revolute"
            elif jt == mujoco.mjtJoint.mjJNT_SLIDE:
                # A slide's anchor does not affect kinematics; the pending translation
                # commutes with the slide and is pushed past it.
                origin = Tf(pending.R, None)
                after = Tf(None, pending.R.T @ pending.t - ref * axis)
                utype = "prismatic"
            else:
                raise NotImplementedError(f"joint {jname}: {JNT_NAMES.get(jt, jt)} joint below the root")
            pending = after
            last = k == jnum - 1
            child = link if (last and pending.is_identity()) else f"{link}__{jname}"
            if child != link:
                intermediate.append(child)
            if m.jnt_limited[j]:
                lim = (float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1]), effort.get(j, 0.0))
            else:
                lim = (None, None, effort.get(j, 0.0))
            dof = int(m.jnt_dofadr[j])
            dyn = (float(m.dof_damping[dof]), float(m.dof_frictionloss[dof]))
            pieces.append(("joint", jname, utype, prev, child, origin, axis, lim, dyn))
            urdf_joint_of[j] = jname
            prev = child
        if jnum == 0 or not pending.is_identity():
            pieces.append(("fixed", f"{link}__fixed", prev, link, pending))
        # Emit: intermediate links first (massless, no geometry), then the body link.
        for p in pieces:
            if p[0] == "joint":
                _, jname, utype, par, child, origin, axis, lim, dyn = p
                if child != link:
                    parts.append(f"  <link name={quoteattr(child)}/>\n")
                parts.append(joint_xml(jname, utype, par, child, origin, axis, lim, dyn))
            else:
                _, fname, par, child, origin = p
                parts.append(joint_xml(fname, "fixed", par, child, origin))
        parts.append(link_xml(m, b, link, gnames, body_geoms))

    parts.append("</robot>\n")
    info = {
        "kind": kind,
        "links": links,
        "geom_names": gnames,
        "urdf_joint_of": urdf_joint_of,
        "intermediate_links": intermediate,
    }
    return "".join(parts), info


# --------------------------------------------------------------------------- sidecar

def enum_name(enum_cls, value) -> str:
    try:
        return enum_cls(int(value)).name
    except ValueError:
        return str(int(value))


def contact_pairs(m, gnames) -> list[list[str]]:
    """Geom pairs that MuJoCo's collision filter lets through (no <pair>/<exclude>
    in these models): contype/conaffinity compatibility, different weld bodies, and
    (unless filterparent is disabled) no parent/child weld bodies except the world."""
    assert m.npair == 0 and m.nexclude == 0
    filterparent = not (m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    out = []
    for g1 in range(m.ngeom):
        for g2 in range(g1 + 1, m.ngeom):
            if not ((m.geom_contype[g1] & m.geom_conaffinity[g2]) or (m.geom_contype[g2] & m.geom_conaffinity[g1])):
                continue
            w1 = int(m.body_weldid[m.geom_bodyid[g1]])
            w2 = int(m.body_weldid[m.geom_bodyid[g2]])
            if w1 == w2:
                continue
            p1 = int(m.body_weldid[m.body_parentid[w1]])
            p2 = int(m.body_weldid[m.body_parentid[w2]])
            if filterparent and w1 != 0 and w2 != 0 and (w1 == p2 or w2 == p1):
                continue
            out.append([gnames[g1], gnames[g2]])
    return out


def build_sidecar(m, robot, source, sha, env_id, frame_skip, info, xml_text):
    links = info["links"]
    gnames = info["geom_names"]
    jnames = [name_of(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(m.njnt)]

    joints = []
    for j in range(m.njnt):
        jt = int(m.jnt_type[j])
        qa, da = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
        nq = {0: 7, 1: 4}.get(jt, 1)
        nv = {0: 6, 1: 3}.get(jt, 1)
        dof_vals = lambda arr: [float(x) for x in arr[da:da + nv]]  # noqa: E731
        one = lambda vals: vals[0] if len(set(vals)) == 1 else vals  # noqa: E731
        joints.append({
            "name": jnames[j],
            "type": JNT_NAMES[jt],
            "urdf_joint": info["urdf_joint_of"].get(j),
            "body": links[m.jnt_bodyid[j]],
            "qposadr": qa,
            "dofadr": da,
            "nq": nq,
            "nv": nv,
            "axis": [float(x) for x in m.jnt_axis[j]],
            "anchor": [float(x) for x in m.jnt_pos[j]],
            "ref": [float(x) for x in m.qpos0[qa:qa + nq]] if nq > 1 else float(m.qpos0[qa]),
            "armature": one(dof_vals(m.dof_armature)),
            "damping": one(dof_vals(m.dof_damping)),
            "frictionloss": one(dof_vals(m.dof_frictionloss)),
            "stiffness": float(m.jnt_stiffness[j]),
            "springref": [float(x) for x in m.qpos_spring[qa:qa + nq]] if nq > 1 else float(m.qpos_spring[qa]),
            "limited": bool(m.jnt_limited[j]),
            "range": [float(m.jnt_range[j, 0]), float(m.jnt_range[j, 1])] if m.jnt_limited[j] else None,
            "margin": float(m.jnt_margin[j]),
            "solref_limit": [float(x) for x in m.jnt_solref[j]],
            "solimp_limit": [float(x) for x in m.jnt_solimp[j]],
        })

    actuators = []
    for a in range(m.nu):
        j = int(m.actuator_trnid[a, 0])
        actuators.append({
            "name": name_of(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a) or None,
            "joint": jnames[j],
            "gear": float(m.actuator_gear[a, 0]),
            "ctrlrange": [float(x) for x in m.actuator_ctrlrange[a]],
            "ctrllimited": bool(m.actuator_ctrllimited[a]),
            "forcelimited": bool(m.actuator_forcelimited[a]),
            "forcerange": [float(x) for x in m.actuator_forcerange[a]],
            "gaintype": enum_name(mujoco.mjtGain, m.actuator_gaintype[a]),
            "biastype": enum_name(mujoco.mjtBias, m.actuator_biastype[a]),
            "dyntype": enum_name(mujoco.mjtDyn, m.actuator_dyntype[a]),
            "gain": float(m.actuator_gainprm[a, 0]),
        })

    def geom_entry(g):
        return {
            "name": gnames[g],
            "mujoco_name": name_of(m, mujoco.mjtObj.mjOBJ_GEOM, g) or None,
            "link": links[m.geom_bodyid[g]],
            "type": GEOM_NAMES[int(m.geom_type[g])],
            "size": [float(x) for x in m.geom_size[g]],
            "pos": [float(x) for x in m.geom_pos[g]],
            "quat": [float(x) for x in m.geom_quat[g]],
            "friction": [float(x) for x in m.geom_friction[g]],
            "contype": int(m.geom_contype[g]),
            "conaffinity": int(m.geom_conaffinity[g]),
            "condim": int(m.geom_condim[g]),
            "margin": float(m.geom_margin[g]),
            "gap": float(m.geom_gap[g]),
            "solref": [float(x) for x in m.geom_solref[g]],
            "solimp": [float(x) for x in m.geom_solimp[g]],
            "solmix": float(m.geom_solmix[g]),
            "priority": int(m.geom_priority[g]),
            "rgba": [f32(x) for x in m.geom_rgba[g]],
        }

    geoms = [geom_entry(g) for g in range(m.ngeom) if m.geom_bodyid[g] != 0]
    world_geoms = [geom_entry(g) for g in range(m.ngeom) if m.geom_bodyid[g] == 0]

    bodies = []
    for b in range(1, m.nbody):
        I = body_inertia_tensor(m, b)
        bodies.append({
            "name": links[b],
            "mujoco_id": b,
            "mujoco_name": name_of(m, mujoco.mjtObj.mjOBJ_BODY, b) or None,
            "parent": links[m.body_parentid[b]],
            "mass": float(m.body_mass[b]),
            "com": [float(x) for x in m.body_ipos[b]],
            "inertia": [[float(x) for x in row] for row in I],
            "pos": [float(x) for x in m.body_pos[b]],
            "quat": [float(x) for x in m.body_quat[b]],
        })

    tendons = []
    for t in range(m.ntendon):
        adr, num_ = int(m.tendon_adr[t]), int(m.tendon_num[t])
        wraps = []
        for w in range(adr, adr + num_):
            if m.wrap_type[w] != mujoco.mjtWrap.mjWRAP_JOINT:
                raise NotImplementedError("only fixed (joint) tendons are supported")
            wraps.append({"joint": jnames[m.wrap_objid[w]], "coef": float(m.wrap_prm[w])})
        used_by_actuator = any(
            m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_TENDON and m.actuator_trnid[a, 0] == t for a in range(m.nu))
        inert = (m.tendon_stiffness[t] == 0 and m.tendon_damping[t] == 0 and not m.tendon_limited[t]
                 and m.tendon_frictionloss[t] == 0 and m.tendon_armature[t] == 0 and not used_by_actuator)
        tendons.append({
            "name": name_of(m, mujoco.mjtObj.mjOBJ_TENDON, t),
            "type": "fixed",
            "joints": wraps,
            "stiffness": float(m.tendon_stiffness[t]),
            "damping": float(m.tendon_damping[t]),
            "frictionloss": float(m.tendon_frictionloss[t]),
            "armature": float(m.tendon_armature[t]),
            "limited": bool(m.tendon_limited[t]),
            "range": [float(x) for x in m.tendon_range[t]] if m.tendon_limited[t] else None,
            "lengthspring": [float(x) for x in m.tendon_lengthspring[t]],
            "used_by_actuator": bool(used_by_actuator),
            "has_effect": not inert,
            "note": ("no stiffness, damping, frictionloss, armature, limit or actuator: the tendon "
                     "exerts no force and does not change the dynamics (it only defines a length "
                     "that nothing reads); a simulator may ignore it") if inert else
                    "this tendon applies forces and must be modelled",
        })

    custom = {}
    for i in range(m.nnumeric):
        adr, sz = int(m.numeric_adr[i]), int(m.numeric_size[i])
        custom[name_of(m, mujoco.mjtObj.mjOBJ_NUMERIC, i)] = [float(x) for x in m.numeric_data[adr:adr + sz]]

    kind = info["kind"]
    sidecar = {
        "source": source,
        "source_sha256": sha,
        "urdf": f"{robot}.urdf",
        "generator": f"tools/mjcf_to_urdf.py, mujoco {mujoco.__version__}",
        "gymnasium": {"env_id": env_id, "frame_skip": frame_skip,
                      "control_dt": float(m.opt.timestep) * frame_skip},
        "root": ({"kind": "free", "link": links[1],
                  "note": "URDF root link is the torso; add a free-flyer. MuJoCo free-joint qpos is "
                          "[x y z qw qx qy qz] (world position of the torso frame, orientation "
                          "world<-torso); qvel is [linear velocity of the torso origin in the WORLD "
                          "frame, angular velocity in the TORSO frame]."}
                 if kind == "free" else
                 {"kind": "planar", "link": "world",
                  "joints": ["rootx", "rootz", "rooty"],
                  "note": "fixed-base URDF; the first three joints (prismatic x, prismatic z, "
                          "revolute y) are the planar root and their values equal qpos[0:3]."}),
        "timestep": float(m.opt.timestep),
        "integrator": INTEGRATOR_NAMES.get(int(m.opt.integrator), str(int(m.opt.integrator))),
        "gravity": [float(x) for x in m.opt.gravity],
        "option": {
            "solver": enum_name(mujoco.mjtSolver, m.opt.solver),
            "iterations": int(m.opt.iterations),
            "tolerance": float(m.opt.tolerance),
            "ls_iterations": int(m.opt.ls_iterations),
            "cone": enum_name(mujoco.mjtCone, m.opt.cone),
            "jacobian": enum_name(mujoco.mjtJacobian, m.opt.jacobian),
            "impratio": float(m.opt.impratio),
            "noslip_iterations": int(m.opt.noslip_iterations),
            "disableflags": int(m.opt.disableflags),
            "enableflags": int(m.opt.enableflags),
            "filterparent": not bool(m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT),
            "o_margin": float(m.opt.o_margin),
            "density": float(m.opt.density),
            "viscosity": float(m.opt.viscosity),
            "wind": [float(x) for x in m.opt.wind],
        },
        "total_mass": float(mujoco.mj_getTotalmass(m)),
        "nq": int(m.nq),
        "nv": int(m.nv),
        "nu": int(m.nu),
        "init_qpos": [float(x) for x in m.qpos0],
        "init_qvel": [0.0] * int(m.nv),
        "init_note": "Gymnasium's init_qpos/init_qvel are MuJoCo's qpos0 and zeros "
                     "(MujocoEnv copies data.qpos/qvel right after loading).",
        "joints": joints,
        "actuators": actuators,
        "geoms": geoms,
        "world_geoms": world_geoms,
        "contact_pairs": contact_pairs(m, gnames),
        "contact_pairs_note": "geom pairs MuJoCo may collide (contype/conaffinity, weld-body and "
                              "parent-child filtering, 'world' geoms included); all other pairs never "
                              "generate contacts. MuJoCo combines friction by element-wise max, "
                              "condim by max, solref/solimp by solmix weighting (equal here).",
        "bodies": bodies,
        "intermediate_links": info["intermediate_links"],
        "tendons": tendons,
    }
    if custom:
        sidecar["custom_numeric"] = custom
        sidecar["custom_numeric_note"] = ("<custom><numeric> entries of the XML; Gymnasium does not "
                                          "read them (its init_qpos is qpos0).")
    return sidecar


# --------------------------------------------------------------------------- main

def clean_json(x):
    """Recursively turn -0.0 into 0.0 (cosmetic; MuJoCo's quaternions contain -0)."""
    if isinstance(x, float):
        return x + 0.0
    if isinstance(x, list):
        return [clean_json(v) for v in x]
    if isinstance(x, dict):
        return {k: clean_json(v) for k, v in x.items()}
    return x


def sha256_file(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        h.update(f.read())
    return h.hexdigest()


def main(argv=None) -> int:
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.dirname(here)
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--src", default=None,
                    help="folder with the MJCF sources (default: assets/mujoco if it holds them, "
                         "else /work/shared/reference-robots/mujoco)")
    ap.add_argument("--out", default=os.path.join(repo, "assets", "mujoco"))
    args = ap.parse_args(argv)

    src = args.src
    if src is None:
        cand = os.path.join(repo, "assets", "mujoco")
        src = cand if all(os.path.exists(os.path.join(cand, f)) for _, f, _, _ in MODELS) \
            else "/work/shared/reference-robots/mujoco"
    os.makedirs(args.out, exist_ok=True)

    for robot, source, env_id, frame_skip in MODELS:
        spath = os.path.join(src, source)
        dst = os.path.join(args.out, source)
        if os.path.abspath(spath) != os.path.abspath(dst):
            shutil.copyfile(spath, dst)
        sha = sha256_file(dst)
        m = compile_model(dst)
        urdf, info = build_urdf(m, robot, source, sha)
        with open(dst, encoding="utf-8") as f:
            xml_text = f.read()
        side = build_sidecar(m, robot, source, sha, env_id, frame_skip, info, xml_text)
        with open(os.path.join(args.out, f"{robot}.urdf"), "w", encoding="utf-8") as f:
            f.write(urdf)
        with open(os.path.join(args.out, f"{robot}.mujoco.json"), "w", encoding="utf-8") as f:
            json.dump(clean_json(side), f, indent=1)
            f.write("\n")
        print(f"{robot:13s} <- {source:17s} nq={m.nq:2d} nv={m.nv:2d} nu={m.nu:2d} "
              f"bodies={m.nbody - 1:2d} intermediate links={len(info['intermediate_links']):2d} "
              f"mass={side['total_mass']:.6f}")

    lic_src = os.path.join(src, LICENSE_FILE)
    lic_dst = os.path.join(args.out, LICENSE_FILE)
    if os.path.exists(lic_src) and os.path.abspath(lic_src) != os.path.abspath(lic_dst):
        shutil.copyfile(lic_src, lic_dst)
    return 0


if __name__ == "__main__":
    sys.exit(main())

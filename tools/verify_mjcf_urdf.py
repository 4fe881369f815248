#!/usr/bin/env python3
"""Check the generated URDFs in assets/mujoco against MuJoCo, numerically.

Usage (from the repository root; needs `mujoco` and `pin` (Pinocchio)):

    python tools/verify_mjcf_urdf.py [--configs 50] [--seed 0] [--dir assets/mujoco]

For every model the MJCF is compiled with MuJoCo and the URDF is loaded with
Pinocchio (a free-flyer is added for ant and humanoid).  Joints are mapped by name;
MuJoCo's free-joint quaternion (w,x,y,z) becomes Pinocchio's (x,y,z,w).  Over random
configurations (joint values uniform in their ranges, root positions/orientations
random) and random velocities it compares:

* masses: total, per body (URDF <inertial> vs body_mass) and per Pinocchio joint body
  (the links Pinocchio merges through fixed joints vs the MuJoCo bodies they carry);
* every MuJoCo body's world position and rotation vs the URDF link of the same name
  (Pinocchio frame placements), and its world CoM and world inertia tensor;
* every geom's world pose and size vs the URDF <collision> of the same name;
* the joint-space mass matrix: mj_fullM minus the armature diagonal vs crba;
* bias forces: qfrc_bias (gravity + Coriolis/centrifugal; MuJoCo keeps joint springs
  and damping in qfrc_passive, so they are not in it) vs nonLinearEffects.

Free-joint velocity conventions differ.  MuJoCo: v_mj = [linear velocity of the torso
origin in the WORLD frame, angular velocity in the TORSO frame, joint rates];
Pinocchio: v_pin = [linear velocity in the TORSO frame, angular in the TORSO frame,
joint rates].  So v_mj = T v_pin with T = blockdiag(R, I, P) (R = world<-torso
rotation, P the joint permutation).  The comparison is done in Pinocchio's
coordinates on the whole matrix, not only a block:
    M_pin   = T^T M_mj T
    nle_pin = T^T (qfrc_bias + M_mj Tdot v_pin),  Tdot v_pin = [R (w x v_b); 0; 0]
(the second term is the derivative of T: d/dt (R v_b) = R (w x v_b) + R dv_b/dt).

Relative error = max|a - b| / max|b| per quantity; the script exits non-zero if any
relative error exceeds --tol (default 1e-8).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pinocchio as pin

MODELS = [
    ("ant", "ant.xml"),
    ("walker2d", "walker2d_v5.xml"),
    ("hopper", "hopper.xml"),
    ("half_cheetah", "half_cheetah.xml"),
    ("humanoid", "humanoid.xml"),
]


def compile_model(path):
    old = os.getcwd()
    with tempfile.TemporaryDirectory() as tmp:  # keeps MUJOCO_LOG.TXT out of the tree
        os.chdir(tmp)
        try:
            return mujoco.MjModel.from_xml_path(os.path.abspath(os.path.join(old, path)))
        finally:
            os.chdir(old)


def rel(a, b):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(float(np.abs(b).max()), 1e-300)
    return float(np.abs(a - b).max()) / scale


def rpy_to_mat(rpy):
    return pin.rpy.rpyToMatrix(np.asarray(rpy, float))


def parse_origin(el):
    o = el.find("origin")
    if o is None:
        return pin.SE3.Identity()
    xyz = np.array([float(x) for x in o.get("xyz", "0 0 0").split()])
    rpy = np.array([float(x) for x in o.get("rpy", "0 0 0").split()])
    return pin.SE3(rpy_to_mat(rpy), xyz)


def parse_urdf(path):
    root = ET.parse(path).getroot()
    links = {}
    for ln in root.findall("link"):
        inert = ln.find("inertial")
        entry = {"mass": 0.0, "com": np.zeros(3), "I": np.zeros((3, 3)), "collision": {}, "visual": {}}
        if inert is not None:
            o = parse_origin(inert)
            i = inert.find("inertia")
            I = np.array([[float(i.get("ixx")), float(i.get("ixy")), float(i.get("ixz"))],
                          [float(i.get("ixy")), float(i.get("iyy")), float(i.get("iyz"))],
                          [float(i.get("ixz")), float(i.get("iyz")), float(i.get("izz"))]])
            entry.update(mass=float(inert.find("mass").get("value")), com=o.translation,
                         I=o.rotation @ I @ o.rotation.T)
        for kind in ("collision", "visual"):
            for c in ln.findall(kind):
                g = c.find("geometry")[0]
                entry[kind][c.get("name")] = (parse_origin(c), g.tag, dict(g.attrib))
        links[ln.get("name")] = entry
    joints = {j.get("name"): j for j in root.findall("joint")}
    return links, joints


def geom_urdf_size(m, g):
    t, s = int(m.geom_type[g]), m.geom_size[g]
    if t == mujoco.mjtGeom.mjGEOM_SPHERE:
        return "sphere", {"radius": s[0]}
    if t == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return "capsule", {"radius": s[0], "length": 2 * s[1]}
    if t == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return "cylinder", {"radius": s[0], "length": 2 * s[1]}
    if t == mujoco.mjtGeom.mjGEOM_BOX:
        return "box", {"size": 2 * s[:3]}
    raise NotImplementedError(t)


def link_name_map(m):
    """MuJoCo body id -> URDF link name (same rule as the converter)."""
    out = {}
    used = set()
    for b in range(m.nbody):
        n = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or ""
        if b == 0:
            n = "world"
        if not n:
            if m.body_jntnum[b] > 0:
                n = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.body_jntadr[b]) + "_body"
            else:
                n = f"body{b}"
        if n in used:
            n = f"{n}_{b}"
        used.add(n)
        out[b] = n
    return out


def check_model(robot, source, folder, nconf, rng, tol):
    m = compile_model(os.path.join(folder, source))
    d = mujoco.MjData(m)
    urdf_path = os.path.join(folder, f"{robot}.urdf")
    free = m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    model = pin.buildModelFromUrdf(urdf_path, pin.JointModelFreeFlyer()) if free \
        else pin.buildModelFromUrdf(urdf_path)
    model.gravity.linear = np.array(m.opt.gravity, float)
    data = model.createData()
    links, ujoints = parse_urdf(urdf_path)
    bodyname = link_name_map(m)
    gname = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}" for g in range(m.ngeom)]

    res = {"robot": robot, "nq": model.nq, "nv": model.nv, "mj_nq": m.nq, "mj_nv": m.nv,
           "urdf_links": len(links), "urdf_joints": len(ujoints),
           "pin_bodies": model.njoints, "fails": []}

    # ---- joint maps (MuJoCo qpos/dof index -> Pinocchio index)
    qmap, vmap = {}, {}
    for j in range(m.njnt):
        jt = m.jnt_type[j]
        if jt == mujoco.mjtJoint.mjJNT_FREE:
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        jid = model.getJointId(name)
        assert jid < model.njoints, f"{robot}: joint {name} missing in Pinocchio"
        assert model.joints[jid].nq == 1 and model.joints[jid].nv == 1, name
        qmap[int(m.jnt_qposadr[j])] = model.joints[jid].idx_q
        vmap[int(m.jnt_dofadr[j])] = model.joints[jid].idx_v
        # limits
        if m.jnt_limited[j]:
            lo, hi = model.lowerPositionLimit[model.joints[jid].idx_q], model.upperPositionLimit[model.joints[jid].idx_q]
            if abs(lo - m.jnt_range[j, 0]) > 1e-15 or abs(hi - m.jnt_range[j, 1]) > 1e-15:
                res["fails"].append(f"limit {name}")
    assert model.nq == m.nq and model.nv == m.nv, (model.nq, m.nq, model.nv, m.nv)

    def to_pin_q(qm):
        qp = np.zeros(model.nq)
        if free:
            qp[0:3] = qm[0:3]
            qp[3:6] = qm[4:7]
            qp[6] = qm[3]
        for a, b in qmap.items():
            qp[b] = qm[a]
        return qp

    def tmat(R):
        T = np.zeros((m.nv, model.nv))
        if free:
            T[0:3, 0:3] = R
            T[3:6, 3:6] = np.eye(3)
        for a, b in vmap.items():
            T[a, b] = 1.0
        return T

    # ---- masses
    pin_total = sum(model.inertias[i].mass for i in range(model.njoints))
    mj_total = mujoco.mj_getTotalmass(m)
    res["total_mass_mj"] = mj_total
    res["total_mass_pin"] = pin_total
    res["err_total_mass"] = abs(pin_total - mj_total) / mj_total
    body_mass_err = 0.0
    for b in range(1, m.nbody):
        body_mass_err = max(body_mass_err, abs(links[bodyname[b]]["mass"] - m.body_mass[b]) / m.body_mass[b])
    # massless intermediate links really are massless
    mj_links = set(bodyname[b] for b in range(m.nbody))
    extra_mass = sum(abs(v["mass"]) for k, v in links.items() if k not in mj_links)
    res["err_body_mass"] = max(body_mass_err, extra_mass)
    # Pinocchio per-joint-body mass vs the MuJoCo bodies it carries
    per_joint = np.zeros(model.njoints)
    for b in range(1, m.nbody):
        fid = model.getFrameId(bodyname[b], pin.BODY)
        per_joint[model.frames[fid].parentJoint] += m.body_mass[b]
    res["err_pin_body_mass"] = rel([model.inertias[i].mass for i in range(model.njoints)], per_joint)

    # ---- geometry counts
    mj_geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0]
    n_coll = sum(len(v["collision"]) for v in links.values())
    n_vis = sum(len(v["visual"]) for v in links.values())
    res["geoms"] = f"{len(mj_geoms)}/{n_coll}/{n_vis}"
    if not (len(mj_geoms) == n_coll == n_vis):
        res["fails"].append("geom count")
    size_err = 0.0
    for g in mj_geoms:
        ln = links[bodyname[m.geom_bodyid[g]]]
        for kind in ("collision", "visual"):
            _, tag, attrs = ln[kind][gname[g]]
            etag, esize = geom_urdf_size(m, g)
            if tag != etag:
                res["fails"].append(f"geom type {gname[g]}")
            for k, v in esize.items():
                got = np.array([float(x) for x in attrs[k].split()])
                size_err = max(size_err, rel(got, np.atleast_1d(v)))
    res["err_geom_size"] = size_err

    # ---- Pinocchio's own geometry parser (urdfdom + coal), if it accepts capsules
    try:
        gmodel = pin.buildGeomFromUrdf(model, urdf_path, pin.GeometryType.COLLISION)
        res["pin_geom_objects"] = len(gmodel.geometryObjects)
    except Exception as exc:  # pragma: no cover - informative only
        gmodel = None
        res["pin_geom_objects"] = f"failed: {exc}"

    # Pinocchio names the geometry objects "<link>_<k>" (k-th <collision> of the link in
    # document order); map them to MuJoCo geoms through the URDF collision names.
    pin_geom_of = {}
    for ln_name, ln in links.items():
        for k, cname in enumerate(ln["collision"]):
            pin_geom_of[f"{ln_name}_{k}"] = gname.index(cname)
    if gmodel is not None:
        gsize_err = 0.0
        for go in gmodel.geometryObjects:
            g = pin_geom_of.get(go.name)
            if g is None:
                continue
            geo, sz = go.geometry, m.geom_size[g]
            if isinstance(geo, pin.coal.Capsule) if hasattr(pin, "coal") else type(geo).__name__ == "Capsule":
                got, exp = [geo.radius, geo.halfLength], sz[:2]
            elif type(geo).__name__ == "Sphere":
                got, exp = [geo.radius], sz[:1]
            elif type(geo).__name__ == "Cylinder":
                got, exp = [geo.radius, geo.halfLength], sz[:2]
            elif type(geo).__name__ == "Box":
                got, exp = list(geo.halfSide), sz[:3]
            else:
                res["fails"].append(f"pin geom type {go.name}")
                continue
            gsize_err = max(gsize_err, rel(got, exp))
        res["err_geom_size"] = max(res["err_geom_size"], gsize_err)

    # ---- random configurations
    errs = {k: 0.0 for k in ("pos", "rot", "com", "inertia", "geom_pose", "pin_geom_pose", "M", "bias")}
    body_frames = {b: model.getFrameId(bodyname[b], pin.BODY) for b in range(1, m.nbody)}
    gdata = gmodel.createData() if gmodel is not None else None
    for c in range(nconf):
        qm = np.array(m.qpos0, float)
        if c > 0:
            for j in range(m.njnt):
                a = m.jnt_qposadr[j]
                jt = m.jnt_type[j]
                if jt == mujoco.mjtJoint.mjJNT_FREE:
                    qm[a:a + 3] = rng.normal(0.0, 1.0, 3)
                    qq = rng.normal(size=4)
                    qm[a + 3:a + 7] = qq / np.linalg.norm(qq)
                elif m.jnt_limited[j]:
                    qm[a] = rng.uniform(m.jnt_range[j, 0], m.jnt_range[j, 1])
                elif jt == mujoco.mjtJoint.mjJNT_HINGE:
                    qm[a] = rng.uniform(-np.pi, np.pi)
                else:
                    qm[a] = rng.uniform(-2.0, 2.0)
        vm = rng.normal(0.0, 2.0, m.nv) if c > 0 else np.zeros(m.nv)
        d.qpos[:] = qm
        d.qvel[:] = vm
        d.ctrl[:] = 0.0
        mujoco.mj_forward(m, d)

        qp = to_pin_q(qm)
        R0 = d.xmat[1].reshape(3, 3) if free else np.eye(3)
        T = tmat(R0)
        vp = np.linalg.lstsq(T, vm, rcond=None)[0]  # T is orthogonal-like: exact inverse
        assert np.abs(T @ vp - vm).max() < 1e-12
        pin.forwardKinematics(model, data, qp, vp)
        pin.updateFramePlacements(model, data)

        for b in range(1, m.nbody):
            oMf = data.oMf[body_frames[b]]
            errs["pos"] = max(errs["pos"], float(np.abs(oMf.translation - d.xpos[b]).max()))
            errs["rot"] = max(errs["rot"], float(np.abs(oMf.rotation - d.xmat[b].reshape(3, 3)).max()))
            ln = links[bodyname[b]]
            com_w = oMf.rotation @ ln["com"] + oMf.translation
            errs["com"] = max(errs["com"], float(np.abs(com_w - d.xipos[b]).max()))
            Rw = oMf.rotation
            I_w = Rw @ ln["I"] @ Rw.T
            Ri = d.ximat[b].reshape(3, 3)
            I_mj = Ri @ np.diag(m.body_inertia[b]) @ Ri.T
            errs["inertia"] = max(errs["inertia"], rel(I_w, I_mj))
        for g in mj_geoms:
            oMf = data.oMf[body_frames[m.geom_bodyid[g]]]
            org = links[bodyname[m.geom_bodyid[g]]]["collision"][gname[g]][0]
            oMg = oMf * org
            e = max(float(np.abs(oMg.translation - d.geom_xpos[g]).max()),
                    float(np.abs(oMg.rotation - d.geom_xmat[g].reshape(3, 3)).max()))
            errs["geom_pose"] = max(errs["geom_pose"], e)
        if gmodel is not None:
            pin.updateGeometryPlacements(model, data, gmodel, gdata)
            for k, go in enumerate(gmodel.geometryObjects):
                g = pin_geom_of.get(go.name)
                if g is None:
                    res["fails"].append(f"pin geom name {go.name}")
                    continue
                oMg = gdata.oMg[k]
                e = max(float(np.abs(oMg.translation - d.geom_xpos[g]).max()),
                        float(np.abs(oMg.rotation - d.geom_xmat[g].reshape(3, 3)).max()))
                errs["pin_geom_pose"] = max(errs["pin_geom_pose"], e)

        # mass matrix
        Mmj = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, Mmj)
        Mmj -= np.diag(m.dof_armature)
        pin.crba(model, data, qp)
        Mp = np.triu(data.M) + np.triu(data.M, 1).T
        errs["M"] = max(errs["M"], rel(Mp, T.T @ Mmj @ T))

        # bias forces
        nle = pin.nonLinearEffects(model, data, qp, vp)
        tdot_v = np.zeros(m.nv)
        if free:
            tdot_v[0:3] = R0 @ np.cross(vp[3:6], vp[0:3])
        expected = T.T @ (d.qfrc_bias + Mmj @ tdot_v)
        errs["bias"] = max(errs["bias"], rel(nle, expected))

    res.update({f"err_{k}": v for k, v in errs.items()})
    for k in ("err_total_mass", "err_body_mass", "err_pin_body_mass", "err_geom_size", "err_pos", "err_rot",
              "err_com", "err_inertia", "err_geom_pose", "err_pin_geom_pose", "err_M", "err_bias"):
        if res[k] > tol:
            res["fails"].append(f"{k}={res[k]:.3g}")
    return res


def main(argv=None):
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dir", default=os.path.join(os.path.dirname(here), "assets", "mujoco"))
    ap.add_argument("--configs", type=int, default=50, help="configurations per model (first one is qpos0)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--tol", type=float, default=1e-8)
    args = ap.parse_args(argv)
    rng = np.random.default_rng(args.seed)

    print(f"mujoco {mujoco.__version__}, pinocchio {pin.__version__}, {args.configs} configurations per model "
          f"(seed {args.seed}); errors: pos/rot/com/geom pose absolute [m or -], others relative")
    results = [check_model(r, s, args.dir, args.configs, rng, args.tol) for r, s in MODELS]

    cols = [("robot", "robot", "{}"), ("nq", "nq", "{}"), ("nv", "nv", "{}"),
            ("urdf_links", "URDF links", "{}"), ("pin_bodies", "pin njoints", "{}"),
            ("geoms", "geoms mj/coll/vis", "{}"), ("pin_geom_objects", "pin geoms", "{}"),
            ("total_mass_mj", "total mass kg", "{:.12g}"), ("err_total_mass", "mass", "{:.1e}"),
            ("err_body_mass", "body mass", "{:.1e}"), ("err_pin_body_mass", "pin body mass", "{:.1e}"),
            ("err_pos", "body pos", "{:.1e}"), ("err_rot", "body rot", "{:.1e}"),
            ("err_com", "CoM", "{:.1e}"), ("err_inertia", "inertia", "{:.1e}"),
            ("err_geom_size", "geom size", "{:.1e}"), ("err_geom_pose", "geom pose", "{:.1e}"),
            ("err_pin_geom_pose", "pin geom pose", "{:.1e}"),
            ("err_M", "M", "{:.1e}"), ("err_bias", "bias", "{:.1e}")]
    print("| " + " | ".join(c[1] for c in cols) + " | result |")
    print("|" + "---|" * (len(cols) + 1))
    ok = True
    for r in results:
        cells = [c[2].format(r[c[0]]) if not isinstance(r[c[0]], str) else r[c[0]] for c in cols]
        status = "ok" if not r["fails"] else "FAIL: " + ", ".join(r["fails"])
        ok &= not r["fails"]
        print("| " + " | ".join(cells) + f" | {status} |")
    print("all within tolerance" if ok else "SOME CHECKS FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

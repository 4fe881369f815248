#!/usr/bin/env python3
"""Side-by-side timing: Pinocchio (C++, bench_pinocchio.cpp) vs centaur-dynamics.

1. Builds bench_pinocchio.cpp once against the pip package's headers and
   libraries (cached under target/pinocchio-bench/, keyed by a hash of the
   source, the flags and the compiler version), and checks the build against
   the Python bindings on one random state (like --verify).
2. For each robot, runs Pinocchio and Centaur's `dyn_bench` alternately,
   A/B/A/B..., --rounds times each (the machine is shared and noisy); each run
   prints median ns per call, and the table shows the median over the runs.
3. Prints a Markdown table (one row per robot and algorithm, ratio =
   centaur / pinocchio, lower is better), or JSON with --json.

Both tools print {"fk", "jacobians", "rnea", "crba", "aba", "centroidal"}:
median nanoseconds per call.

Needs (see requirements.txt): the venv with `pin`, plus the header-only pip
packages cmeel-eigen (Eigen 3.4.1, matching libpinocchio) and
cmeel-urdfdom-headers, and g++.

Examples (from the repository root):
    /work/venv/py/bin/python tools/pinocchio/bench_side_by_side.py --pinocchio-only
    /work/venv/py/bin/python tools/pinocchio/bench_side_by_side.py --rounds 5 --json
    /work/venv/py/bin/python tools/pinocchio/bench_side_by_side.py \\
        --centaur-cmd "target/release/examples/dyn_bench"
"""

from __future__ import annotations

import argparse
import datetime as dt
import hashlib
import json
import os
import re
import shlex
import statistics
import subprocess
import sys
import sysconfig
from pathlib import Path

import pinref

KEYS = ("fk", "jacobians", "rnea", "crba", "aba", "centroidal")
SOURCE = Path(__file__).resolve().with_name("bench_pinocchio.cpp")
DEFAULT_CENTAUR_CMD = "cargo run --release -q -p centaur-dynamics --example dyn_bench --"
# Order of the table; name -> (URDF relative to the repo root, floating base).
BENCH_ROBOTS = ["solo12", "minitaur", "minitaur_angles", "minitaur_revolute", "talos_reduced", "ur5_robot"]
# Pinocchio parametrises a continuous joint by (cos θ, sin θ) (nq 2), so its algorithms
# skip the sin/cos that an angle parametrisation evaluates. The Minitaur's 8 motor joints
# are continuous, hence three Minitaur rows:
# - "minitaur": both tools take (cos θ, sin θ) for them (Centaur with --continuous-cos-sin,
#   nq 31 on both sides);
# - "minitaur_angles": the same URDF, Centaur with its default angles (nq 23) against
#   Pinocchio's (cos θ, sin θ) (nq 31): not like for like, Centaur evaluates 8 more sin/cos;
# - "minitaur_revolute": the continuous joints declared revolute (limits ±π), both tools
#   take angles (nq 23). Written into the build directory at run time.
DERIVED = {"minitaur_revolute": "minitaur"}
SAME_URDF = {"minitaur_angles": "minitaur"}
CENTAUR_FLAGS = {"minitaur": ["--continuous-cos-sin"]}

# Compile definitions exported by Pinocchio's CMake targets (pinocchio_headers,
# pinocchio_parsers), minus PINOCCHIO_ENABLE_TEMPLATE_INSTANTIATION (we want the
# algorithms compiled here with -march=native, not the library's baseline copies).
PIN_DEFINES = [
    "-DBOOST_MPL_LIMIT_LIST_SIZE=30",
    "-DBOOST_MPL_LIMIT_VECTOR_SIZE=30",
    "-DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS",
    "-DBOOST_FUSION_INVOKE_MAX_ARITY=12",
    "-DPINOCCHIO_WITH_URDFDOM",
]
# Keep Eigen's object layout and heap allocator identical to libpinocchio's
# (built for baseline x86-64): see the header comment of bench_pinocchio.cpp.
ABI_DEFINES = ["-DEIGEN_MAX_ALIGN_BYTES=16", "-DEIGEN_MALLOC_ALREADY_ALIGNED=1"]
OPT_FLAGS = ["-O3", "-march=native", "-DNDEBUG", "-std=c++17"]


def cmeel_prefix(arg: str | None) -> Path:
    """The cmeel.prefix of the pip packages (pin, libpinocchio, cmeel-*)."""
    if arg:
        return Path(arg)
    return Path(sysconfig.get_paths()["platlib"]) / "cmeel.prefix"


def pinocchio_version(prefix: Path) -> str | None:
    """PINOCCHIO_VERSION from the headers the harness is compiled against."""
    config = prefix / "include" / "pinocchio" / "config.hpp"
    for line in config.read_text().splitlines() if config.exists() else []:
        parts = line.replace("#", " ").split()
        if parts[:2] == ["define", "PINOCCHIO_VERSION"] and len(parts) == 3:
            return parts[2].strip('"')
    return None


def compile_command(prefix: Path, cxx: str, out: Path, extra: list[str]) -> list[str]:
    inc, lib = prefix / "include", prefix / "lib"
    for needed, package in ((inc / "eigen3" / "Eigen" / "Core", "cmeel-eigen"),
                            (inc / "urdfdom_headers" / "urdf_model" / "model.h",
                             "cmeel-urdfdom-headers"),
                            (inc / "pinocchio" / "config.hpp", "libpinocchio")):
        if not needed.exists():
            sys.exit(f"missing {needed}: pip install {package} (see tools/pinocchio/requirements.txt)")
    return [
        cxx, *OPT_FLAGS, *ABI_DEFINES, *PIN_DEFINES, *extra,
        "-isystem", str(inc), "-isystem", str(inc / "eigen3"),
        "-isystem", str(inc / "urdfdom_headers"), "-isystem", str(inc / "urdfdom"),
        str(SOURCE), "-o", str(out),
        f"-L{lib}", f"-Wl,-rpath,{lib}",
        "-lpinocchio_parsers", "-lpinocchio_default", "-lurdfdom_model",
        "-lboost_filesystem", "-lboost_serialization",
    ]


def build(prefix: Path, cxx: str, build_dir: Path, extra: list[str], force: bool) -> tuple[Path, bool]:
    """Compile bench_pinocchio.cpp unless an identical build is cached."""
    version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout
    key = hashlib.sha256()
    key.update(SOURCE.read_bytes())
    key.update(" ".join(compile_command(prefix, cxx, Path("out"), extra)).encode())
    key.update(version.encode())
    out = build_dir / f"bench_pinocchio-{key.hexdigest()[:12]}"
    if out.exists() and not force:
        return out, False
    build_dir.mkdir(parents=True, exist_ok=True)
    cmd = compile_command(prefix, cxx, out, extra)
    log = out.with_suffix(".log")
    print("building:", shlex.join(cmd), file=sys.stderr)
    print(f"(Pinocchio's headers take a few minutes to compile; compiler output in {log})",
          file=sys.stderr)
    # Eigen's AVX-512 paths trigger many harmless -Wstringop-overread warnings
    # inside Pinocchio's headers: keep them in the log, show it only on failure.
    with open(log, "w") as fh:
        proc = subprocess.run(cmd, stdout=fh, stderr=subprocess.STDOUT)
    if proc.returncode != 0:
        sys.stderr.write(log.read_text()[-6000:])
        sys.exit(f"compilation failed (exit code {proc.returncode}), see {log}")
    return out, True


def verify(binary: Path, robots: list[str]) -> None:
    """Check the C++ build against the Python bindings on one random state."""
    try:
        import numpy as np
        import pinocchio as pin
    except ImportError:
        print("verify: pinocchio not importable here, skipped", file=sys.stderr)
        return
    for name in robots:
        urdf, floating = pinref.ROBOTS[name]
        path = pinref.resolve_path(urdf)
        dump = json.loads(subprocess.run(
            [str(binary), str(path), *(["--floating-base"] if floating else []), "--dump-first"],
            check=True, capture_output=True, text=True).stdout)
        m = (pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer()) if floating
             else pin.buildModelFromUrdf(str(path)))
        d = m.createData()
        q, v, a, tau = (np.array(dump[k]) for k in ("q", "v", "a", "tau"))
        refs = {"rnea": pin.rnea(m, d, q, v, a), "crba": pin.crba(m, d, q),
                "aba": pin.aba(m, d, q, v, tau), "centroidal": pin.computeCentroidalMap(m, d, q),
                "com": pin.centerOfMass(m, d, q)}
        worst = max(pinref.rel_err(dump[k], r) for k, r in refs.items())
        status = "ok" if worst <= 1e-12 else "MISMATCH"
        print(f"verify {name}: C++ build vs Python bindings, max rel err {worst:.1e} "
              f"[{status}] (Eigen {dump['eigen']}, {dump['simd']})", file=sys.stderr)
        if status != "ok":
            sys.exit("the C++ benchmark build disagrees with Pinocchio's Python bindings")


def robot_urdf(name: str, build_dir: Path) -> tuple[str, bool]:
    """(URDF path, floating base) of a bench robot, writing the derived ones first."""
    if name in SAME_URDF:
        return pinref.ROBOTS[SAME_URDF[name]]
    if name not in DERIVED:
        return pinref.ROBOTS[name]
    urdf, floating = pinref.ROBOTS[DERIVED[name]]
    text = pinref.resolve_path(urdf).read_text()
    joints = re.split(r"(<joint\b.*?</joint>)", text, flags=re.S)
    for k, part in enumerate(joints):
        if part.startswith("<joint") and 'type="continuous"' in part:
            part = part.replace('type="continuous"', 'type="revolute"')
            limits = 'lower="-3.141592653589793" upper="3.141592653589793"'
            if "<limit" not in part:
                part = part.replace("</joint>", f'<limit {limits} effort="0" velocity="0"/></joint>')
            elif "lower=" not in part and "upper=" not in part:
                part = part.replace("<limit ", f"<limit {limits} ", 1)
            joints[k] = part
    out = build_dir / f"{name}.urdf"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("".join(joints))
    return str(out), floating


def run_json(cmd: list[str]) -> dict:
    proc = subprocess.run(cmd, cwd=pinref.REPO_ROOT, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{shlex.join(cmd)} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    # Tolerate log lines before the JSON object: parse the last line that is one.
    for line in reversed(proc.stdout.strip().splitlines()):
        line = line.strip()
        if line.startswith("{"):
            return json.loads(line)
    raise RuntimeError(f"{shlex.join(cmd)} printed no JSON object:\n{proc.stdout[-2000:]}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pinocchio-only", action="store_true", help="do not run Centaur")
    ap.add_argument("--centaur-cmd", default=DEFAULT_CENTAUR_CMD,
                    help="Centaur bench command; URDF [--floating-base] are appended "
                         f"(default: {DEFAULT_CENTAUR_CMD!r})")
    ap.add_argument("--rounds", type=int, default=3, help="runs of each tool per robot (>= 1)")
    ap.add_argument("--robot", action="append", choices=BENCH_ROBOTS,
                    help="robot to bench (repeatable; default: all)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of Markdown")
    ap.add_argument("--pool", type=int, default=1000, help="random states per pool (C++)")
    ap.add_argument("--budget-ms", type=float, default=300.0,
                    help="minimum timing per algorithm per run (C++)")
    ap.add_argument("--min-rounds", type=int, default=31, help="minimum pool sweeps (C++)")
    ap.add_argument("--prefix", help="cmeel.prefix to build against (default: this venv's)")
    ap.add_argument("--cxx", default=os.environ.get("CXX", "g++"))
    ap.add_argument("--extra-cxxflags", default="", help="appended to the compile command")
    ap.add_argument("--build-dir", type=Path,
                    default=pinref.REPO_ROOT / "target" / "pinocchio-bench")
    ap.add_argument("--rebuild", action="store_true", help="ignore the cached binary")
    ap.add_argument("--verify", action="store_true",
                    help="check the cached build against the Python bindings again")
    args = ap.parse_args()

    robots = args.robot or BENCH_ROBOTS
    prefix = cmeel_prefix(args.prefix)
    binary, fresh = build(prefix, args.cxx, args.build_dir,
                          shlex.split(args.extra_cxxflags), args.rebuild)
    if fresh or args.verify:
        verify(binary, sorted({SAME_URDF.get(r, DERIVED.get(r, r)) for r in robots}))

    results = []
    for name in robots:
        urdf, floating = robot_urdf(name, args.build_dir)
        tail = [urdf] + (["--floating-base"] if floating else [])
        pin_cmd = [str(binary), *tail, "--pool", str(args.pool),
                   "--budget-ms", str(args.budget_ms), "--min-rounds", str(args.min_rounds)]
        runs = {"pinocchio": [], "centaur": []}
        for r in range(args.rounds):          # A/B/A/B...
            runs["pinocchio"].append(run_json(pin_cmd))
            print(f"{name} round {r + 1}: pinocchio "
                  + " ".join(f"{k}={runs['pinocchio'][-1][k]:.0f}" for k in KEYS), file=sys.stderr)
            if not args.pinocchio_only:
                runs["centaur"].append(run_json(shlex.split(args.centaur_cmd) + tail
                                                + CENTAUR_FLAGS.get(name, [])))
                print(f"{name} round {r + 1}: centaur   "
                      + " ".join(f"{k}={runs['centaur'][-1].get(k, float('nan')):.0f}"
                                 for k in KEYS), file=sys.stderr)
        entry = {"robot": name, "urdf": urdf, "floating_base": floating,
                 "nq": runs["pinocchio"][0].get("nq"), "nv": runs["pinocchio"][0].get("nv"),
                 "centaur_nq": runs["centaur"][0].get("nq") if runs["centaur"] else None,
                 "centaur_flags": CENTAUR_FLAGS.get(name, [])}
        for tool, rs in runs.items():
            if not rs:
                continue
            entry[tool] = {k: {"median_ns": statistics.median(r[k] for r in rs if k in r),
                               "best_ns": min(r[k] for r in rs if k in r),
                               "runs_ns": [r.get(k) for r in rs]}
                           for k in KEYS if any(k in r for r in rs)}
        results.append(entry)

    if args.json:
        doc = {"date": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
               "pinocchio_version": pinocchio_version(prefix),
               "pinocchio_binary": str(binary),
               "compile_flags": OPT_FLAGS + ABI_DEFINES,
               "rounds": args.rounds, "robots": results}
        print(json.dumps(doc, indent=1))
        return 0

    print("| robot | nq/nv | algorithm | Pinocchio ns (best / median) | Centaur ns (best / median) | "
          "centaur/pinocchio (best) |")
    print("|---|---|---|---:|---:|---:|")
    for e in results:
        for k in KEYS:
            p = e.get("pinocchio", {}).get(k, {})
            c = e.get("centaur", {}).get(k, {})
            ratio = f"{c['best_ns'] / p['best_ns']:.2f}" if p and c else "–"
            cs = f"{c['best_ns']:,.0f} / {c['median_ns']:,.0f}" if c else "–"
            nq = e["nq"] if e["centaur_nq"] in (None, e["nq"]) else f"{e['nq']} (C: {e['centaur_nq']})"
            print(f"| {e['robot']} | {nq}/{e['nv']} | {k} | "
                  f"{p['best_ns']:,.0f} / {p['median_ns']:,.0f} | {cs} | {ratio} |")
    print()
    print(f"Best and median over {args.rounds} alternating runs per tool; each run reports the "
          "median ns per call over a pool of random states. The ratio compares the best runs: "
          "on this shared machine a tool's run can be 2-5x slower than its others (Pinocchio's "
          "RNEA/ABA are bimodal across processes), and the best run is the closest to the "
          "code's own speed. nq/nv are Pinocchio's, with Centaur's nq after C: where it "
          "differs (a continuous joint counts 2 in nq as (cos, sin); minitaur: both take "
          "(cos, sin); minitaur_angles: Centaur takes angles; minitaur_revolute declares the "
          "Minitaur's continuous joints revolute, both take angles). "
          "Ratio < 1: Centaur faster.")
    return 0


if __name__ == "__main__":
    sys.exit(main())

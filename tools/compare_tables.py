#!/usr/bin/env python3
"""Prints the README's tables of a `centaur compare` run from its compare.json.

    python3 tools/compare_tables.py runs/compare_minitaur_ppo_2m/compare.json [--agent-names H P C]

Three tables, as the README shows them: the final deterministic evaluation per agent (IQM
with its 95 % stratified-bootstrap CI, mean ± std over seeds, forward speed, falls, cost of
transport), the evaluations at every budget, and each seed's final return and falls; then,
where compare.json has it, the head-to-head `centaur compare` read off them (by budget, pure
RL's final return, equal wall-clock). Every figure is read from compare.json; nothing is
recomputed.
"""
import argparse
import json
import sys


def num(x, digits):
    """`x` with thousands separators at `digits` decimals (1,654.6)."""
    return f"{x:,.{digits}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("compare_json")
    ap.add_argument("--digits", type=int, default=2, help="decimals of returns (2 for the Minitaur, 1 for the Ant)")
    ap.add_argument("--agent-names", nargs=3, metavar=("HYBRID", "PURE", "CONTROLLER"),
                    default=["hybrid", "pure RL", "controller alone"])
    args = ap.parse_args()
    try:
        with open(args.compare_json) as f:
            d = json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        print(f"error: cannot read {args.compare_json}: {e}", file=sys.stderr)
        return 1
    missing = [k for k in ("hybrid", "pure_rl", "controller", "budgets", "seeds", "steps") if k not in d]
    if missing:
        print(f"error: {args.compare_json} is not a compare.json (lacks {', '.join(missing)})", file=sys.stderr)
        return 1
    k = args.digits
    print(f"{d.get('env', '?')}, {d.get('algo', '?')}, {d['seeds']} seeds × {d['steps']:,} samples\n")
    print("| agent | return IQM [95 % CI] | mean ± std over seeds | forward speed (m/s) | falls | cost of transport |")
    print("|---|---:|---:|---:|---:|---:|")
    for key, name in zip(("hybrid", "pure_rl", "controller"), args.agent_names):
        a = d[key]
        ci = a["return_iqm_ci95"]
        print(f"| {name} | {num(a['return_iqm'], k)} [{num(ci['low'], k)}, {num(ci['high'], k)}] | "
              f"{num(a['return_mean'], k)} ± {num(a['return_std'], k)} | "
              f"{a['mean_speed']:.3f} ± {a['mean_speed_std']:.3f} | {a['falls']}/{a['episodes']} | "
              f"{a['cost_of_transport']:.2f} |")
    print()
    print("| samples | hybrid IQM [95 % CI] | pure IQM [95 % CI] | hybrid falls | pure falls | hybrid / pure training wall (s) |")
    print("|---:|---:|---:|---:|---:|---:|")
    for b in d["budgets"]:
        h, p = b["hybrid_ci95"], b["pure_ci95"]
        print(f"| {b['env_steps']:,} | {num(b['hybrid_iqm'], k)} [{num(h['low'], k)}, {num(h['high'], k)}] | "
              f"{num(b['pure_iqm'], k)} [{num(p['low'], k)}, {num(p['high'], k)}] | "
              f"{b['hybrid_falls'][0]}/{b['hybrid_falls'][1]} | {b['pure_falls'][0]}/{b['pure_falls'][1]} | "
              f"{b['hybrid_wall_seconds']:,.0f} / {b['pure_wall_seconds']:,.0f} |")
    print()
    for key, name in zip(("hybrid", "pure_rl"), args.agent_names):
        seeds = ", ".join(f"{s['return_mean']:.{k}f}/{s['falls']}" for s in d[key]["per_seed"])
        walls = ", ".join(f"{s['wall_seconds']:,.0f}" for s in d[key]["per_seed"])
        print(f"{name} per seed (return / falls of {d[key]['per_seed'][0]['episodes']}): {seeds}; training wall (s): {walls}")
    h2h = d.get("head_to_head")  # written by `centaur compare` since 2026-12-07
    if h2h:
        print()
        below = ", ".join(f"{s:,}" for s in h2h["hybrid_below_at"]) or "none"
        print(f"By budget: at or above pure RL at {h2h['hybrid_at_or_above']} of {h2h['budgets']} (below at {below}); "
              f"fewer falls at {h2h['fewer_falls']}, as many at {h2h['as_many_falls']}")
        at, frac = h2h.get("hybrid_reaches_pure_final_at"), h2h.get("fraction_of_pure_samples")
        reached = f"reached at {at:,} samples ({frac:.3f} of {h2h['pure_samples']:,})" if at is not None and frac is not None \
            else "not reached"
        print(f"Pure RL's final return ({num(h2h['pure_final_iqm'], k)}): {reached}")
        w = h2h["equal_wall_clock"]
        rows = ", ".join(f"{p['seconds']:,.0f} s: {num(p['hybrid_iqm'], k)} against {num(p['pure_iqm'], k)}" for p in w["points"])
        print(f"Equal wall-clock: at or above at {w['hybrid_at_or_above']} of {len(w['points'])} ({rows})"
              + ("; pure RL's times from the reused run" if w["pure_times_from_another_run"] else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())

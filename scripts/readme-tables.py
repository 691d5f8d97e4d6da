#!/usr/bin/env python3
"""The README's result tables, from an `sms sweep` folder and an `sms ablate` folder.

Usage: scripts/readme-tables.py SWEEP_DIR ABLATE_DIR OVERLAPPED_SWEEP_DIR
Prints Markdown: (1) per scene, the headline speed-ups over RB_8 with blocking stack timing and,
beside them, with overlapped timing (a sweep run with `--stack-timing overlapped`), geomean last;
(2) geomean speed-up, off-chip and DRAM accesses against RB_8, bytes per SM; (3) the ablation.
"""
import json
import sys

sweep, ablate, overlapped = sys.argv[1], sys.argv[2], sys.argv[3]
load = lambda d, f: json.load(open(f"{d}/{f}.json"))["data"]
HEAD = ["RB_16", "RB_FULL", "RB_8+SH_8", "RB_8+SH_8+SK", "RB_8+SH_8+SK+RA", "RB_2"]
SHORT = {"RB_8+SH_8+SK": "+SK", "RB_8+SH_8+SK+RA": "SMS"}
short = lambda c: SHORT.get(c, c)

perf = {r["config"]: r for r in load(sweep, "performance")["rows"]}
scenes = [p["scene"] for p in perf["RB_8"]["per_scene"]]
arms = {r["arm"]: r for r in load(ablate, "ablation")["rows"]}
over = {r["config"]: r for r in load(overlapped, "performance")["rows"]}
over_ps = {p["scene"]: {c: next(q["speedup"] for q in r["per_scene"] if q["scene"] == p["scene"]) for c, r in over.items()} for p in over["RB_8"]["per_scene"]}
over_geo = {c: r["geomean"] for c, r in over.items()}

cols = [short(c) for c in HEAD]
print("| scene | " + " | ".join(cols) + " | " + " | ".join(f"{c} overlapped" for c in ("RB_16", "RB_FULL", "SMS")) + " |")
print("|---|" + "---:|" * (len(cols) + 3))
for s in scenes + ["geomean"]:
    get = lambda c: perf[c]["geomean"] if s == "geomean" else next(p["speedup"] for p in perf[c]["per_scene"] if p["scene"] == s)
    oget = lambda c: over_geo[c] if s == "geomean" else over_ps[s][c]
    cells = [f"{get(c):.3f}" for c in HEAD] + [f"{oget(c):.3f}" for c in ("RB_16", "RB_FULL", "RB_8+SH_8+SK+RA")]
    name = f"**{s}**" if s == "geomean" else s
    print(f"| {name} | " + " | ".join(cells) + " |")

print()
off = {r["config"]: r for r in load(sweep, "offchip")["rows"]}
cost = {r["config"]: r for r in load(sweep, "cost")["rows"]}
base = off["RB_8"]
tot = lambda r, k: r[f"{k}_node"] + r[f"{k}_stack"]
print("| configuration | speed-up (geomean) | off-chip accesses vs RB_8 | of which stack | DRAM accesses vs RB_8 | bytes added per SM |")
print("|---|---:|---:|---:|---:|---:|")
for c in ["RB_8"] + HEAD + ["RB_4+SH_8+SK+RA", "RB_16+SH_8+SK+RA"]:
    r, k = off[c], cost[c]
    sh = f" (+{k['sh_bytes_per_sm'] // 1024} KB shared)" if k["sh_bytes_per_sm"] else ""
    print(
        f"| {short(c)} | {perf[c]['geomean']:.4f} | {tot(r, 'offchip') / tot(base, 'offchip'):.3f} | "
        f"{r['offchip_stack'] / tot(base, 'offchip'):.3f} | {tot(r, 'dram') / tot(base, 'dram'):.3f} | "
        f"{k['added_bytes_per_sm']:.0f}{sh} |"
    )

print()
ARMS = HEAD + ["RB_2+SH_8+SK+RA"]
print("| mechanism off | " + " | ".join(cols) + " | RB_2+SMS |")
print("|---|" + "---:|" * len(ARMS))
for name, r in arms.items():
    geo = {g["config"]: g["geomean"] for g in r["geomean"]}
    ref = {g["config"]: g["geomean"] for g in arms["all on"]["geomean"]}
    cells = [f"{geo[c]:.3f}" + ("" if name == "all on" else f" ({geo[c] - ref[c]:+.3f})") for c in ARMS]
    print(f"| {name.removesuffix(' off')} | " + " | ".join(cells) + " |")

#!/usr/bin/env python3
"""Error of a sampled `sms sweep` against a full one: per configuration, the largest absolute
difference of the speed-up over RB_8 across scenes, and the difference of the geomean.

Usage: scripts/sample-error.py SAMPLED_DIR FULL_DIR
"""
import json
import sys


def speedups(folder):
    rows = json.load(open(f"{folder}/performance.json"))["data"]["rows"]
    return {r["config"]: ({p["scene"]: p["speedup"] for p in r["per_scene"]}, r["geomean"]) for r in rows}


sampled, full = speedups(sys.argv[1]), speedups(sys.argv[2])
print("| configuration | largest per-scene error (scene) | geomean sampled | geomean full | geomean error |")
print("|---|---:|---:|---:|---:|")
worst_scene, worst_geo = 0.0, 0.0
for config, (per, geo) in full.items():
    s_per, s_geo = sampled[config]
    err, where = max((abs(s_per[k] - v), k) for k, v in per.items())
    worst_scene, worst_geo = max(worst_scene, err), max(worst_geo, abs(s_geo - geo))
    print(f"| {config} | {err:.4f} ({where}) | {s_geo:.4f} | {geo:.4f} | {s_geo - geo:+.4f} |")
print(f"\nlargest per-scene speed-up error {worst_scene:.4f}, largest geomean error {worst_geo:.4f}")

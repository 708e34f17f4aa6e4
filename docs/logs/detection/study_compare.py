"""Per (host, SNR): class correct / depth within ±1 with the class right / μ inside its 95 % interval over the
impure signals, and clean signals called none, for several study JSON files side by side; then the signals
on which the fine scan ran. Usage: python docs/logs/detection/study_compare.py NAME=FILE.json ...
"""
import collections
import json
import sys

runs = dict(arg.split("=", 1) for arg in sys.argv[1:])
rows = collections.defaultdict(dict)
for name, path in runs.items():
    groups = collections.defaultdict(list)
    for r in json.load(open(path))["records"]:
        groups[(r["host"], r["snr_db"])].append(r)
    for key, records in groups.items():
        impure = [r for r in records if r["true_class"] != "none"]
        correct = sum(r["class_correct"] for r in impure) / len(impure)
        depth = sum(1 for r in impure if r["class_correct"] and r["depth_error"] is not None
                    and abs(r["depth_error"]) <= 1) / len(impure)
        covered = [r["mass_ratio_covered"] for r in impure if r.get("mass_ratio_covered") is not None]
        clean = sum(r["class_correct"] for r in records if r["true_class"] == "none")
        rows[key][name] = f"{correct:.3f} / {depth:.3f} / {sum(covered) / len(covered):.3f} / {clean}"
print("| host | SNR [dB] | " + " | ".join(runs) + " |")
print("| --- | --- |" + " --- |" * len(runs))
for (host, snr) in sorted(rows, key=lambda k: (k[0], -k[1])):
    print(f"| {host} | {snr:g} | " + " | ".join(rows[(host, snr)].get(n, "") for n in runs) + " |")
for name, path in runs.items():
    scanned = [r for r in json.load(open(path))["records"] if r.get("fine_scan")]
    print(f"\n{name}: fine scan on {len(scanned)} signals")
    for r in scanned:
        f = r["fine_scan"]
        print(f"  {r['host']} {r['snr_db']:g} dB truth {r['true_class']} d={r['true_depth']} mu={r['true_mass_ratio']}"
              f" -> {r['class']} d={r['depth']} mu={r['mass_ratio']:.4f} covered={r['mass_ratio_covered']}"
              f" misfit before {f['misfit_before']:.2f} improved {f['improved']} {f['seconds']:.1f} s")

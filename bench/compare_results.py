#!/usr/bin/env python3
"""Compares the accuracy figures of two lcd_evaluate result folders (results.json), e.g. a fresh
run against bench/results, and says which differ.

    bench/compare_results.py bench/results/corridor /tmp/new/corridor [...more pairs]

Accuracy (R@100P, AUC, AP, recall@1) and bytes per image must match to 1e-6; times are shown as
the new / old ratio of medians and never fail the comparison (they depend on the machine's load).
Exit status 1 when any accuracy figure differs or a configuration is missing.
"""
import json
import sys

ACCURACY = ["recall_at_100_precision", "auc", "average_precision", "recall_at_1", "bytes_per_image"]


def load(folder):
    with open(folder.rstrip("/") + "/results.json") as f:
        return {c["name"]: c for c in json.load(f)["configurations"]}


def compare(old_folder, new_folder):
    old, new = load(old_folder), load(new_folder)
    same = True
    print(f"{old_folder} -> {new_folder}")
    for name, before in old.items():
        after = new.get(name)
        if after is None:
            print(f"  {name:24s} missing from the new run")
            same = False
            continue
        changed = [k for k in ACCURACY if abs(float(before.get(k, 0)) - float(after.get(k, 0))) > 1e-6]
        ratio = after["describe_ms"]["median"] / max(before["describe_ms"]["median"], 1e-9)
        state = "same" if not changed else "DIFFERS: " + ", ".join(
            f"{k} {before.get(k)} -> {after.get(k)}" for k in changed)
        print(f"  {name:24s} R@100P {float(after['recall_at_100_precision']):.3f} "
              f"AUC {float(after['auc']):.3f}  {state}  (describe time x{ratio:.2f})")
        same = same and not changed
    return same


def main(argv):
    if len(argv) < 2 or len(argv) % 2:
        sys.exit(__doc__)
    results = [compare(argv[i], argv[i + 1]) for i in range(0, len(argv), 2)]
    sys.exit(0 if all(results) else 1)


if __name__ == "__main__":
    main(sys.argv[1:])

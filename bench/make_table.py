#!/usr/bin/env python3
"""Markdown table of lcd_evaluate results (results.json in each folder given)."""
import json
import os
import sys


def main(folders):
    print("| dataset | configuration | R@100P | AUC | AP | R@1 | describe ms (median / p99) |"
          " query ms (median / p99) | bytes per image |")
    print("|---|---|---|---|---|---|---|---|---|")
    for folder in folders:
        with open(os.path.join(folder, "results.json")) as handle:
            results = json.load(handle)
        for c in results["configurations"]:
            print("| %s | %s | %.3f | %.3f | %.3f | %.3f | %.2f / %.2f | %.2f / %.2f | %d |" % (
                results["dataset"], c["name"], c["recall_at_100_precision"], c["auc"],
                c["average_precision"], c["recall_at_1"], c["describe_ms"]["median"],
                c["describe_ms"]["p99"], c["query_ms"]["median"], c["query_ms"]["p99"],
                c["bytes_per_image"]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/env python3
"""Markdown tables of lcd_evaluate results (results.json in each folder given).

make_table.py FOLDER...            one row per dataset and configuration, every measure
make_table.py --matrix FOLDER...   one row per dataset, one column per configuration:
                                   "R@100P / R@1" (folders of one dataset are merged)
"""
import json
import os
import sys


def load(folders):
    for folder in folders:
        with open(os.path.join(folder, "results.json")) as handle:
            yield json.load(handle)


def full_table(folders):
    print("| dataset | configuration | R@100P | AUC | AP | R@1 | describe ms (median / p99) |"
          " query ms (median / p99) | bytes per image |")
    print("|---|---|---|---|---|---|---|---|---|")
    for results in load(folders):
        for c in results["configurations"]:
            print("| %s | %s | %.3f | %.3f | %.3f | %.3f | %.2f / %.2f | %.2f / %.2f | %d |" % (
                results["dataset"], c["name"], c["recall_at_100_precision"], c["auc"],
                c["average_precision"], c["recall_at_1"], c["describe_ms"]["median"],
                c["describe_ms"]["p99"], c["query_ms"]["median"], c["query_ms"]["p99"],
                c["bytes_per_image"]))


def matrix(folders):
    rows = {}
    columns = []
    for results in load(folders):
        row = rows.setdefault(results["dataset"], {})
        for c in results["configurations"]:
            if c["name"] not in columns:
                columns.append(c["name"])
            row[c["name"]] = "%.3f / %.2f" % (c["recall_at_100_precision"], c["recall_at_1"])
    print("| dataset | " + " | ".join(columns) + " |")
    print("|---|" + "---|" * len(columns))
    for dataset, row in rows.items():
        print("| %s | %s |" % (dataset, " | ".join(row.get(name, "-") for name in columns)))


def main(arguments):
    if arguments and arguments[0] == "--matrix":
        matrix(arguments[1:])
    else:
        full_table(arguments)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/python3
"""Pictures of lcd_evaluate results: PR curves of every configuration on one plot, each
similarity matrix beside the ground truth, and the trajectory with the loops accepted at 100 %
precision (when the run had poses).

usage: plot_results.py RESULTS_FOLDER [RESULTS_FOLDER ...]
Writes pr_curves.png, matrices.png and trajectory.png into each folder. Needs matplotlib
(Debian: python3-matplotlib).
"""
import csv
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402


def read_csv(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def plot_pr(folder, results):
    fig, ax = plt.subplots(figsize=(5.5, 4.5))
    for config in results["configurations"]:
        rows = read_csv(os.path.join(folder, config["pr_curve"]))
        recall = [0.0] + [float(r["recall"]) for r in rows]
        precision = [1.0] + [float(r["precision"]) for r in rows]
        ax.plot(recall, precision, label="%s (AUC %.2f, R@100P %.2f)" % (
            config["name"], config["auc"], config["recall_at_100_precision"]))
    ax.set_xlabel("recall")
    ax.set_ylabel("precision")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1.02)
    ax.set_title(results["dataset"], fontsize=10)
    ax.legend(fontsize=8, loc="lower left")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "pr_curves.png"), dpi=100)
    plt.close(fig)


def plot_matrices(folder, results):
    configs = results["configurations"]
    fig, axes = plt.subplots(1, len(configs) + 1, figsize=(3.2 * (len(configs) + 1), 3.4))
    axes[0].imshow(mpimg.imread(os.path.join(folder, "ground_truth.png")), cmap="gray")
    axes[0].set_title("ground truth", fontsize=9)
    for ax, config in zip(axes[1:], configs):
        ax.imshow(mpimg.imread(os.path.join(folder, "similarity_%s.png" % config["name"])))
        ax.set_title("similarity: %s" % config["name"], fontsize=9)
    for ax in axes:
        ax.set_xlabel("database image")
        ax.set_ylabel("query image")
        ax.set_xticks([])
        ax.set_yticks([])
    fig.tight_layout()
    # Fewer dots per panel as panels are added, so the picture stays under 1 MB.
    fig.savefig(os.path.join(folder, "matrices.png"), dpi=90 if len(configs) < 10 else 72)
    plt.close(fig)


def plot_trajectory(folder, results):
    path = os.path.join(folder, "trajectory.csv")
    if not os.path.exists(path):
        return
    points = [(float(r["x"]), float(r["y"])) for r in read_csv(path)]
    best = max(results["configurations"], key=lambda c: c["recall_at_100_precision"])
    matches = read_csv(os.path.join(folder, "matches_%s.csv" % best["name"]))
    fig, ax = plt.subplots(figsize=(6, 5))
    ax.plot([p[0] for p in points], [p[1] for p in points], color="0.6", lw=1, label="trajectory")
    accepted = [m for m in matches if m["accepted_at_100p"] == "1"]
    for m in accepted:
        a = points[int(m["query"])]
        b = points[int(m["match"])]
        ax.plot([a[0], b[0]], [a[1], b[1]], color="tab:green" if m["correct"] == "1" else "tab:red",
                lw=1.5)
    ax.set_title("%s: %d loops accepted at 100%% precision (%s)" % (
        results["dataset"], len(accepted), best["name"]), fontsize=9)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "trajectory.png"), dpi=100)
    plt.close(fig)


def main(folders):
    if not folders:
        print(__doc__)
        return 2
    for folder in folders:
        with open(os.path.join(folder, "results.json")) as handle:
            results = json.load(handle)
        plot_pr(folder, results)
        plot_matrices(folder, results)
        plot_trajectory(folder, results)
        print("plots written to", folder)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

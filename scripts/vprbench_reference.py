#!/usr/bin/env python3
"""Computes VPR-Bench's recall at 100 % precision and PR AUC with scikit-learn, as VPR-Bench does
(precision_recall_curve over each query's best-match score and whether that match is right, then
auc(recall, precision)), for the outcomes test/core/test_evaluation.cpp generates. The test holds
the figures this prints; rerun it (Debian: python3-sklearn) when the generator changes.
"""
from sklearn.metrics import auc, precision_recall_curve

QUERIES = 60


def outcome(i):
    """Query i's best-match score (23 levels, so many ties) and whether the match is right."""
    return ((i * 37) % 23) / 22.0, (i * 11) % 7 < 4


def main():
    scores, right = zip(*(outcome(i) for i in range(QUERIES)))
    precision, recall, _ = precision_recall_curve(right, scores)
    recall_at_100_precision = max(r for p, r in zip(precision, recall) if p == 1.0)
    print(f"right matches {sum(right)} of {QUERIES}")
    print(f"VPR-Bench AUC {auc(recall, precision):.17g}")
    print(f"VPR-Bench R@100P {recall_at_100_precision:.17g}")


if __name__ == "__main__":
    main()

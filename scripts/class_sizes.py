#!/usr/bin/env python3
"""Counts the data members of every class in include/ and src/ and fails past the limits.

A class's data members are the declarations in its own body whose names end in an underscore (the
style guide's rule for class members; plain structs' members do not, and are not classes with
behaviour). The limits: no class past --max-members (25), LoopDetector past 12.

  scripts/class_sizes.py [--max-members N] [--list]
"""
import argparse
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
SPECIAL_LIMITS = {"LoopDetector": 12}
CLASS_HEAD = re.compile(
    r"^[ \t]*(class|struct)\s+(?:CAPABILITY\([^)]*\)\s+|SCOPED_CAPABILITY\s+)?(\w+)"
    r"(?:\s+final)?\s*(?::[^;{]*)?\{", re.M)
MEMBER = re.compile(
    r"\b[A-Za-z]\w*_\s*(?:(?:PT_)?GUARDED_BY\([^)]*\)\s*)?(?:\{[^;{}]*\}|=[^;]*)?;")


def strip_comments_and_strings(text):
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r'"(?:\\.|[^"\\\n])*"', '""', text)


def own_body(text, start):
    """The class body from just after its '{', with nested braces' contents left out."""
    depth, kept, i = 1, [], start
    while depth > 0 and i < len(text):
        c = text[i]
        if c == "{":
            depth += 1
            if depth == 2:
                kept.append("{")
        elif c == "}":
            depth -= 1
            if depth == 1:
                kept.append("}")
        elif depth == 1:
            kept.append(c)
        i += 1
    return "".join(kept)


def classes(path):
    text = strip_comments_and_strings(path.read_text(encoding="utf-8"))
    for head in CLASS_HEAD.finditer(text):
        if head.group(1) != "class":
            continue
        members = MEMBER.findall(own_body(text, head.end()))
        yield head.group(2), len(members)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-members", type=int, default=25)
    parser.add_argument("--list", action="store_true", help="print every class's count")
    args = parser.parse_args()
    files = sorted(p for folder in ("include", "src") for p in (ROOT / folder).rglob("*")
                   if p.suffix in (".h", ".cpp"))
    too_big = []
    counted = 0
    for path in files:
        for name, count in classes(path):
            counted += 1
            limit = SPECIAL_LIMITS.get(name, args.max_members)
            if args.list:
                print(f"{count:3d}  {name}  ({path.relative_to(ROOT)})")
            if count > limit:
                too_big.append(f"{name} ({path.relative_to(ROOT)}): {count} data members, "
                               f"the limit is {limit}")
    for name in SPECIAL_LIMITS:
        if not any(name == n for p in files for n, _ in classes(p)):
            too_big.append(f"{name}: not found")
    if too_big:
        print("class_sizes: split these by job:\n  " + "\n  ".join(too_big), file=sys.stderr)
        return 1
    print(f"class_sizes: {counted} classes, none past {args.max_members} data members "
          f"(LoopDetector <= {SPECIAL_LIMITS['LoopDetector']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

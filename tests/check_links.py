#!/usr/bin/python3
"""Link check (a CTest): every relative markdown link in README.md, experiments/README.md and
paper_notes/*.md resolves to a file or folder of the repository (anchors are not checked; web
links, code spans and code blocks are skipped). Prints every broken link with its file and line; exit status 1 if any.

Usage: /usr/bin/python3 tests/check_links.py [SOURCE_DIR]
"""
import glob
import os
import re
import sys

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")


def broken_links(root):
    files = [os.path.join(root, "README.md"), os.path.join(root, "experiments", "README.md")]
    files += sorted(glob.glob(os.path.join(root, "paper_notes", "*.md")))
    broken, checked = [], 0
    for md in files:
        with open(md, encoding="utf-8") as f:
            text = f.read()
        # Code spans and blocks are not links.
        text = re.sub(r"```.*?```", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
        for number, line in enumerate(text.split("\n"), 1):
            if line.startswith("    ") or line.startswith("\t"):
                continue  # an indented code block
            line = re.sub(r"`[^`]*`", "", line)
            for target in LINK.findall(line):
                if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
                    continue  # web, mail, anchors in the same file
                path = target.split("#", 1)[0]
                checked += 1
                resolved = os.path.normpath(os.path.join(os.path.dirname(md), path))
                inside = os.path.commonpath([os.path.abspath(root), os.path.abspath(resolved)])
                if not os.path.exists(resolved) or inside != os.path.abspath(root):
                    broken.append("%s:%d: %s" % (os.path.relpath(md, root), number, target))
    return broken, checked, len(files)


if __name__ == "__main__":
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..")
    broken, checked, files = broken_links(root)
    for b in broken:
        print("broken link:", b)
    print("%d relative links checked in %d files, %d broken" % (checked, files, len(broken)))
    sys.exit(1 if broken else 0)

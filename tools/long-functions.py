#!/usr/bin/env python3
"""Functions in src/ longer than a limit (default 120 lines, signature to closing brace).

    python3 tools/long-functions.py [--limit N]     # exit 1 when one is longer

Braces are matched on the source with strings, chars and comments blanked out, which is
enough for rustfmt-formatted code.
"""

import re
import sys
from pathlib import Path

SRC = Path(__file__).resolve().parent.parent / "src"
FN = re.compile(r"^\s*(?:pub(?:\([^)]*\))?\s+)?(?:const\s+|async\s+|unsafe\s+)*fn\s+([A-Za-z0-9_]+)")


def blank(text):
    """Strings, chars and comments replaced by spaces (line structure kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == '"' or text.startswith('r"', i) or text.startswith("r#", i):
            m = re.match(r'r(#*)"', text[i:])
            if m:
                end = '"' + m.group(1)
                j = text.find(end, i + len(m.group(0)))
                j = n if j < 0 else j + len(end)
            else:
                j = i + 1
                while j < n and text[j] != '"':
                    j += 2 if text[j] == "\\" else 1
                j += 1
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "'" and re.match(r"'(\\.|[^\\'])'", text[i:i + 4]):
            m = re.match(r"'(\\.|[^\\'])'", text[i:])
            out.append(" " * len(m.group(0)))
            i += len(m.group(0))
        else:
            out.append(c)
            i += 1
    return "".join(out)


def functions(path):
    lines = blank(path.read_text()).split("\n")
    for k, line in enumerate(lines):
        m = FN.match(line)
        if not m:
            continue
        # `nest`: brackets and parentheses, so that the `;` of an array type in the
        # signature (`[f32; 3]`) is not taken for the end of a bodiless declaration
        depth, opened, nest = 0, False, 0
        for j in range(k, len(lines)):
            for ch in lines[j]:
                if ch == "{":
                    depth += 1
                    opened = True
                elif ch == "}":
                    depth -= 1
                elif ch in "([":
                    nest += 1
                elif ch in ")]":
                    nest -= 1
                elif ch == ";" and not opened and depth == 0 and nest == 0:
                    break  # a declaration without a body
            else:
                if opened and depth == 0:
                    yield m.group(1), k + 1, j - k + 1
                    break
                continue
            break


def main(argv):
    limit = int(argv[argv.index("--limit") + 1]) if "--limit" in argv else 120
    long = []
    for f in sorted(SRC.rglob("*.rs")):
        for name, line, count in functions(f):
            if count > limit:
                long.append((count, f"{f.relative_to(SRC.parent)}:{line} {name}: {count} lines"))
    for _, text in sorted(long, reverse=True):
        print(text)
    print(f"{len(long)} functions over {limit} lines", file=sys.stderr)
    return 1 if long else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

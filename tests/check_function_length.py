#!/usr/bin/env python3
"""No function in analysis/experiments/ is longer than 120 lines (docs/architecture.md, "Where to add things": a study).

    check_function_length.py [ROOT]          check ROOT/analysis/experiments (default: the repository)
    check_function_length.py --top N [ROOT]  also print the N longest functions
    check_function_length.py --max L [ROOT]  another limit than 120 lines
    check_function_length.py --self-test     show that a long function is reported and a short one is not

A function's length counts from its signature line to its closing brace. The
C++ is parsed roughly: comments, string and character literals (raw strings
included) and preprocessor lines are blanked first, then the braces are matched;
a brace block whose header has a parameter list and no `=` is a function body
(member functions of a class or struct defined in the class count too; lambdas
count as part of the function that holds them). Exit 1 and one line per
function over the limit.
"""
import os
import re
import sys
import tempfile

LIMIT = 120
FOLDER = "analysis/experiments"
SUFFIXES = (".cpp", ".hpp", ".h")


def blank(text):
    """The text with comments, literals and preprocessor lines replaced by spaces (newlines kept)."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":
            j = i
            while j < n and text[j] != "\n":  # a directive, continued lines included
                if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n":
                    out.append(" \n")
                    j += 2
                    continue
                out.append(" ")
                j += 1
            i = j
            continue
        if c == "\n":
            out.append(c)
            line_start = True
            i += 1
            continue
        if not c.isspace():
            line_start = False
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
        elif c == "R" and text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            m = re.match(r'R"([^(\s]*)\(', text[i:])
            if not m:
                out.append(c)
                i += 1
                continue
            end = text.find(")" + m.group(1) + '"', i)
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            if c == "'" and i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum():
                out.append(" ")  # a digit separator: 1'000'000
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            j = min(j + 1, n)
            out.append(" " * (j - i))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


LABEL = re.compile(r"^\s*(public|private|protected)\s*:(?!:)")
TRANSPARENT = re.compile(r"^\s*(template\s*<.*>\s*)?(namespace\b|extern\b|class\b|struct\b|union\b)", re.S)


def functions(text):
    """(name, first line, last line) of every function body in a C++ source."""
    s = blank(text)
    found = []
    depth_kinds = []  # per open brace: "scope" (namespace, class) or "other"
    header_start = 0
    i, n = 0, len(s)
    while i < n:
        c = s[i]
        if c in ";}" or (c == ":" and LABEL.match(s[header_start:i + 1])):
            if c == "}" and depth_kinds:
                depth_kinds.pop()
            header_start = i + 1
        elif c == "{":
            header = s[header_start:i]
            is_scope = bool(TRANSPARENT.match(header)) and "(" not in header.split("{")[0].split(":")[0]
            if is_scope or (depth_kinds and depth_kinds[-1] != "scope"):
                depth_kinds.append("scope" if is_scope else "other")
                header_start = i + 1
                i += 1
                continue
            paren = header.find("(")
            if paren >= 0 and "=" not in header[:paren].replace("operator=", "").replace("==", ""):
                name = re.findall(r"[~\w:]+(?:\s*(?:<[^()]*>|operator\s*\S+))?\s*$", header[:paren])
                depth, j = 1, i + 1
                while j < n and depth:
                    depth += {"{": 1, "}": -1}.get(s[j], 0)
                    j += 1
                first = header_start + len(header) - len(header.lstrip())
                found.append(((name[0].strip() if name else "?"), s.count("\n", 0, first) + 1,
                              s.count("\n", 0, j - 1) + 1))
                header_start = i = j
                continue
            depth_kinds.append("other")  # an initializer, an enum: skipped as a whole
            header_start = i + 1
        i += 1
    return found


def check(root, limit=LIMIT):
    """(problems, [(length, 'path:line name')]) for the sources under ROOT/analysis/experiments."""
    measured = []
    top = os.path.join(root, FOLDER)
    for dirpath, _, names in os.walk(top):
        for name in sorted(names):
            if not name.endswith(SUFFIXES):
                continue
            full = os.path.join(dirpath, name)
            rel = os.path.relpath(full, root).replace(os.sep, "/")
            with open(full, encoding="utf-8", errors="replace") as fh:
                for fn, first, last in functions(fh.read()):
                    measured.append((last - first + 1, f"{rel}:{first} {fn}"))
    measured.sort(key=lambda m: (-m[0], m[1]))
    problems = [f"{where}: {length} lines (limit {limit})" for length, where in measured if length > limit]
    return problems, measured


def self_test():
    """A long function must be reported; braces in strings and comments and long tables must not count."""
    body = "\n".join(f"    x += {k};" for k in range(125))
    long_fn = f"namespace a {{\nint long_one(int x) {{\n{body}\n    return x;\n}}\n}}  // namespace a\n"
    short_body = "\n".join(f"    x += {k};  // }} {{" for k in range(100))
    table = ",\n".join(f"    {{{k}, \"}}{k}\"}}" for k in range(200))
    clean = (f"namespace {{\nconst std::map<int, const char*> kTable = {{\n{table}}};\n}}\n"
             f"struct S {{\n    int f() const {{ return 1; }}\n}};\n"
             f"int short_one(int x) {{\n    const char* s = \"{{{{ /* \";\n{short_body}\n    return x;\n}}\n")
    failed = 0
    for name, text, want in [("long function", long_fn, "long_one: 128 lines"), ("clean file", clean, None)]:
        with tempfile.TemporaryDirectory() as d:
            os.makedirs(os.path.join(d, FOLDER))
            with open(os.path.join(d, FOLDER, "e.cpp"), "w") as fh:
                fh.write(text)
            problems, measured = check(d)
            ok = any(want in p for p in problems) if want else not problems
            print(f"self-test {name}: {'as expected' if ok else 'WRONG'}: {problems or 'no violation'}")
            failed += not ok
            if name == "clean file" and [m[1].split()[-1] for m in measured] != ["short_one", "f"]:
                print(f"self-test clean file: WRONG functions found: {measured}")
                failed += 1
    return 1 if failed else 0


def main(argv):
    if "--self-test" in argv:
        return self_test()
    limit, top, args = LIMIT, 0, []
    it = iter(argv)
    for a in it:
        if a == "--max":
            limit = int(next(it))
        elif a == "--top":
            top = int(next(it))
        else:
            args.append(a)
    root = args[0] if args else os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    problems, measured = check(root, limit)
    for length, where in measured[:top]:
        print(f"function length: {length:4d} {where}")
    for p in problems:
        print("function length: " + p)
    print(f"function length: {len(problems)} function(s) over {limit} lines among {len(measured)} in {FOLDER}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

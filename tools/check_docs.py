#!/usr/bin/env python3
"""Checks that the documentation matches the tree (the ctests docs_api_index
and docs_tree_clean; docs/decisions.md item 48).

  check_docs.py api  SOURCE_DIR   every public function declared in
                                  include/dkf/*.h has one line in
                                  docs/reference/api.md under its header's
                                  heading, and every function the index names
                                  is declared there
  check_docs.py tree SOURCE_DIR   the repository's files refer to nothing outside
                                  the repository (no machine paths, no
                                  sibling directories, no tracker numbers),
                                  every docs/*.md path they name and every
                                  relative link of a Markdown page (with its
                                  #heading) exists, and
                                  docs/README.md links every page of docs/

Each problem is printed as FILE:LINE: what; exit 1 if there is any.
"""
import os
import re
import sys

API_INDEX = "docs/reference/api.md"

# A function declaration at file scope: type words, then dkf_name( .
DECL = re.compile(r"(?:^|[;}])\s*((?:[A-Za-z_]\w*[\s*]+)+?)\*?\s*(dkf_[a-z0-9_]+)\s*\(", re.M)
# A line of the index: "| `dkf_name(args)` | what it computes |".
INDEX_ROW = re.compile(r"^\|\s*`(dkf_[a-z0-9_]+)\(")
INDEX_HEADER = re.compile(r"^## `dkf/([a-z0-9_]+\.h)`")


def strip_c(text):
    """The header without comments and preprocessor lines, newlines kept."""
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"^#ifdef __cplusplus\n.*?^#endif", "", text, flags=re.S | re.M)
    text = re.sub(r"^\s*#(?:[^\n]*\\\n)*[^\n]*", lambda m: "\n" * m.group(0).count("\n"),
                  text, flags=re.M)
    return text


def declared(src):
    """{function name: header} of every public function in include/dkf/."""
    out = {}
    inc = os.path.join(src, "include", "dkf")
    for h in sorted(os.listdir(inc)):
        if not h.endswith(".h"):
            continue
        with open(os.path.join(inc, h), encoding="utf-8") as f:
            text = strip_c(f.read())
        depth = 0
        flat = []
        for ch in text:            # keep file scope only: drop what is inside braces
            if ch == "{":
                depth += 1
                flat.append(";")
            elif ch == "}":
                depth -= 1
                flat.append(";")
            elif depth == 0:
                flat.append(ch)
        for m in DECL.finditer("".join(flat)):
            words = m.group(1).split()
            if words and words[0] not in ("return", "typedef"):
                out[m.group(2)] = h
    return out


def indexed(src, problems):
    """{function name: header heading} of the index's rows."""
    out = {}
    header = None
    path = os.path.join(src, API_INDEX)
    with open(path, encoding="utf-8") as f:
        for no, line in enumerate(f, 1):
            m = INDEX_HEADER.match(line)
            if m:
                header = m.group(1)
                continue
            m = INDEX_ROW.match(line)
            if not m:
                continue
            name = m.group(1)
            if name in out:
                problems.append("%s:%d: %s is listed twice" % (API_INDEX, no, name))
            out[name] = (header, no)
    return out


def check_api(src):
    """The index against the headers: (problems, summary)."""
    problems = []
    decl = declared(src)
    idx = indexed(src, problems)
    for name, h in sorted(decl.items()):
        if name not in idx:
            problems.append("%s: %s (include/dkf/%s) is missing" % (API_INDEX, name, h))
        elif idx[name][0] != h:
            problems.append("%s:%d: %s is declared in dkf/%s, listed under %s"
                            % (API_INDEX, idx[name][1], name, h, idx[name][0]))
    for name, (h, no) in sorted(idx.items()):
        if name not in decl:
            problems.append("%s:%d: %s is not declared in include/dkf/" % (API_INDEX, no, name))
    return problems, "%d public functions, %d index rows" % (len(decl), len(idx))


# What must not appear in a file of the tree: a tracker's issue number, a path
# into a sibling directory of the repository, a machine's absolute path (one
# that starts there, not .../work/... inside a relative path).
FORBIDDEN = [
    (re.compile(r"\bissues?(?: +#?|_?)[0-9]", re.I), "a tracker issue number"),
    (re.compile(r"\.\./shared\b"), "a path outside the repository"),
    (re.compile(r"(?<![\w.$}/-])/work[/]"), "a machine path"),
]
# The same number on the next line of a comment or paragraph.
WRAPPED = re.compile(r"\bissues?[ \t]*\n[ \t*#/-]*#?[0-9]", re.I)
DOC_PATH = re.compile(r"(?:(?<=\}/)|(?<![\w/.-]))(docs/[\w/-]+\.md)")  # also ${DIR}/docs/...
LINK = re.compile(r"\]\(([^)#:\s]*)(?:#([^)\s]*))?\)")  # a relative Markdown link or image
SKIP = (".png", ".lcmlog", ".bin", ".gz", ".key")


# What is checked: the sources, scripts and documents of the repository.
TREE = ["README.md", "CHANGELOG.md", "CMakeLists.txt", ".ci", "bench", "cmake", "docs",
        "examples", "include", "lcmtypes", "ports", "scenarios", "src", "tests", "tools"]


def tree_files(src):
    """The files of TREE below src, build directories and fuzz corpora left out."""
    for top in TREE:
        path = os.path.join(src, top)
        if os.path.isfile(path):
            yield top
        for d, dirs, names in os.walk(path):
            dirs[:] = sorted(x for x in dirs if not x.startswith(("build", "."))
                             and x != "corpus")
            for name in sorted(names):
                if not name.endswith(SKIP):
                    yield os.path.relpath(os.path.join(d, name), src)


def check_tree(src):
    """Every file of the tree, then the index of docs/: (problems, summary)."""
    problems = []
    read = 0
    for rel in tree_files(src):
        try:
            with open(os.path.join(src, rel), encoding="utf-8") as f:
                text = f.read()
        except UnicodeDecodeError:
            continue
        read += 1
        problems += file_problems(src, rel, text)
    problems += unindexed(src)
    return problems, "%d files read" % read


def file_problems(src, rel, text):
    """What one file refers to that it must not, or that does not exist."""
    out = []
    lines = text.split("\n")
    for m in WRAPPED.finditer(text):
        no = text.count("\n", 0, m.start()) + 1
        out.append("%s:%d: a tracker issue number: %s" % (rel, no, lines[no - 1].strip()[:100]))
    for no, line in enumerate(lines, 1):
        where = "%s:%d: " % (rel, no)
        out += [where + "%s: %s" % (what, line.strip()[:100])
                for pat, what in FORBIDDEN if pat.search(line)]
        out += [where + "%s does not exist" % m.group(1) for m in DOC_PATH.finditer(line)
                if not os.path.isfile(os.path.join(src, m.group(1)))]
        if rel.endswith(".md"):
            out += [where + p for p in link_problems(src, rel, line)]
    return out


def link_problems(src, rel, line):
    """The relative links of a Markdown line whose file or #heading is missing."""
    out = []
    for m in LINK.finditer(line):
        target = os.path.join(src, os.path.dirname(rel), m.group(1)) if m.group(1) \
            else os.path.join(src, rel)
        if not os.path.exists(target):
            out.append("link to %s, which does not exist" % m.group(1))
        elif m.group(2) and target.endswith(".md") and m.group(2) not in anchors(target):
            out.append("link to %s#%s: no such heading" % (m.group(1), m.group(2)))
    return out


def anchors(path):
    """The anchors GitHub makes of a page's headings: lower case, punctuation
    but - and _ dropped, spaces to -, a repeated heading numbered. (A comment
    line of a code block counts too: an anchor too many, never one missing.)"""
    out, seen = set(), {}
    with open(path, encoding="utf-8") as f:
        for line in f:
            m = re.match(r"#+ (.*)", line)
            if not m:
                continue
            a = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
            out.add(a if a not in seen else "%s-%d" % (a, seen[a]))
            seen[a] = seen.get(a, 0) + 1
    return out


def unindexed(src):
    """The pages of docs/ that docs/README.md does not link."""
    docs = os.path.join(src, "docs")
    with open(os.path.join(docs, "README.md"), encoding="utf-8") as f:
        linked = {os.path.normpath(os.path.join(docs, m))
                  for m in re.findall(r"\]\(([\w./-]+\.md)", f.read())}
    out = []
    for d, _, names in os.walk(docs):
        for name in sorted(names):
            path = os.path.normpath(os.path.join(d, name))
            if name.endswith(".md") and name != "README.md" and path not in linked:
                out.append("docs/README.md: %s is not linked" % os.path.relpath(path, src))
    return out


def main():
    if len(sys.argv) != 3 or sys.argv[1] not in ("api", "tree"):
        sys.stderr.write(__doc__)
        return 2
    problems, summary = (check_api if sys.argv[1] == "api" else check_tree)(sys.argv[2])
    for p in problems:
        print(p)
    print("check_docs %s: %s, %d problem(s)" % (sys.argv[1], summary, len(problems)))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

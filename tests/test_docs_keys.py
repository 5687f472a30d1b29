#!/usr/bin/python3
"""docs/case_file.md documents every key the case-file schema reads, and no other.

Usage: test_docs_keys.py REPO_ROOT [-v]

The schema is what the code reads through YamlSection. Every source file under
src/ and include/ that names YamlSection is scanned (comments stripped, calls
may be split over lines) for

- the reading calls `x.real("key", ...)`, `x.integer`, `x.boolean`, `x.text`,
  `x.choice`, `x.reals`, `x.points`, `x.section`, `x.list`, `x.has`,
  `x.free_map`, and any other YamlSection method that src/io/yaml_section.cpp
  defines on top of them (`x.index_lists`, ...);
- calls of helper functions that take a YamlSection& and pass one of their
  `const std::string&` parameters on as a key (`required_choice(s, "type",
  {...})`, `parse_face(f, raw, face_names[i], ...)`).

A key argument is resolved when it is a string literal, an element of a
string-list constant of the same file (`face_names[i]`), or the variable of a
`for (const char* key : {"a", "b"})` loop; other arguments are listed as
unresolved (informational: they are read with literals elsewhere).

Each read is attributed to the top-level section of the case file it is made
in, by following the YamlSection variables: `X = Y.section("k")`,
`for (YamlSection& X : Y.list("k"))`, vectors of list entries, the
YamlSection parameters of functions (from their call sites, also across
files), and functions registered as `&Model::from_yaml` (the material models).
A read whose section cannot be followed is "anywhere".

On the page, a key is documented in a section when it is backquoted in the
"Key..." column of a table that follows the section's heading (### `bodies`),
or, for a top-level key, when it is the heading itself.

Checks, each printing what is wrong and making the test exit 1:

1. every key read is documented in every section where the code reads it;
2. every option of every choice list (`x.choice(key, {...})`, required_choice,
   and the material models registered in src/materials/registry.cpp) is
   backquoted somewhere on the page;
3. the reverse: every backquoted name in the Key column of a key table (and
   every backquoted heading) is a key the code reads in that section. Values
   such as `geostatic` are never in a Key column, so they are not taken for
   keys;
4. the ESRI ASCII grid header keys of src/io/terrain_file.cpp and the page's
   "Header key" table agree (case-insensitively).
"""
import pathlib
import re
import sys

# The reading methods of YamlSection; more are found in src/io/yaml_section.cpp (readers_of).
READERS = {"real", "integer", "boolean", "text", "choice", "reals", "points", "section", "list", "has",
           "free_map"}
STRING = re.compile(r'"((?:[^"\\\n]|\\.)*)"')
IDENT = re.compile(r"[A-Za-z_]\w*")
ANYWHERE = None  # the section of a read whose YamlSection could not be followed
KEYWORDS = {"if", "for", "while", "switch", "return", "catch", "sizeof", "else", "do"}


# ------------------------------------------------------------ C++ scanning

def skip_literal(src, i):
    """Index just past the string or char literal starting at src[i]."""
    quote, j, n = src[i], i + 1, len(src)
    while j < n and src[j] != quote:
        j += 2 if src[j] == "\\" else 1
    return j + 1


def strip_comments(src):
    """Replace // and /* */ comments by blanks (newlines kept), leave literals alone."""
    out, i, n = [], 0, len(src)
    while i < n:
        c = src[i]
        if c in "\"'":
            j = skip_literal(src, i)
            out.append(src[i:j])
            i = j
        elif src.startswith("//", i):
            j = src.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif src.startswith("/*", i):
            j = src.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", src[i:j]))
            i = j
        else:
            out.append(c)
            i += 1
    return "".join(out)


def balanced(src, i, open_ch, close_ch):
    """Index just past the bracket matching src[i] == open_ch (literals skipped)."""
    depth, n = 0, len(src)
    while i < n:
        c = src[i]
        if c in "\"'":
            i = skip_literal(src, i)
            continue
        if c == open_ch:
            depth += 1
        elif c == close_ch:
            depth -= 1
            if depth == 0:
                return i + 1
        i += 1
    return n


def split_top(text, opening="([{", closing=")]}"):
    """Split at commas outside brackets and literals."""
    out, depth, start, k = [], 0, 0, 0
    while k < len(text):
        c = text[k]
        if c in "\"'":
            k = skip_literal(text, k)
            continue
        if c in opening:
            depth += 1
        elif c in closing:
            depth -= 1
        elif c == "," and depth == 0:
            out.append(text[start:k].strip())
            start = k + 1
        k += 1
    if text.strip():
        out.append(text[start:].strip())
    return out


def call_args(src, i):
    """Arguments of the call whose '(' is at src[i], and the index past ')'."""
    end = balanced(src, i, "(", ")")
    return split_top(src[i + 1:end - 1]), end


def literal(arg):
    m = STRING.fullmatch(arg.strip())
    return m.group(1) if m else None


def braced_strings(arg):
    """["a", "b"] for an argument `{"a", "b"}` of literals only, else None."""
    arg = arg.strip()
    if arg.startswith("{") and arg.endswith("}") and not STRING.sub("", arg[1:-1]).replace(",", "").strip():
        return STRING.findall(arg)
    return None


def string_lists(src):
    """NAME -> [strings] for every `NAME = {"a", "b", ...}` / `NAME[6] = {...}` of literals only."""
    lists = {}
    for m in re.finditer(r"(\w+)\s*(?:\[\s*\w*\s*\])?\s*=\s*\{", src):
        start = m.end() - 1
        values = braced_strings(src[start:balanced(src, start, "{", "}")])
        if values:
            lists[m.group(1)] = values
    return lists


def range_for_lists(src):
    """(start, end, NAME, [strings]) of every `for (... NAME : {"a", "b"})` and its statement."""
    out = []
    for m in re.finditer(r"\bfor\s*\(", src):
        close = balanced(src, m.end() - 1, "(", ")")
        h = re.match(r"[^:;]*?\b(\w+)\s*:\s*(\{.*\})\s*$", src[m.end():close - 1], re.S)
        if not h or braced_strings(h.group(2)) is None:
            continue
        rest = close + re.match(r"\s*", src[close:]).end()
        end = balanced(src, rest, "{", "}") if src.startswith("{", rest) else src.find(";", rest) + 1
        out.append((close, end, h.group(1), braced_strings(h.group(2))))
    return out


def readers_of(path):
    """The YamlSection methods that read a key: those whose definition in
    yaml_section.cpp registers its `key` parameter (has, child) or passes it on
    to another reading method (index_lists, ...). Fixed point."""
    if not path.exists():
        return set()
    src = strip_comments(path.read_text(encoding="utf-8"))
    bodies = {}
    for m in re.finditer(r"YamlSection::(\w+)\s*(\()\s*const\s+std::string\s*&\s*key\b", src):
        start = src.find("{", balanced(src, m.start(2), "(", ")"))
        if start >= 0:
            bodies.setdefault(m.group(1), []).append(src[start:balanced(src, start, "{", "}")])
    readers, changed = {"has", "child"}, True
    while changed:
        changed = False
        for name, texts in bodies.items():
            if name not in readers and any(
                    "read_.insert(key)" in t or re.search(r"\b(%s)\s*\(\s*key\b" % "|".join(readers), t)
                    for t in texts):
                readers.add(name)
                changed = True
    return readers - {"child"}


class Function:
    def __init__(self, source, name, params, lo, hi):
        self.source, self.name, self.params, self.lo, self.hi = source, name, params, lo, hi
        self.names = [(IDENT.findall(p) or [""])[-1] for p in params]
        self.sections = [i for i, p in enumerate(params) if re.search(r"\bYamlSection\s*&", p)]
        self.bindings = []   # (position, variable, kind, argument, key): kind "param", "root", "child", "vector", "entry"


class Source:
    def __init__(self, path, root):
        self.rel = str(path.relative_to(root))
        self.text = strip_comments(path.read_text(encoding="utf-8", errors="replace"))
        self.lists = string_lists(self.text)
        self.loops = range_for_lists(self.text)
        self.functions = []
        for m in re.finditer(r"\b(\w+)\s*\(", self.text):
            if m.group(1) in KEYWORDS:
                continue
            close = balanced(self.text, m.end() - 1, "(", ")")
            rest = re.match(r"\s*(?:const\s*)?(?:noexcept\s*)?(?:override\s*)?\{", self.text[close:])
            if not rest:
                continue
            lo = close + rest.end() - 1
            params = split_top(self.text[m.end():close - 1], "<([{", ">)]}")
            self.functions.append(Function(self, m.group(1), params, lo, balanced(self.text, lo, "{", "}")))
        # Innermost first, so that a position belongs to the smallest enclosing definition.
        self.functions.sort(key=lambda f: f.hi - f.lo)

    def line(self, index):
        return self.text.count("\n", 0, index) + 1

    def function_at(self, index):
        return next((f for f in self.functions if f.lo <= index < f.hi), None)


# ------------------------------------------------------------ the schema read by the code

def scan_code(root):
    READERS.update(readers_of(root / "src" / "io" / "yaml_section.cpp"))
    sources = []
    for pattern in ("src/**/*.cpp", "include/**/*.hpp"):
        for p in sorted(root.glob(pattern)):
            s = Source(p, root)
            if re.search(r"\bYamlSection\b", s.text):
                sources.append(s)
    functions = [f for s in sources for f in s.functions]
    by_name = {}
    for f in functions:
        by_name.setdefault(f.name, []).append(f)

    call = re.compile(r"(?:(\w+)\s*(?:\[[^\]]*\])?\s*(?:\.|->)\s*)?\b(\w+)\s*\(")
    all_calls = {}
    for s in sources:
        found = []
        for m in call.finditer(s.text):
            if m.group(2) in KEYWORDS:
                continue
            args, end = call_args(s.text, m.end() - 1)
            if re.match(r"\s*(?:const\s*)?(?:noexcept\s*)?(?:override\s*)?\{", s.text[end:end + 40]):
                continue  # a definition, not a call
            found.append((m.group(1), m.group(2), args, m.start()))
        all_calls[s.rel] = found

    def calls(src, lo=0, hi=None):
        """(variable or None, name, args, position) of every call in src.text[lo:hi]."""
        hi = len(src.text) if hi is None else hi
        return [c for c in all_calls[src.rel] if lo <= c[3] < hi]

    # Helpers: function name -> {param index: "key" | "choices"}, to a fixed point.
    helpers, changed = {}, True
    while changed:
        changed = False
        for f in functions:
            roles = dict(helpers.get(f.name, {}))
            for var, name, args, _ in calls(f.source, f.lo, f.hi):
                for arg, role in key_roles(name, args, helpers):
                    if role == "key" and arg in f.names and "string" in f.params[f.names.index(arg)]:
                        roles.setdefault(f.names.index(arg), "key")
            if roles:
                for i, p in enumerate(f.params):
                    if "vector<std::string>" in p and i not in roles:
                        roles[i] = "choices"  # e.g. required_choice(s, key, choices)
            if roles and roles != helpers.get(f.name, {}):
                helpers[f.name] = roles
                changed = True

    # YamlSection variables and where they come from.
    for s in sources:
        t = s.text
        for f in s.functions:
            for i in f.sections:
                f.bindings.append((f.lo, f.names[i], "param", i, None))
        patterns = [
            (r"\bYamlSection\s+(\w+)\s*\(\s*\w+\s*,\s*\"\"", "root"),
            (r"\bYamlSection\s+(\w+)\s*=\s*(\w+)\s*(?:\[[^\]]*\])?\s*\.\s*section\s*\(\s*([^)]*)\)", "child"),
            (r"\bYamlSection\s*&?\s*(\w+)\s*:\s*(\w+)\s*\.\s*list\s*\(\s*([^)]*)\)", "child"),
            (r"std::vector\s*<\s*YamlSection\s*>\s*&?\s*(\w+)\s*=\s*(\w+)\s*\.\s*list\s*\(\s*([^)]*)\)", "child"),
            (r"\bYamlSection\s*&?\s*(\w+)\s*:\s*(\w+)\s*\)", "entry"),
        ]
        for pattern, kind in patterns:
            for m in re.finditer(pattern, t):
                f = s.function_at(m.start())
                if f is not None:
                    groups = m.groups() + (None, None)
                    f.bindings.append((m.start(), groups[0], kind, groups[1], groups[2]))
        for f in s.functions:
            f.bindings.sort(key=lambda b: b[0])

    # Contexts (sets of section paths) of parameters, to a fixed point.
    param_context = {}   # (function name, param index) -> set of paths

    def context(f, var, at, depth=0):
        """Section paths of YamlSection variable `var` at position `at` in function f."""
        if f is None or depth > 20:
            return {ANYWHERE}
        binding = None
        for b in f.bindings:
            if b[0] <= at and b[1] == var:
                binding = b
        if binding is None:
            outer = f.source.function_at(f.lo - 1) if f.lo > 0 else None
            return context(outer, var, at, depth + 1) if outer is not None and outer is not f else {ANYWHERE}
        _, _, kind, arg, key = binding
        if kind == "root":
            return {""}
        if kind == "param":
            return set(param_context.get((f.name, arg), set())) or {ANYWHERE}
        parents = context(f, arg, binding[0], depth + 1)
        if kind == "entry":
            return parents
        name = literal(key.split(",")[0]) if key else None
        name = name if name is not None else "*"
        return {ANYWHERE if p is ANYWHERE else (name if p == "" else p + "." + name) for p in parents}

    def arg_context(src, arg, at):
        m = re.match(r"(\w+)\s*(?:\[[^\]]*\])?$", arg.strip())
        return context(src.function_at(at), m.group(1), at) if m else {ANYWHERE}

    changed = True
    for _ in range(50):
        if not changed:
            break
        changed = False
        for s in sources:
            for var, name, args, at in calls(s):
                for f in by_name.get(name, []):
                    for i in f.sections:
                        if i < len(args):
                            new = arg_context(s, args[i], at) - {ANYWHERE}
                            old = param_context.setdefault((f.name, i), set())
                            if not new <= old:
                                old |= new
                                changed = True
            # Functions registered by pointer (&Model::from_yaml) get the sections of
            # the YamlSection parameters of the functions of the registering file.
            for m in re.finditer(r"&\s*(?:\w+::)*(\w+)\b", s.text):
                registering = set()
                for g in s.functions:
                    for i in g.sections:
                        registering |= param_context.get((g.name, i), set())
                for f in by_name.get(m.group(1), []):
                    for i in f.sections:
                        old = param_context.setdefault((f.name, i), set())
                        if not registering <= old:
                            old |= registering
                            changed = True

    reads = {}       # key -> {top-level section or ANYWHERE: first "file:line"}
    choices = {}     # option -> "file:line (key)"
    unresolved = []
    for s in sources:
        for var, name, args, at in calls(s):
            if name not in READERS and name not in helpers:
                continue
            if name in READERS and var is None:
                continue  # not a method call on a YamlSection
            where = f"{s.rel}:{s.line(at)}"
            f = s.function_at(at)
            if name in READERS:
                paths = context(f, var, at)
            else:
                target = by_name[name][0]
                paths = arg_context(s, args[target.sections[0]], at) if target.sections and \
                    target.sections[0] < len(args) else {ANYWHERE}
            own_params = set(f.names) if f is not None else set()
            key_names = []
            for arg, role in key_roles(name, args, helpers):
                if role == "key":
                    key_names = resolve_keys(s, arg, at)
                    if key_names is None:
                        key_names = []
                        if not (arg in own_params and f.name in helpers):
                            unresolved.append(f"{where}: {name}({arg}, ...)")
                    for k in key_names:
                        for p in paths:
                            top = p if p is ANYWHERE else p.split(".")[0]
                            reads.setdefault(k, {}).setdefault(top, where)
                else:
                    options = braced_strings(arg)
                    base = re.match(r"(\w+)$", arg)
                    if options is None and base and base.group(1) in s.lists:
                        options = s.lists[base.group(1)]
                    if options is None:
                        if not (arg in own_params and f.name in helpers):
                            unresolved.append(f"{where}: choices {arg} of {name}(...)")
                        continue
                    for o in options:
                        choices.setdefault(o, f"{where} ({', '.join(key_names) or name})")

    # The material models: the values of `model`.
    registry = root / "src" / "materials" / "registry.cpp"
    if registry.exists():
        reg = strip_comments(registry.read_text(encoding="utf-8"))
        for m in re.finditer(r'\{\s*"(\w+)"\s*,\s*&?\s*[\w:]+from_yaml\s*\}', reg):
            choices.setdefault(m.group(1), f"src/materials/registry.cpp:{reg.count(chr(10), 0, m.start()) + 1} (model)")
    return reads, choices, unresolved


def key_roles(name, args, helpers):
    """[(argument, role)] of a call: the reader's key (and choices) or the helper's."""
    if name in READERS:
        roles = [(args[0], "key")] if args else []
        if name == "choice" and len(args) > 1:
            roles.append((args[1], "choices"))
        return roles
    if name in helpers:
        return [(args[i], role) for i, role in sorted(helpers[name].items()) if i < len(args)]
    return []


def resolve_keys(src, arg, at):
    """The key(s) an argument names, or None."""
    value = literal(arg)
    if value is not None:
        return [value]
    base = re.match(r"(\w+)\s*(?:\[.*\])?$", arg.strip())
    if base and base.group(1) in src.lists:
        return src.lists[base.group(1)]
    for lo, hi, var, values in src.loops:
        if lo <= at < hi and arg.strip() == var:
            return values
    return None


# ------------------------------------------------------------ the page

def scan_doc(doc):
    """name -> {section: line} for names in Key columns (section: the heading's
    key, "" for a heading itself, ANYWHERE under other headings); the ESRI
    header keys of the "Header key" table; everything backquoted."""
    documented, header_keys = {}, {}
    lines, section, i = doc.split("\n"), ANYWHERE, 0
    while i < len(lines):
        line = lines[i]
        if not line.startswith("|"):
            heading = re.match(r"#+\s+(.*)", line)
            if heading:
                named = re.match(r"`([^`]+)`", heading.group(1))
                section = named.group(1) if named else ANYWHERE
                if named:
                    documented.setdefault(section, {}).setdefault("", i + 1)
            i += 1
            continue
        j = i
        while j < len(lines) and lines[j].startswith("|"):
            j += 1
        header = [c.strip() for c in lines[i].strip().strip("|").split("|")]
        key_col = next((k for k, c in enumerate(header) if re.match(r"Key\b", c)), None)
        esri_col = next((k for k, c in enumerate(header) if c == "Header key"), None)
        for row in range(i + 2, j):
            cells = [c.strip() for c in lines[row].strip().strip("|").split("|")]
            if key_col is not None and key_col < len(cells):
                for name in re.findall(r"`([^`]+)`", cells[key_col]):
                    documented.setdefault(name, {}).setdefault(section, row + 1)
            if esri_col is not None and esri_col < len(cells):
                for name in re.findall(r"`([^`]+)`", cells[esri_col]):
                    header_keys.setdefault(name.lower(), row + 1)
        i = j
    return documented, header_keys, set(re.findall(r"`([^`\n]+)`", doc))


def section_name(section):
    return "anywhere" if section is ANYWHERE else "the top level" if section == "" else f"`{section}`"


def main():
    args = [a for a in sys.argv[1:] if a != "-v"]
    root = pathlib.Path(args[0] if args else ".").resolve()
    doc = (root / "docs" / "case_file.md").read_text(encoding="utf-8")
    reads, choices, unresolved = scan_code(root)
    documented, doc_header_keys, backquoted = scan_doc(doc)

    terrain = root / "src" / "io" / "terrain_file.cpp"
    header_keys = []
    if terrain.exists():
        for values in string_lists(strip_comments(terrain.read_text(encoding="utf-8"))).values():
            if "ncols" in values:
                header_keys = values

    if "-v" in sys.argv:
        for k in sorted(reads):
            print(f"  key {k:20s} " + ", ".join(f"{section_name(s)} ({w})" for s, w in reads[k].items()))
        for o in sorted(choices):
            print(f"  choice {o:17s} {choices[o]}")

    failures = []
    for k in sorted(reads):
        places = documented.get(k, {})
        for section, where in reads[k].items():
            if section is ANYWHERE:
                ok = bool(places)
            else:
                ok = section in places or ANYWHERE in places
            if not ok:
                failures.append(f"key `{k}` of {section_name(section)} (read at {where}) is not documented there: "
                                f"not in a Key column under the heading ### `{section}`"
                                if section not in (ANYWHERE, "") else
                                f"key `{k}` (read at {where}) is not documented: no heading ### `{k}` "
                                f"and not in a Key column of docs/case_file.md")
    for o in sorted(choices):
        if o not in backquoted:
            failures.append(f"choice `{o}` (of {choices[o]}) is not written as `{o}` in docs/case_file.md")
    for name in sorted(documented):
        for section, line in documented[name].items():
            code = reads.get(name, {})
            if "." in name:
                ok = all(p in reads for p in name.split("."))
            elif section is ANYWHERE:
                ok = bool(code)
            else:
                ok = section in code or ANYWHERE in code
            if not ok:
                failures.append(f"docs/case_file.md:{line}: `{name}` is documented as a key of "
                                f"{section_name(section)}, but the code reads no such key there"
                                + (f" (it reads it in {', '.join(section_name(s) for s in code)})" if code else ""))
    known_header = {h.lower() for h in header_keys}
    if not header_keys:
        failures.append("src/io/terrain_file.cpp: found no list of ESRI header keys (a string list holding \"ncols\")")
    for h in sorted(known_header - set(doc_header_keys)):
        failures.append(f"ESRI header key `{h}` of src/io/terrain_file.cpp is not in the Header key table")
    for h in sorted(set(doc_header_keys) - known_header):
        failures.append(f"docs/case_file.md:{doc_header_keys[h]}: header key `{h}` is not read by src/io/terrain_file.cpp")

    pairs = sum(len(v) for v in reads.values())
    files = sorted({w.split(":")[0] for v in reads.values() for w in v.values()})
    print(f"docs_keys: {len(reads)} keys ({pairs} key-section pairs) read in {', '.join(files)}; "
          f"{len(choices)} choice values; {len(header_keys)} ESRI header keys; "
          f"{sum(len(v) for v in documented.values())} names in the page's Key columns and headings")
    if unresolved:
        print("note: key or choice arguments that are not literals (not checked):")
        for u in unresolved:
            print("  " + u)
    if failures:
        print(f"FAIL: {len(failures)} problem(s):")
        for f in failures:
            print("  " + f)
        return 1
    print("docs_keys: ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())

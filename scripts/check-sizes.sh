#!/usr/bin/env bash
# The size check: no C++ source file (*.cpp, *.h, *.inc) of src/, apps/, python/, bench/,
# fuzz/ or tests/ over 700 lines, no function over 150 lines. Test files are checked like the
# rest: a long test is as hard to read as long code. Functions come from universal-ctags
# (their first and last lines; a lambda counts on its own too, inside the function that holds it).
#
# scripts/size-limits.txt lists the exceptions, each with its size when it was listed as its
# ceiling: an exception may shrink but not grow, and anything over the limits and not listed
# fails. An entry no longer needed (now within the limit, or gone) or smaller than its
# ceiling is reported so that it can be removed or lowered; --strict makes that a failure too.
#
# Usage: scripts/check-sizes.sh [--strict]
# Exit: 0 passed, 1 a size over its limit (one line each: FILE:LINE, name, size, limit),
#       77 skipped: universal-ctags is missing (scripts/install-deps.sh installs it).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"

if ! command -v ctags >/dev/null || ! ctags --version 2>/dev/null | grep -q "Universal Ctags" ||
   ! ctags --list-features 2>/dev/null | grep -q '^json'; then
  echo "check-sizes: skipped: universal-ctags with JSON output is not installed" \
       "(apt-get install universal-ctags, or scripts/install-deps.sh)" >&2
  exit 77
fi
python="$(command -v /usr/bin/python3 || command -v python3)"

files=()
while IFS= read -r -d '' f; do files+=("$f"); done < <(
  find src apps python bench fuzz tests -type f \( -name '*.cpp' -o -name '*.h' -o -name '*.inc' \) -print0 | sort -z)

# The check, fed one JSON line per function definition (name, scope, first and last line).
read -r -d '' program <<'PY' || true
import json, re, sys

FILE_LIMIT, FUNCTION_LIMIT = 700, 150
allow_path, args = sys.argv[1], sys.argv[2:]
strict = bool(args) and args[0] == "--strict"
files = args[1:] if strict else args

def display_name(tag):
    """A function as a reader finds it: Scope::Name, a test as TEST(Suite, Name), a lambda
    as (lambda in Scope)."""
    name, scope = tag["name"], tag.get("scope", "")
    scope = "::".join(p for p in scope.split("::") if not p.startswith("__anon"))
    if name.startswith("__anon"):
        return "(lambda in %s)" % (scope or "file scope")
    m = re.match(r"/\^\s*((?:TEST|TEST_F|TEST_P|TYPED_TEST)\s*\([^)]*\))", tag.get("pattern", ""))
    if m and name.startswith("TEST"):
        return re.sub(r"\s+", " ", m.group(1))
    return scope + "::" + name if scope else name

# Sizes now: (path, name) -> (size, first line); a name defined twice keeps its longest.
sizes = {}
for path in files:
    with open(path, "rb") as f:
        sizes[(path, "")] = (f.read().count(b"\n"), 1)
for line in sys.stdin:
    tag = json.loads(line)
    if tag.get("_type") != "tag" or "end" not in tag:
        continue
    key = (tag["path"], display_name(tag))
    size = tag["end"] - tag["line"] + 1
    if size > sizes.get(key, (0, 0))[0]:
        sizes[key] = (size, tag["line"])

# The allow-list: "CEILING PATH" for a file, "CEILING PATH NAME" for a function.
allowed = {}
with open(allow_path) as f:
    for number, text in enumerate(f, 1):
        text = text.strip()
        if not text or text.startswith("#"):
            continue
        parts = text.split(None, 2)
        if len(parts) < 2 or not parts[0].isdigit():
            sys.exit("%s:%d: expected CEILING PATH [FUNCTION], got: %s" % (allow_path, number, text))
        allowed[(parts[1], parts[2] if len(parts) == 3 else "")] = (int(parts[0]), number)

failures, notes = [], []
for (path, name), (size, first) in sorted(sizes.items()):
    limit = FUNCTION_LIMIT if name else FILE_LIMIT
    what = "function %s" % name if name else "file"
    if size <= limit:
        continue
    ceiling = allowed.get((path, name), (None,))[0]
    if ceiling is None:
        failures.append("%s:%d: %s: %d lines, limit %d" % (path, first, what, size, limit))
    elif size > ceiling:
        failures.append("%s:%d: %s: %d lines, limit %d (its ceiling in %s; it may shrink, not grow)"
                        % (path, first, what, size, ceiling, allow_path))
for (path, name), (ceiling, number) in sorted(allowed.items(), key=lambda e: e[1][1]):
    size = sizes.get((path, name), (None,))[0]
    what = "function %s" % name if name else "file"
    limit = FUNCTION_LIMIT if name else FILE_LIMIT
    if size is None:
        notes.append("%s:%d: %s %s: not found: remove the entry" % (allow_path, number, path, what))
    elif size <= limit:
        notes.append("%s:%d: %s %s: %d lines, within the limit %d: remove the entry"
                     % (allow_path, number, path, what, size, limit))
    elif size < ceiling:
        notes.append("%s:%d: %s %s: %d lines, its ceiling %d: lower the ceiling to %d"
                     % (allow_path, number, path, what, size, ceiling, size))

for line in failures:
    print("check-sizes: " + line)
for line in notes:
    print("check-sizes: note: " + line)
exceptions = len(allowed)
if failures or (strict and notes):
    print("check-sizes: failed: files at most %d lines, functions at most %d; %d over (%d listed exceptions)"
          % (FILE_LIMIT, FUNCTION_LIMIT, len(failures), exceptions))
    sys.exit(1)
print("check-sizes: passed: %d files, functions at most %d lines, files at most %d (%d listed exceptions)"
      % (len(files), FUNCTION_LIMIT, FILE_LIMIT, exceptions))
PY

ctags --language-force=C++ --sort=no --kinds-C++=f --fields=+ne --output-format=json -o - "${files[@]}" |
  "$python" -c "$program" scripts/size-limits.txt "$@" "${files[@]}"

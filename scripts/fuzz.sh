#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, AddressSanitizer + UndefinedBehaviorSanitizer) and runs
# each for the given number of seconds (default 60), one after the other.
#   scripts/fuzz.sh [SECONDS] [TARGET...]      targets: fuzz_scene_file fuzz_template_file fuzz_mesh_import fuzz_image_decode
# Environment: FUZZ_BUILD_DIR (default build-fuzz; CI passes build-asan, which has them
# too), FUZZ_JOBS (parallel fuzzing processes per target, default 1), FUZZ_KEEP_CORPUS=1
# (merge what the run found into fuzz/corpus/ instead of a scratch folder).
# Inputs found to crash are written to fuzz/regressions/<target>/ (replayed by the test
# suite's FuzzRegression tests once kept); the script then exits non-zero. For the targets
# whose libraries run in a child process (Assimp, the image decoders), a finding inside the
# library is triaged by its signature (the sanitizer's kind of error and the first frame in
# the library): one with the signature of an input kept in fuzz/regressions/<target>/ (those
# are replayed first; the FuzzRegression tests check that the child process contains them)
# is known and counted; a new one fails the run too, naming its file, which is copied there:
# committing it, under a name that says what it is, is its triage.
# FUZZ_TRIAGE_MAX (default 60) findings are replayed per target; any more fail the run.
# FUZZ_LIBRARY_FINDINGS=report (scripts/test.sh, CI): a new finding inside a contained
# library is kept and named but does not fail the run.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_scene_file fuzz_template_file fuzz_mesh_import fuzz_image_decode)
build="${FUZZ_BUILD_DIR:-build-fuzz}"
jobs="${FUZZ_JOBS:-1}"

scripts/install-deps.sh clang libclang-rt-14-dev
if [ ! -f "$build/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DLIGHTMESH_FUZZ=ON -DLIGHTMESH_SANITIZE=address,undefined \
    -DLIGHTMESH_BUILD_TESTS=OFF -DLIGHTMESH_BUILD_BENCHMARKS=OFF >/dev/null
fi
ninja -C "$build" -j"$(nproc)" "${targets[@]}"

# Assimp and TBB are not instrumented; leaks are checked by the ASan test run instead of
# here, where a leak report would stop the fuzzer at the first input.
export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=0:allocator_may_return_null=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
# A finding's signature: the sanitizer's (or libFuzzer's) kind of error and the function
# of the first frame inside the library, e.g. "stack-overflow Assimp::ColladaParser::ReadNode".
finding_signature() {
  local kind func
  kind="$(printf '%s\n' "$1" | grep -oE 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer|UndefinedBehaviorSanitizer): [A-Za-z-]+' |
          head -n 1 | awk '{print $3}')"
  [ -n "$kind" ] || kind="$(printf '%s\n' "$1" | grep -oE 'runtime error: [a-z ]+' | head -n 1 | tr ' ' '-')"
  func="$(printf '%s\n' "$2" | sed -E 's/^ +#[0-9]+ 0x[0-9a-f]+ in ([^ (]+).*/\1/')"
  echo "${kind:-crash} ${func:-unknown}"
}

status=0
for t in "${targets[@]}"; do
  seeds="fuzz/corpus/$t"
  crashes="fuzz/regressions/$t"
  mkdir -p "$crashes"
  if [ "${FUZZ_KEEP_CORPUS:-0}" = 1 ]; then work="$seeds"; else work="$(mktemp -d)"; fi
  extra=(); [ -f "fuzz/$t.dict" ] && extra+=(-dict="fuzz/$t.dict")
  [ "$jobs" -gt 1 ] && extra+=(-jobs="$jobs" -workers="$jobs")
  max_len=4096; [ "$t" = fuzz_template_file ] && max_len=16384
  # Assimp allocates what a file's counts say: above 1 GiB, ASan returns null (new throws,
  # the import fails as it would on the budget) instead of libFuzzer calling it an OOM.
  asan="$ASAN_OPTIONS"
  prefix="$crashes/"
  # Assimp and the image decoders have crashes and endless loops of their own, which the
  # renderer contains (child process, deadline): fork mode goes on past them, and each
  # finding is triaged below by the library its first frame is in.
  contained=""
  case "$t" in
    fuzz_mesh_import) contained="libassimp"; library="Assimp" ;;
    fuzz_image_decode) contained="libpng|libjpeg|stbi__|libOpenEXR|libIex|libImath"; library="libpng, libjpeg-turbo, stb_image or OpenEXR" ;;
  esac
  if [ -n "$contained" ]; then
    asan="$asan:max_allocation_size_mb=1024"
    # The signatures of the findings kept so far: the known ones.
    signatures=()
    for f in "$crashes"/*; do
      [ -f "$f" ] || continue
      report="$(ASAN_OPTIONS="$asan" timeout 60 "$build/fuzz/$t" -timeout=5 -rss_limit_mb=2048 "$f" 2>&1 || true)"
      first="$(printf '%s\n' "$report" | grep -E '^ +#[0-9]+ ' | grep -E "$contained" | head -n 1 || true)"
      [ -z "$first" ] || signatures+=("$(finding_signature "$report" "$first")")
    done
    findings="$build/findings/$t"  # this run's findings only
    rm -rf "$findings"
    mkdir -p "$findings"
    prefix="$findings/"
    extra+=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
  fi
  echo "fuzz: $t for $seconds s" >&2
  log="$(mktemp)"
  code=0
  ASAN_OPTIONS="$asan" "$build/fuzz/$t" "$work" "$seeds" "${extra[@]}" -max_total_time="$seconds" \
      -max_len="$max_len" -timeout=10 -rss_limit_mb=2048 \
      -artifact_prefix="$prefix" -print_final_stats=1 >"$log" 2>&1 || code=$?
  # In fork mode libFuzzer (14) exits with the code of the last job that ended, even an
  # ignored timeout or crash ("INFO: exiting: 70"): a run that reached its time limit is
  # judged by the triage of its findings below, not by that code. The jobs' output shares
  # the log with the parent's, so the parent's line may start mid-line (not anchored).
  if [ "$code" -ne 0 ] && [ -n "$contained" ] &&
      grep -qE "INFO: fuzzed for [0-9]+ seconds, wrapping up soon" "$log"; then
    echo "fuzz: $t: fork mode ended with code $code after its time limit (the last job's); findings triaged below" >&2
    code=0
  fi
  if [ "$code" -ne 0 ]; then
    status=1
    echo "fuzz: $t FAILED; the input is in $prefix -- last lines of its log:" >&2
    tail -n 40 "$log" >&2
  fi
  grep -hE "^(#[0-9]+[[:space:]]+DONE|Done [0-9]+ runs|stat::number_of_executed_units|stat::peak_rss_mb)" "$log" fuzz-*.log >&2 2>/dev/null || true
  if [ -n "$contained" ]; then
    grep -E "^#[0-9]+: .*oom/timeout/crash" "$log" | tail -n 1 >&2 || true
    # Whose code is at fault: the first frame of the replayed report in the library or in lm::.
    # A finding in the library is known when a kept regression has its signature.
    n=0; inside=0; known=0; memory=0; untriaged=()
    for f in "$findings"/*; do
      [ -f "$f" ] || continue
      if [ "$n" -ge "${FUZZ_TRIAGE_MAX:-60}" ]; then untriaged+=("$f"); continue; fi
      n=$((n + 1))
      report="$(ASAN_OPTIONS="$asan" timeout 60 "$build/fuzz/$t" -timeout=5 -rss_limit_mb=2048 "$f" 2>&1 || true)"
      first="$(printf '%s\n' "$report" | grep -E '^ +#[0-9]+ ' | grep -E "$contained|lm::" | head -n 1 || true)"
      if printf '%s' "$first" | grep -qE "$contained"; then
        inside=$((inside + 1))
        signature="$(finding_signature "$report" "$first")"
        if printf '%s\n' "${signatures[@]}" | grep -qxF "$signature"; then
          known=$((known + 1))
        else
          # FUZZ_LIBRARY_FINDINGS=report (CI): kept and named, not a failure -- the library
          # runs contained in a child process, and a run's random new finding in it must not
          # block a change to lightmesh; a developer's run fails on it for triage.
          [ "${FUZZ_LIBRARY_FINDINGS:-fail}" = report ] || status=1
          signatures+=("$signature")  # its duplicates in this run are not new again
          cp "$f" "$crashes/"
          echo "fuzz: $t: a new finding inside $library's code ($signature), kept in $crashes/$(basename "$f"):" \
               "fix it, or commit it there under a name that says what it is once triaged" >&2
        fi
      elif [ -z "$first" ] && printf '%s' "$report" | grep -q "libFuzzer: out-of-memory"; then
        # Over the RSS limit with no allocation to blame: counted, not attributed.
        memory=$((memory + 1))
      else
        status=1
        cp "$f" "$crashes/"
        echo "fuzz: $t: a finding outside $library, kept in $crashes/$(basename "$f")${first:+: $first}" >&2
      fi
    done
    echo "fuzz: $t: $n findings replayed, $inside of them inside $library's own code ($known of those known from $crashes/; contained by the child process; in $findings)" >&2
    [ "$memory" -eq 0 ] || echo "fuzz: $t: $memory of them over the RSS limit without a stack (unattributed)" >&2
    if [ ${#untriaged[@]} -gt 0 ]; then
      status=1
      echo "fuzz: $t: ${#untriaged[@]} more findings not replayed (FUZZ_TRIAGE_MAX=${FUZZ_TRIAGE_MAX:-60}), so not triaged: ${untriaged[*]}" >&2
    fi
  fi
  rm -f "$log" fuzz-*.log
  [ "${FUZZ_KEEP_CORPUS:-0}" = 1 ] || rm -rf "$work"
done
exit $status

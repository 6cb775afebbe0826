#!/usr/bin/env bash
# mpi_render_test.sh -- `mpirun -np N lightmesh render` against one process.
#   mpi_render_test.sh CASE LIGHTMESH MPIEXEC SOURCE_DIR
# CASE: identical | failure | killed | bad-scene | schedule | templates | other-commands | many-lights
# Run by ctest (tests/CMakeLists.txt), which sets OMPI_ALLOW_RUN_AS_ROOT{,_CONFIRM}=1: CI
# runs as root. --oversubscribe: more ranks than this machine's 2 cores.
set -u
case_name="$1" lightmesh="$2" mpiexec="$3" source_dir="$4"
work="$(mktemp -d "${TMPDIR:-/tmp}/lightmesh-mpi-test.XXXXXX")"
trap 'rm -rf "$work"' EXIT
mpi() { local n="$1"; shift; timeout 120 "$mpiexec" --oversubscribe -np "$n" "$@"; }
fail() { echo "FAIL: $*" >&2; exit 1; }
size=(--width 96 --height 72)

case "$case_name" in
identical)
    # Every shadow method and light-mesh variant (and the penumbra mode): 1, 2, 3 ranks and 1, 2 threads give the
    # bytes of a single-process render.
    methods=("--shadows soft" "--shadows soft --light-radius 0.4 --soft-samples 16" "--shadows rt"
             "--shadows area --light-radius 0.15 --samples 4" "--shadows denoised --light-radius 0.15 --samples 2")
    for v in grid templates reduced none inside object consensus; do methods+=("--shadows lmm --variant $v"); done
    methods+=("--shadows lmm --light-radius 0.3")  # contact-hardening penumbrae
    for m in "${methods[@]}"; do
        # shellcheck disable=SC2086
        "$lightmesh" render builtin:gazebo "${size[@]}" $m -q -o "$work/ref.png" >/dev/null ||
            fail "single-process render ($m)"
        # Ranks x threads: 1 x 2, 2 x 1, 3 x 2 (each count of ranks, each count of threads).
        for nt in 1:2 2:1 3:2; do
            n=${nt%:*} t=${nt#*:}
            # shellcheck disable=SC2086
            mpi "$n" "$lightmesh" render builtin:gazebo "${size[@]}" $m -t "$t" -q -o "$work/mpi.png" \
                >/dev/null || fail "mpirun -np $n, $t threads ($m)"
            cmp -s "$work/ref.png" "$work/mpi.png" || fail "$n ranks x $t threads differ from one process ($m)"
            rm -f "$work/mpi.png"
        done
        echo "ok: $m"
    done
    # Denoised shadows in bands taller than the denoiser's apron (400 rows: 3 ranks get 128,
    # 128 and 144 rows, each with 96 rows of apron).
    den=(builtin:gazebo --width 64 --height 400 --shadows denoised --light-radius 0.15 --samples 1 -q)
    "$lightmesh" render "${den[@]}" -o "$work/ref.exr" >/dev/null || fail "single-process denoised"
    for n in 2 3; do
        mpi "$n" "$lightmesh" render "${den[@]}" -o "$work/mpi.exr" >/dev/null || fail "mpirun -np $n denoised"
        cmp -s "$work/ref.exr" "$work/mpi.exr" || fail "denoised: $n ranks differ from one process"
        rm -f "$work/mpi.exr"
    done
    # Linear float pixels (EXR), and an image smaller than the ranks' share (17x5: two
    # tiles for three ranks).
    "$lightmesh" render builtin:gazebo --width 17 --height 5 --shadows lmm -q -o "$work/ref.exr" >/dev/null ||
        fail "single-process EXR"
    mpi 3 "$lightmesh" render builtin:gazebo --width 17 --height 5 --shadows lmm -q -o "$work/mpi.exr" >/dev/null ||
        fail "mpirun EXR"
    cmp -s "$work/ref.exr" "$work/mpi.exr" || fail "EXR from 3 ranks differs from one process"
    ;;
failure)
    # A rank that fails while rendering: one message (from rank 0, naming the rank), exit
    # code 1, and the file already at the output path is left as it was.
    echo "previous" >"$work/out.png"
    LIGHTMESH_MPI_TEST_FAIL_RANK=1 mpi 2 "$lightmesh" render builtin:gazebo "${size[@]}" --shadows lmm -q \
        -o "$work/out.png" >"$work/stdout" 2>"$work/stderr"
    code=$?
    cat "$work/stderr"
    [ "$code" -ne 0 ] || fail "exit code 0"
    [ "$(grep -c 'lightmesh: error:' "$work/stderr")" -eq 1 ] || fail "expected one error line"
    grep -q 'out of memory.*(rank 1 of 2)' "$work/stderr" || fail "the message does not name rank 1"
    [ "$(cat "$work/out.png")" = "previous" ] || fail "the old output file was touched"
    [ -z "$(ls "$work" | grep -v -e '^out.png$' -e '^stdout$' -e '^stderr$')" ] || fail "a temporary file is left"
    ;;
killed)
    # A rank killed mid-render: the job ends (no hang: the timeout would fail it), non-zero,
    # and no image appears.
    start=$(date +%s)
    LIGHTMESH_MPI_TEST_KILL_RANK=1 mpi 2 "$lightmesh" render builtin:gazebo "${size[@]}" --shadows rt -q \
        -o "$work/out.png" >/dev/null 2>"$work/stderr"
    code=$?
    [ "$code" -ne 0 ] || fail "exit code 0"
    [ "$code" -ne 124 ] || fail "the job hung (timeout)"
    [ ! -e "$work/out.png" ] || fail "an image was written"
    echo "ended with code $code after $(( $(date +%s) - start )) s"
    ;;
bad-scene)
    mpi 3 "$lightmesh" render "$work/missing.json" -o "$work/out.png" >/dev/null 2>"$work/stderr"
    code=$?
    cat "$work/stderr"
    [ "$code" -eq 1 ] || fail "exit code $code, expected 1"
    [ "$(grep -c 'lightmesh: error:' "$work/stderr")" -eq 1 ] || fail "expected one error line, from rank 0"
    grep -q 'missing.json' "$work/stderr" || fail "the message does not name the file"
    [ ! -e "$work/out.png" ] || fail "an image was written"
    ;;
many-lights)
    # 130 lamps with ranges (scripts/many-lights.py; the light mesh in three groups of
    # lights): 3 ranks give the bytes of one process in every method.
    python3 "$source_dir/scripts/many-lights.py" "$source_dir/scenes/table_vase.json" "$work/lamps.json" \
        --grid 13 10 --box -2 -2 2 2 --height 2.5 --intensity 0.2 --range 2.5 --radius 0.05 >/dev/null ||
        fail "many-lights.py"
    for m in soft rt lmm "area --samples 4"; do
        # shellcheck disable=SC2086
        "$lightmesh" render "$work/lamps.json" "${size[@]}" --shadows $m -q -o "$work/ref.png" >/dev/null ||
            fail "single-process render ($m)"
        # shellcheck disable=SC2086
        mpi 3 "$lightmesh" render "$work/lamps.json" "${size[@]}" --shadows $m -q -o "$work/mpi.png" >/dev/null ||
            fail "mpirun ($m)"
        cmp -s "$work/ref.png" "$work/mpi.png" || fail "3 ranks differ from one process ($m, 130 lights)"
    done
    ;;
schedule)
    # All the geometry in one corner of the image: the ranks that get those tiles take
    # fewer, so the per-rank tile counts differ (dynamic scheduling); the image still
    # matches one process.
    sed -e "s|\"models/|\"$source_dir/scenes/models/|g" \
        -e 's|"look_at": \[0.25, 0.55, 0\]|"look_at": [-1.6, -0.6, 0]|' \
        -e '/"ground"/d' "$source_dir/scenes/table_vase.json" >"$work/corner.json"
    grep -q '"look_at": \[-1.6' "$work/corner.json" || fail "could not move the camera"
    common=(render "$work/corner.json" --width 256 --height 192 --aa 1 --shadows lmm --cc 100)
    "$lightmesh" "${common[@]}" -q -o "$work/ref.png" >/dev/null || fail "single-process render"
    mpi 2 "$lightmesh" "${common[@]}" -t 1 -q --stats -o "$work/mpi.png" >"$work/stats" || fail "mpirun"
    cat "$work/stats" | grep '^rank'
    cmp -s "$work/ref.png" "$work/mpi.png" || fail "the image differs from one process"
    t0=$(sed -n 's/^rank 0 *tiles \([0-9]*\) .*/\1/p' "$work/stats")
    t1=$(sed -n 's/^rank 1 *tiles \([0-9]*\) .*/\1/p' "$work/stats")
    [ -n "$t0" ] && [ -n "$t1" ] || fail "no per-rank tile counts in --stats"
    [ $((t0 + t1)) -eq 192 ] || fail "tiles $t0 + $t1, expected 192"
    [ "$t0" -ne "$t1" ] || fail "both ranks rendered $t0 tiles: nothing was redistributed"
    ;;
templates)
    # Three ranks building and caching the same sphere template at once, in an empty
    # folder: the same image, and a cache file that a later run loads.
    mkdir "$work/templates"
    "$lightmesh" render builtin:gazebo "${size[@]}" --shadows lmm --ki 2.5 --template-dir "$work/ref-templates" \
        -q -o "$work/ref.png" >/dev/null || fail "single-process render"
    mpi 3 "$lightmesh" render builtin:gazebo "${size[@]}" --shadows lmm --ki 2.5 --template-dir "$work/templates" \
        -q -o "$work/mpi.png" >/dev/null || fail "mpirun"
    cmp -s "$work/ref.png" "$work/mpi.png" || fail "the image differs from one process"
    [ "$(ls "$work/templates" | wc -l)" -eq 1 ] || fail "expected one cache file, found: $(ls "$work/templates")"
    "$lightmesh" render builtin:gazebo "${size[@]}" --shadows lmm --ki 2.5 --template-dir "$work/templates" \
        --stats -o "$work/again.png" | grep -q 'templates.* loaded' || fail "the cache file did not load"
    ;;
other-commands)
    # Every other command runs once, on rank 0, and says so.
    mpi 2 "$lightmesh" info builtin:gazebo >"$work/stdout" 2>"$work/stderr" || fail "info under mpirun"
    [ "$(grep -c '^scene ' "$work/stdout")" -eq 1 ] || fail "info ran $(grep -c '^scene ' "$work/stdout") times"
    grep -q 'runs once, on rank 0' "$work/stderr" || fail "no note that it runs on rank 0"
    ;;
*)
    fail "unknown case $case_name"
    ;;
esac
echo "mpi_render_test $case_name: passed"

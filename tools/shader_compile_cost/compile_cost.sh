#!/bin/bash
# The cost of compiling the lit fragment shader on lavapipe, counted in instructions rather than
# timed (this machine's speed drifts by 2x, LLVM's instruction count does not).
#
#   tools/shader_compile_cost/compile_cost.sh [--optimized] [penumbra bench options...]
#
# Runs `penumbra bench --shader-edits 1 --size 16x16 [options]` with an LD_PRELOAD shim that
# writes the LLVM modules llvmpipe builds, takes the fragment shader module of the edit (the last
# one), and counts with callgrind the instructions `llc` spends generating code for it: at -O0,
# as `--cpu-shader-compile fast` (the default while shaders are watched) does, or at -O2 with
# --optimized. Prints the module's IR instruction count, llc's instructions in millions (parsing
# the module included, about 90 M for the helmet's) and the machine code's size.
# Needs: cc, valgrind, binutils (size), llvm-15 (llc-15, llvm-as-15) and Mesa's lavapipe with
# LLVM 15 (Debian 12). PENUMBRA names the binary (default: the checkout's
# target/release/penumbra); KEEP=1 keeps the work folder. Example, DamagedHelmet's variant with
# image-based lighting, then an edited copy of the shaders:
#   tools/shader_compile_cost/compile_cost.sh
#   tools/shader_compile_cost/compile_cost.sh --shader-dir /tmp/edited-shaders
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
penumbra=${PENUMBRA:-$here/../../target/release/penumbra}
mode=(--cpu-shader-compile fast)
opt=0
if [[ ${1:-} == --optimized ]]; then
    mode=(--cpu-shader-compile optimized)
    opt=2
    shift
fi
work=$(mktemp -d)
# KEEP=1 keeps the folder (the modules, llc's object) and prints its path.
if [[ -n ${KEEP:-} ]]; then echo "compile_cost.sh: keeping $work" >&2; else trap 'rm -rf "$work"' EXIT; fi
cc -shared -fPIC -O1 -o "$work/dump.so" "$here/dump_llvm_modules.c" -ldl
mkdir "$work/modules"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$work}
DUMP_DIR="$work/modules" LD_PRELOAD="$work/dump.so" \
    "$penumbra" "${mode[@]}" bench --shader-edits 1 --size 16x16 "$@" > "$work/bench.txt"
module=$(grep -l "ModuleID = 'fs" "$work"/modules/*.opt.ll | sort | tail -1 || true)
if [[ -z $module ]]; then
    echo "compile_cost.sh: llvmpipe compiled no fragment shader (is the adapter lavapipe? see $work/bench.txt)" >&2
    trap - EXIT
    exit 1
fi
llvm-as-15 -o "$work/fs.bc" "$module"
# llvmpipe generates code for the host CPU and every feature it has, AVX-512 included. Under
# valgrind, `-mcpu=native` would name valgrind's emulated CPU instead (haswell: no AVX-512, whose
# instruction selection costs 12 % more on this module), so the host's name is read outside it.
cpu=$(llc-15 --version | awk '/Host CPU:/ { print $3 }')
count=$(valgrind --tool=callgrind --callgrind-out-file=/dev/null \
    llc-15 -O$opt -mcpu="$cpu" -filetype=obj -o "$work/fs.o" "$work/fs.bc" 2>&1 |
    grep -o "Collected : [0-9]*" | grep -o "[0-9]*" || true)
if [[ -z $count ]]; then
    echo "compile_cost.sh: callgrind counted nothing (is valgrind installed?)" >&2
    exit 1
fi
text=$(size -A "$work/fs.o" | awk '$1 == ".text" { print $2 }')
echo "IR instructions $(grep -c '^  ' "$module"), llc -O$opt -mcpu=$cpu $((count / 1000000)) M instructions, machine code $text bytes"

#!/usr/bin/env bash
# Renders each Khronos sample model's compressed variant (glTF-Draco, glTF-KTX2-Basisu,
# glTF-KTX-BasisU) and its plain variant (glTF, else glTF-Binary) with `penumbra render` at
# 256x256 (the defaults: same view and exposure for both), and prints a Markdown table: FLIP
# mean and error-weighted 99.9th percentile between the two, and whether the compressed file
# loaded with a "not supported" warning. docs/coverage.md, "Compressed variants".
#
#   tools/compressed_variants.sh MODELS_DIR [PENUMBRA]
#
# MODELS_DIR holds <Model>/<variant>/ folders (glTF-Sample-Assets' Models/); PENUMBRA defaults to
# target/release/penumbra. Needs `cargo build --release --example flip`.
set -uo pipefail
models=${1:?MODELS_DIR}
penumbra=${2:-target/release/penumbra}
flip=target/release/examples/flip
out=$(mktemp -d)
echo "| model | variant | FLIP mean | FLIP 99.9 % | warnings |"
echo "|---|---|---:|---:|---|"
for dir in "$models"/*/; do
    model=$(basename "$dir")
    plain=$(ls "$dir"glTF/*.gltf 2>/dev/null | head -1)
    [ -z "$plain" ] && plain=$(ls "$dir"glTF-Binary/*.glb 2>/dev/null | head -1)
    for variant in glTF-Draco glTF-KTX2-Basisu glTF-KTX-BasisU; do
        file=$(ls "$dir$variant"/*.gltf "$dir$variant"/*.glb 2>/dev/null | head -1)
        [ -z "$file" ] && continue
        if ! "$penumbra" render "$file" --size 256x256 --out "$out/c.png" 2>"$out/c.log"; then
            echo "| $model | $variant | – | – | does not load: $(tail -1 "$out/c.log" | sed 's/.*: //' | cut -c1-80) |"
            continue
        fi
        warn=$(grep -c "not supported" "$out/c.log")
        if [ -z "$plain" ] || ! "$penumbra" render "$plain" --size 256x256 --out "$out/p.png" 2>"$out/p.log"; then
            echo "| $model | $variant | – | – | $warn (plain variant does not load here) |"
            continue
        fi
        read -r mean p999 < <("$flip" "$out/p.png" "$out/c.png")
        echo "| $model | $variant | $mean | $p999 | $warn |"
    done
done
rm -rf "$out"

#!/bin/sh
# Per-fixture efficiency, BSDF vs MIS (docs/benchmarks.md, "Every
# fixture"): every line of ROOT/fixtures/refs/manifest.txt rendered with
# both estimators at SPP (default 1024), relMSE (plain) against the
# fixture's MIS reference, efficiency 1/(relMSE x time); time is the
# render's (CPU) or its GPU time (kernel timestamps). Prints Markdown rows.
# Usage: sh xtask/perf/estimators.sh BIN ROOT cpu|gpu [SPP]
bin=$1; root=$2; backend=$3; spp=${4:-1024}
out=$(mktemp -d)
grep -v '^#' "$root/fixtures/refs/manifest.txt" | while read name scene size rspp seed depth; do
  [ -z "$name" ] && continue
  for est in bsdf mis; do
    line=$("$bin" render "$root/$scene" --backend "$backend" --integrator $est --size "$size" --spp "$spp" --seed 3 --max-depth "$depth" -o "$out/$name-$est" 2>&1 | grep '^rendered')
    if [ "$backend" = gpu ]; then t=$(echo "$line" | sed -n 's/.*GPU time \([0-9.]*\) s.*/\1/p'); else t=$(echo "$line" | sed -n 's/.* in \([0-9.]*\) s.*/\1/p'); fi
    rel=$("$bin" diff "$out/$name-$est.exr" "$root/fixtures/refs/mis/$name.exr" --report "$out/d.html" 2>&1 | sed -n 's/.*relMSE \([0-9.e+-]*\),.*/\1/p')
    echo "$name $est $t $rel" | awk '{printf "| %s | %s | %s s | %.3e | %.3g |\n", $1, $2, $3, $4, 1/($3*$4)}'
  done
done

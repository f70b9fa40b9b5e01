#!/bin/bash
# False-alarm calibration of `twintrace diff`'s default against the stored
# references (docs/gates.md, "Calibration"). Run from the workspace root:
#   xtask/scripts/calibrate.sh [BACKEND gpu|cpu] [FIRST seed] [COUNT seeds] [JOBS] [THREADS per CPU render]
# For every fixture of fixtures/refs/manifest.txt, COUNT correct renders
# (seeds FIRST..) at the gates' budget (1024 spp, the manifest's size and
# depth), JOBS at a time, each compared with its stored reference. Prints
# one CSV line per render: fixture,seed,verdict,per-pixel pass %,
# max |image-sum statistic|,failing tiles. TWINTRACE names the binary
# (default target/release/twintrace). To become `cargo xtask calibrate`.
BACKEND=${1:-gpu}; FIRST=${2:-1000}; COUNT=${3:-300}; JOBS=${4:-8}; THREADS=${5:-2}
T=${TWINTRACE:-target/release/twintrace}
export XDG_RUNTIME_DIR=/tmp TMPDIR=/tmp/cal; mkdir -p /tmp/cal
one() {
  name=$1 scene=$2 size=$3 depth=$4 seed=$5
  o=/tmp/cal/$name-$BACKEND-$seed
  thr=""; [ "$BACKEND" = cpu ] && thr="--threads $THREADS"
  $T render $scene --backend $BACKEND --spp 1024 --size $size --max-depth $depth --seed $seed $thr -o $o >/dev/null 2>&1 || { echo "$name,$seed,RENDER-ERROR"; return; }
  d=$($T diff $o.exr fixtures/refs/$name.exr --report $o.html 2>&1)
  v=$(echo "$d" | grep -o "verdict: [A-Z]*" | cut -d' ' -f2)
  px=$(echo "$d" | grep "^per-pixel" | grep -o "([0-9.]* %" | tr -d '( %')
  z=$(echo "$d" | grep "^image sum" | grep -o "[zt] = [-+0-9.]*" | awk '{a=$3+0; if(a<0)a=-a; if(a>m)m=a} END{print m}')
  tiles=$(echo "$d" | grep "^8x8" | grep -o "[0-9]* of [0-9]*" | head -1 | cut -d' ' -f1)
  rm -f $o.exr $o.png $o.html
  echo "$name,$seed,$v,$px,$z,$tiles"
}
export -f one; export T BACKEND THREADS
grep -v '^#' fixtures/refs/manifest.txt | awk 'NF>=6 {print $1, $2, $3, $6}' | while read name scene size depth; do
  for s in $(seq $FIRST $((FIRST+COUNT-1))); do echo "$name $scene $size $depth $s"; done
done | xargs -P $JOBS -L 1 bash -c 'one "$@"' _

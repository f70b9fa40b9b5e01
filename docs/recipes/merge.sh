#!/bin/sh
# The merge step of a split render: every part of OUTDIR (part-0.exr ..
# part-(PARTS-1).exr, written by part.sh) into OUT.exr and OUT.png
# (docs/split-renders.md). A missing part is an error naming it; twintrace
# merge refuses parts of different renders, gaps, overlaps and corrupt
# files, and writes nothing then.
#
#   merge.sh OUTDIR PARTS OUT
set -eu
if [ $# -ne 3 ]; then
    echo "usage: merge.sh OUTDIR PARTS OUT" >&2
    exit 2
fi
outdir=$1 parts=$2 out=$3
case $parts in
    '' | *[!0-9]*)
        echo "merge.sh: PARTS '$parts' is not a number" >&2
        exit 2
        ;;
esac
set --
i=0
while [ "$i" -lt "$parts" ]; do
    f="$outdir/part-$i.exr"
    if [ ! -f "$f" ]; then
        echo "merge.sh: part $i of $parts is missing: $f" >&2
        exit 1
    fi
    set -- "$@" "$f"
    i=$((i + 1))
done
exec "${TWINTRACE:-twintrace}" merge "$@" -o "$out"

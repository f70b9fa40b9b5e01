#!/bin/sh
# One part of a split render: the sample range of this task's index, as a
# partial film for `twintrace merge` (docs/split-renders.md).
#
#   part.sh SCENE SPP PARTS OUTDIR [twintrace render options...]
#
# The index is $SLURM_ARRAY_TASK_ID (a Slurm job array),
# $JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) or $PART_INDEX. Part i
# of P renders samples i*SPP/P .. (i+1)*SPP/P into OUTDIR/part-i.exr (and
# .png). $TWINTRACE names the binary (default: twintrace on the PATH).
set -eu
if [ $# -lt 4 ]; then
    echo "usage: part.sh SCENE SPP PARTS OUTDIR [twintrace render options...]" >&2
    exit 2
fi
scene=$1 spp=$2 parts=$3 outdir=$4
shift 4
index=${SLURM_ARRAY_TASK_ID:-${JOB_COMPLETION_INDEX:-${PART_INDEX:-}}}
for v in "$spp" "$parts" "$index"; do
    case $v in
        '' | *[!0-9]*)
            echo "part.sh: SPP, PARTS and the task index must be numbers (got '$spp', '$parts', '$index'; the index comes from SLURM_ARRAY_TASK_ID, JOB_COMPLETION_INDEX or PART_INDEX)" >&2
            exit 2
            ;;
    esac
done
if [ "$index" -ge "$parts" ]; then
    echo "part.sh: task index $index is not below PARTS $parts" >&2
    exit 2
fi
start=$((index * spp / parts))
end=$(((index + 1) * spp / parts))
if [ "$start" -ge "$end" ]; then
    echo "part.sh: part $index of $parts has no samples of $spp" >&2
    exit 2
fi
mkdir -p "$outdir"
exec "${TWINTRACE:-twintrace}" render "$scene" --spp "$spp" --samples "$start..$end" \
    -o "$outdir/part-$index" "$@"

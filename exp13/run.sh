#!/bin/bash
# usage: run.sh TAG ENVSETTINGS...   runs every bundled characteristic log
cd /work/wt-lm
tag=$1; shift
for f in datasets/char_*.mcap datasets/law_*.mcap; do
  b=$(basename $f .mcap)
  env "$@" STICKSLIP_OE_TRACE=1 /usr/bin/time -f "CPU %U %S WALL %e" timeout 300 target/release/stickslip fit $f --json \
     > /work/scratch/lm13/runs/${b}.${tag}.json 2> /work/scratch/lm13/runs/${b}.${tag}.err
  echo "$b $tag rc=$? $(tail -1 /work/scratch/lm13/runs/${b}.${tag}.err)"
done

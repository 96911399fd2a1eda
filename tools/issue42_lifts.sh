#!/bin/bash
# usage: lifts.sh REPO OUTROOT  -- the issue-42 measurement lifts, 3 seeds each
R=$1; O=$2; cd $R; P=$R/.venv/bin/platypose
B=data/video/pose2sim-balancing; S=data/video/sports2d-demo
for s in ${SEEDS:-0 1 2}; do
  [ -e $O/bal1-s$s/summary.json ] || timeout 900 $P lift --keypoints $B/openpose-body25b/cam01_json --cams $B/calib_pose2sim.toml --samples 20 --threads 1 --seed $s --formats npz,angles,mot --out $O/bal1-s$s -q
  for c in calib nocalib; do
    d=$O/sp-$c-s$s; mkdir -p $d/demo
    [ -e $O/sp-$c-s0/demo ] && cp -n $O/sp-$c-s0/demo/*detect* $d/demo/ 2>/dev/null
    opt=""; [ $c = calib ] && opt="--cams $S/Calib_demo.toml"
    [ -e $d/summary.json ] || timeout 900 $P lift $S/demo.mp4 $opt --samples 20 --threads 1 --seed $s --formats npz,angles,mot --out $d -q
  done
  [ -e $O/bal4-s$s/summary.json ] || timeout 900 $P lift --keypoints $B/openpose-body25b --cams $B/calib_pose2sim.toml --samples 20 --threads 1 --seed $s --formats npz,angles --out $O/bal4-s$s -q
done
echo ALLDONE

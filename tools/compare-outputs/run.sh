#!/usr/bin/env bash
# Usage: run.sh BIN OUTDIR   (run from the repository root; see README.md beside this file)
# Records stdout (JSON) and CSV outputs of commands covering the three methods and the example models.
BIN=$1; OUT=$2; mkdir -p $OUT
D="--set damping.first_mode_ratio=0.01"
run() { name=$1; shift; timeout 600 $BIN "$@" > $OUT/$name.json 2> $OUT/$name.err; echo "$name exit $?" >> $OUT/exit.txt; }
rm -f $OUT/exit.txt
run s1 solve examples/clamped_bar.toml --frequency 60000 --harmonics 5 --json
run s2 solve examples/clamped_bar.toml --frequency 60000 --harmonics 3 --quadrature sampled --json
run s3 solve examples/clamped_bar_gap0.toml --frequency 50000 --harmonics 5 $D --json
run s4 solve examples/clamped_bar.toml --method hbm-aft --frequency 60000 --harmonics 5 --json
run s5 solve examples/clamped_bar_impact.toml --method mshbm --frequency 90000 --harmonics 5 --json
run s6 solve examples/friction_oscillator/model.toml --method mshbm --frequency 6.5 --harmonics 5 --json
run s7 solve examples/bar_matrices/model.toml --frequency 60000 --harmonics 5 --json
run s8 solve examples/clamped_bar_gap0.toml --method hbm-aft --penalty 1e7 --quadrature exact --frequency 50000 --harmonics 3 $D --json
run f1 frf examples/clamped_bar.toml --from 20000 --to 40000 --harmonics 3 $D --json --output $OUT/f1.csv
run f2 frf examples/clamped_bar_gap0.toml --method hbm-aft --penalty 1e7 --quadrature exact --from 40000 --to 60000 --harmonics 3 $D --overlay-mshbm --json --output $OUT/f2.csv
run f3 frf examples/friction_oscillator/model.toml --method mshbm --from 6 --to 6.3 --harmonics 3 --json --output $OUT/f3.csv
run f4 frf examples/bar_matrices/model.toml --from 30000 --to 42000 --harmonics 3 $D --stability --json --output $OUT/f4.csv
run f5 frf examples/clamped_bar_impact.toml --method mshbm --from 89000 --to 90000 --harmonics 3 --json --output $OUT/f5.csv
run f6 frf examples/clamped_bar.toml --from 1000 --to 100000 --harmonics 5 $D --output $OUT/f6.csv
run t1 simulate examples/dropped_bar.toml --json --output $OUT/t1.csv
run t2 simulate examples/clamped_bar.toml --frequency 90000 --steady-state --set damping.alpha=7587.745 --set damping.beta_linear=2.6e-7 --periods 200 --json
run t3 simulate examples/clamped_bar.toml --frequency 20000 --scheme moreau --periods 3 --json --output $OUT/t3.csv

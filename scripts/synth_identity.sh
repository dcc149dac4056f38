#!/usr/bin/env bash
# Byte-identity check of `stickslip synth` between two binaries.
#
#   scripts/synth_identity.sh BEFORE AFTER DIR
#
# Runs every case below with both binaries (each in its own folder under
# DIR, with the same relative paths) and compares with `cmp` every file
# written (the log, a CSV's channel map, truth.json) and the stdout of
# `--json`. Prints one line per case and exits non-zero if any output
# differs (or if the two binaries disagree on the exit code).
# Covers every --format, seeds 1/2/7, the characteristic, stepped and
# continuous tests, every law family (Stribeck at v_s 1 mm/s), ideal and
# typical sensors, no accelerometer, a --sensors JSON with Butterworth
# filters, gain/offset drift, correlated noise, clipping, delays, many lost
# buffers and dropouts, clip fractions, channel delays and offset drifts,
# CSV column shifts (both signs), table rates, warm-up 0, the test defects,
# a contact stiffness and a refused configuration.
set -u
if [ $# -ne 3 ]; then
    echo "usage: $0 BEFORE AFTER DIR" >&2
    exit 2
fi
BEFORE=$(realpath "$1")
AFTER=$(realpath "$2")
DIR=$3
mkdir -p "$DIR"
DIR=$(realpath "$DIR")
rm -rf "$DIR/before" "$DIR/after"
mkdir -p "$DIR/before" "$DIR/after"

cat > "$DIR/sensors.json" <<'JSON'
{
  "x0": {"rate_hz": 800.0, "noise": 1e-6, "quant": 5e-7, "gain": 1.002, "offset": 1e-5,
         "lowpass_hz": 150.0, "lowpass_order": 3, "buffer_s": 0.05, "start_offset_ns": null,
         "jitter_ns": 2000, "p_lost_buffer": 0.05, "p_dropout": 0.01, "dropout_burst_max": 6,
         "noise_correlation_s": 0.002, "gain_drift_per_s": 1e-4, "delay_s": 0.002},
  "x1": {"rate_hz": 1000.0, "noise": 3e-6, "quant": 1e-6, "gain": 0.995, "offset": -2e-5,
         "lowpass_hz": 300.0, "lowpass_order": 2, "buffer_s": 0.1, "start_offset_ns": 12345,
         "jitter_ns": 3000, "p_lost_buffer": 0.02, "p_dropout": 0.001, "dropout_burst_max": 3,
         "clip_high_fraction": 0.9, "clip_low": -0.003, "offset_drift_per_s": 1e-6},
  "x2": {"rate_hz": 1200.0, "noise": 0.0, "quant": 0.0, "gain": 1.0, "offset": 0.0,
         "lowpass_hz": 90.0, "buffer_s": 0.2, "start_offset_ns": null, "jitter_ns": 0,
         "p_lost_buffer": 0.0, "p_dropout": 0.0, "dropout_burst_max": 1, "delay_s": -0.004,
         "clip_low_fraction": 0.8, "clip_high": 0.004},
  "v2": {"rate_hz": 1000.0, "noise": 4e-4, "quant": 1e-5, "gain": 1.01, "offset": 8e-5,
         "lowpass_hz": 200.0, "lowpass_order": 4, "buffer_s": 0.1, "start_offset_ns": null,
         "jitter_ns": 3000, "p_lost_buffer": 0.005, "p_dropout": 2e-4, "dropout_burst_max": 4,
         "noise_correlation_s": 0.01},
  "a2": {"rate_hz": 2000.0, "noise": 0.02, "quant": 1e-3, "gain": 0.99, "offset": 0.01,
         "lowpass_hz": 250.0, "buffer_s": 0.1, "start_offset_ns": null, "jitter_ns": 3000,
         "p_lost_buffer": 0.005, "p_dropout": 2e-4, "dropout_burst_max": 4, "gain_drift_per_s": -2e-4},
  "normal_force": {"rate_hz": 10.0, "noise": 0.0, "quant": 0.01, "gain": 1.0, "offset": 0.02,
         "lowpass_hz": null, "buffer_s": 0.5, "start_offset_ns": null, "jitter_ns": 3000,
         "p_lost_buffer": 0.0, "p_dropout": 0.0, "dropout_burst_max": 1}
}
JSON

# name|extension|arguments (the log is written to NAME.EXT)
CASES=(
"default|mcap|"
"mcap_seed2|mcap|--seed 2 --duration-s 30"
"mcap_seed7_600|mcap|--seed 7 --duration-s 600"
"lz4|mcap|--format mcap-lz4 --seed 3"
"plain|mcap|--format mcap-plain --seed 4"
"csv|csv|--format csv"
"csv_seed7_600|csv|--seed 7 --duration-s 600"
"csv_shift|csv|--csv-drive-shift-s 0.004 --seed 2"
"csv_shift_neg|csv|--csv-drive-shift-s -0.003 --table-rate-hz 2500 --seed 5"
"parquet|parquet|--seed 2"
"parquet_rate|parquet|--table-rate-hz 333 --seed 8 --duration-s 40"
"stribeck|mcap|--law stribeck --stribeck-velocity-m-per-s 0.001 --duration-s 10"
"stribeck_csv|csv|--law stribeck --stribeck-velocity-m-per-s 0.001 --duration-s 10 --seed 2"
"exponential|mcap|--law exponential --stribeck-velocity-m-per-s 0.003 --duration-s 10 --seed 3"
"coulomb|mcap|--law coulomb --mu-s 0.3 --seed 4"
"decreasing|parquet|--law decreasing --mu-s 0.3 --seed 5"
"stepped|mcap|--test stepped --setpoints-hz 1.2,1.7,2.4 --dwell-s 4 --seed 2"
"stepped_csv|csv|--test stepped --setpoints-hz 1.2,1.7,2.4 --dwell-s 4,3,5 --seed 3"
"stepped_default|mcap|--test stepped"
"continuous|mcap|--test continuous --sweep-s 20 --seed 4"
"continuous_csv|csv|--test continuous --sweep-s 20 --seed 5 --csv-drive-shift-s 0.01"
"continuous_parquet|parquet|--test continuous --sweep-s 15 --from-hz 2.5 --to-hz 1.1 --seed 6"
"ideal|mcap|--ideal-sensors --seed 2"
"ideal_csv|csv|--ideal-sensors --no-accelerometer"
"no_acc|mcap|--no-accelerometer --seed 9"
"sensors_json|mcap|--sensors SENSORS --seed 2"
"sensors_json_csv|csv|--sensors SENSORS --seed 3"
"sensors_json_stepped|mcap|--sensors SENSORS --test stepped --setpoints-hz 1.5,2.2 --dwell-s 5"
"clip|mcap|--clip x1=0.85 --clip-low x2=0.7 --clip v2=0.95 --seed 4"
"clip_csv|csv|--clip x1=0.85 --clip-low a2=0.5 --seed 4"
"delays|mcap|--channel-delay-s x2=0.003,v2=-0.002 --offset-drift-per-s v2=0.0004,x1=1e-6 --seed 5"
"delays_csv|csv|--channel-delay-s x0=0.001,a2=0.002 --offset-drift-per-s x2=2e-6"
"warmup0|mcap|--warmup-s 0 --duration-s 8 --seed 6"
"warmup0_delay|mcap|--warmup-s 0 --duration-s 8 --channel-delay-s x1=0.01 --sensors SENSORS"
"true_amp|mcap|--true-amplitude-m 0.0027 --frequency-hz 2.1 --seed 7"
"defects|mcap|--stroke-friction-gradient-per-m 20 --hardening-per-m2 1e4 --duration-s 8 --seed 2"
"defects_minus|csv|--rs-minus-n 1.1 --rd-minus-n 0.6 --duration-s 8 --seed 3"
"contact|mcap|--contact-stiffness-n-per-m 20000 --duration-s 8 --seed 4"
"slow_freq|mcap|--frequency-hz 0.7 --duration-s 25 --seed 11"
"refused|mcap|--duration-s 1e6"
)

fail=0
for c in "${CASES[@]}"; do
    IFS='|' read -r name ext args <<< "$c"
    args=${args//SENSORS/$DIR\/sensors.json}
    for side in before after; do
        bin=$BEFORE
        [ $side = after ] && bin=$AFTER
        d="$DIR/$side/$name"
        mkdir -p "$d"
        # shellcheck disable=SC2086
        (cd "$d" && "$bin" synth --out "$name.$ext" --json $args > stdout.json 2> stderr.txt; echo $? > rc)
    done
    b="$DIR/before/$name"
    a="$DIR/after/$name"
    bad=""
    cmp -s "$b/rc" "$a/rc" || bad="$bad exit-code"
    for f in $(cd "$b" && ls); do
        [ "$f" = stderr.txt ] && continue
        cmp -s "$b/$f" "$a/$f" || bad="$bad $f"
    done
    for f in $(cd "$a" && ls); do
        [ -e "$b/$f" ] || bad="$bad +$f"
    done
    # A refused case must be refused identically.
    if [ "$(cat "$b/rc")" != 0 ]; then
        cmp -s "$b/stderr.txt" "$a/stderr.txt" || bad="$bad stderr.txt"
    fi
    nfiles=$(cd "$b" && ls | grep -vc '^\(stderr.txt\|rc\)$')
    if [ -z "$bad" ]; then
        echo "identical  $name (rc $(cat "$b/rc"), $nfiles files)"
    else
        echo "DIFFERENT  $name:$bad"
        fail=1
    fi
done
if [ $fail = 0 ]; then
    echo "all ${#CASES[@]} cases identical"
else
    echo "some cases differ" >&2
fi
exit $fail

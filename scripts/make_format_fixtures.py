#!/usr/bin/env python3
"""Makes the TDMS and MAT fixtures of datasets/formats/ and datasets/broken/
(issue 33) with independent writers: npTDMS (TDMS) and scipy.io.savemat
(MAT level 5), from logs written by `stickslip synth` and from the bundled
datasets/char_N2.2.mcap.

    python3 -m venv venv && venv/bin/pip install nptdms scipy pyarrow mcap zstandard
    venv/bin/python scripts/make_format_fixtures.py --stickslip target/release/stickslip

Files (datasets/formats/, each with NAME.map.toml):
- synth_wf.mcap: `stickslip synth` characteristic log, 4 s, typical sensor
  noise and dropouts but no buffer jitter and no lost buffers (sensor set
  synth_wf.sensors.json), channels starting at their own offsets;
- synth_wf.tdms: its samples as TDMS waveform channels in three groups at
  their own rates and start times (positions in mm with unit_string "mm",
  written in two segments, the second one appending data only);
- synth_table.parquet: `stickslip synth` Parquet table, 4 s;
- synth_table.tdms: that table as value channels on a `Time` channel;
- synth_table.mat: that table as -v7 (compressed) MAT variables on `t`;
- synth_rate.mat: that table as -v6 MAT variables without a time variable
  (the map gives rate_hz), with numeric fields in the `rig` struct;
- char_N2.2_wf.tdms: datasets/char_N2.2.mcap (jitter, lost buffers) as
  single-float waveform channels, lost buffers and dropouts as NaN.
Broken files go to datasets/broken/ (see its README).
"""

import argparse
import json
import math
import os
import struct
import subprocess
import sys

import numpy as np
import pyarrow.parquet as pq
import scipy.io
from mcap.reader import make_reader
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter
from nptdms.timestamp import TdmsTimestamp

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "datasets", "formats")
BROKEN = os.path.join(ROOT, "datasets", "broken")
# Seconds from the TDMS epoch (1904-01-01 UTC) to the Unix epoch.
EPOCH_1904 = 2082844800

TOPICS = {
    "/drive/position": "x0",
    "/mass1/position": "x1",
    "/mass2/position": "x2",
    "/mass2/velocity": "v2",
    "/mass2/acceleration": "a2",
    "/friction/normal_force": "normal_force",
}


def sensor(rate, noise, quant, gain, offset, start_ns, lowpass=None, buffer_s=0.1, p_dropout=2e-4):
    return {
        "rate_hz": rate, "noise": noise, "quant": quant, "gain": gain, "offset": offset,
        "lowpass_hz": lowpass, "buffer_s": buffer_s, "start_offset_ns": start_ns,
        "jitter_ns": 0, "p_lost_buffer": 0.0, "p_dropout": p_dropout, "dropout_burst_max": 4,
    }


# The "typical" DAQ of the virtual rig without jitter and lost buffers; each
# channel starts at its own offset.
SENSORS = {
    "x0": sensor(1000.0, 1.5e-6, 0.5e-6, 1.002, 8e-6, 137000),
    "x1": sensor(1000.0, 3e-6, 1e-6, 0.995, 6e-5, 0),
    "x2": sensor(1000.0, 3e-6, 1e-6, 1.004, -4e-5, 250000),
    "v2": sensor(1000.0, 4e-4, 1e-5, 1.003, 3e-5, 500000, lowpass=200.0),
    "a2": sensor(2000.0, 0.02, 1e-3, 0.998, 0.004, 123000, lowpass=250.0),
    "normal_force": sensor(10.0, 0.0, 0.01, 1.001, 0.01, 30000000, buffer_s=0.5, p_dropout=0.0),
}


def read_mcap(path):
    """rig metadata and, per quantity, a list of (t0_ns, dt_ns, values)."""
    rig, bufs = {}, {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for m in reader.iter_metadata():
            if m.name == "rig":
                rig = dict(m.metadata)
        f.seek(0)
        reader = make_reader(f)
        for _schema, channel, message in reader.iter_messages():
            q = TOPICS.get(channel.topic)
            if q is None:
                continue
            d = json.loads(message.data)
            vals = [math.nan if v is None else float(v) for v in d["value"]]
            bufs.setdefault(q, []).append((int(d["t0_ns"]), int(d["dt_ns"]), vals))
    return rig, bufs


def waveform(buffers):
    """One uniform waveform from a channel's buffers: start (ns), dt (ns),
    values with NaN where a buffer was lost."""
    buffers = sorted(buffers)
    t0, dt = buffers[0][0], buffers[0][1]
    end = max(b[0] + (len(b[2]) - 1) * b[1] for b in buffers)
    n = int(round((end - t0) / dt)) + 1
    v = np.full(n, np.nan)
    for b0, bdt, vals in buffers:
        assert bdt == dt, "one sample interval per channel"
        i = int(round((b0 - t0) / dt))
        v[i:i + len(vals)] = vals
    return t0, dt, v


def stamp(ns):
    """A TDMS timestamp of a Unix time in ns, exact to 2^-64 s."""
    secs, rem = divmod(ns, 10**9)
    return TdmsTimestamp(secs + EPOCH_1904, (rem << 64) // 10**9)


def write_map(path, entries):
    with open(path, "w") as f:
        f.write("# Channel map of %s (made by scripts/make_format_fixtures.py)\n[columns]\n" % os.path.basename(path).replace(".map.toml", ""))
        for key, spec in entries:
            f.write("%s = { %s }\n" % (key, ", ".join("%s = %s" % (k, json.dumps(v)) for k, v in spec.items())))


def wf_tdms(mcap_path, out, dtype, groups, mm_positions, segments):
    rig, bufs = read_mcap(mcap_path)
    root = RootObject(properties=rig)
    objs = []
    mapping = []
    for q in ["x0", "x1", "x2", "v2", "a2", "normal_force"]:
        if q not in bufs:
            continue
        t0, dt, v = waveform(bufs[q])
        group, name = groups[q]
        props = {
            "wf_start_time": stamp(t0),
            "wf_increment": dt * 1e-9,
            "wf_start_offset": 0.0,
            "wf_samples": len(v),
        }
        unit = {"x0": "m", "x1": "m", "x2": "m", "v2": "m/s", "a2": "m/s^2", "normal_force": "N"}[q]
        if mm_positions and q in ("x0", "x1", "x2"):
            v = v * 1000.0
            unit = "mm"
        props["unit_string"] = unit
        objs.append((group, name, v.astype(dtype), props))
        mapping.append((q, {"name": "%s/%s" % (group, name)}))
    with TdmsWriter(out) as w:
        for k in range(segments):
            seg = [] if k else [root] + [GroupObject(g) for g in sorted({o[0] for o in objs})]
            for group, name, v, props in objs:
                n = len(v)
                part = v[n * k // segments: n * (k + 1) // segments]
                seg.append(ChannelObject(group, name, part, properties=props if k == 0 else {}))
            w.write_segment(seg)
    write_map(out.replace(".tdms", ".map.toml"), mapping)


def table(parquet_path):
    t = pq.read_table(parquet_path)
    kv = pq.ParquetFile(parquet_path).metadata.metadata or {}
    meta = {k.decode(): v.decode() for k, v in kv.items()
            if not k.startswith(b"ARROW") and k != b"pandas"}
    cols = {n: t.column(n).to_numpy(zero_copy_only=False).astype(float) for n in t.column_names}
    return meta, cols


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--stickslip", default=os.path.join(ROOT, "target", "release", "stickslip"))
    a = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)

    # 1. Waveforms of a synth MCAP without jitter and lost buffers.
    sens = os.path.join(OUT, "synth_wf.sensors.json")
    with open(sens, "w") as f:
        json.dump(SENSORS, f, indent=1)
    mc = os.path.join(OUT, "synth_wf.mcap")
    subprocess.run([a.stickslip, "synth", "--out", mc, "--format", "mcap-plain", "--duration-s", "4",
                    "--warmup-s", "6", "--seed", "33", "--sensors", sens, "--force"], check=True)
    wf_tdms(mc, os.path.join(OUT, "synth_wf.tdms"), np.float64,
            {"x0": ("Drive", "position"), "x1": ("Masses", "x1"), "x2": ("Masses", "x2"),
             "v2": ("Masses", "v2 velocity"), "a2": ("Masses", "a2"), "normal_force": ("Friction", "normal force")},
            mm_positions=False, segments=2)

    # 2. A Parquet table as TDMS value channels and MAT variables.
    pqp = os.path.join(OUT, "synth_table.parquet")
    subprocess.run([a.stickslip, "synth", "--out", pqp, "--duration-s", "4", "--warmup-s", "6",
                    "--seed", "34", "--force"], check=True)
    meta, cols = table(pqp)
    qs = [q for q in ["x0", "x1", "x2", "v2", "a2", "normal_force", "setpoint_hz"] if q in cols]
    with TdmsWriter(os.path.join(OUT, "synth_table.tdms")) as w:
        w.write_segment([RootObject(properties=meta), GroupObject("Table"),
                         ChannelObject("Table", "Time", cols["t"])] +
                        [ChannelObject("Table", q.upper(), cols[q]) for q in qs])
    write_map(os.path.join(OUT, "synth_table.map.toml"),
              [("time", {"name": "Table/Time"})] + [(q, {"name": "Table/" + q.upper()}) for q in qs])
    mat = {"t": cols["t"], "rig": meta}
    for q in qs:
        mat["log_" + q] = cols[q]
    scipy.io.savemat(os.path.join(OUT, "synth_table_v7.mat"), mat, do_compression=True, oned_as="column")
    write_map(os.path.join(OUT, "synth_table_v7.map.toml"),
              [("time", {"name": "t"})] + [(q, {"name": "log_" + q}) for q in qs])
    dt = float(np.median(np.diff(cols["t"])))
    rig_num = {}
    for k, v in meta.items():
        try:
            rig_num[k] = float(v) if k.endswith(("_kg", "_m", "_n", "_hz")) or "_n_per_m" in k else v
        except ValueError:
            rig_num[k] = v
    mat = {"rig": rig_num}
    for q in qs:
        mat[q] = cols[q].reshape(1, -1)  # row vectors
    scipy.io.savemat(os.path.join(OUT, "synth_rate.mat"), mat, do_compression=False, format="5")
    write_map(os.path.join(OUT, "synth_rate.map.toml"),
              [(q, {"name": q, "rate_hz": round(1.0 / dt, 6), "t0_s": float(cols["t"][0])}) for q in qs])

    # 3. A bundled log with jitter and lost buffers as single-float waveforms.
    wf_tdms(os.path.join(ROOT, "datasets", "char_N2.2.mcap"), os.path.join(OUT, "char_N2.2_wf.tdms"), np.float32,
            {"x0": ("DAQ", "drive"), "x1": ("DAQ", "x1"), "x2": ("DAQ", "x2"), "v2": ("DAQ", "v2"),
             "a2": ("Fast", "a2"), "normal_force": ("Slow", "force")},
            mm_positions=False, segments=1)

    broken_files()


def patched(src, dst, fn):
    b = bytearray(open(src, "rb").read())
    fn(b)
    open(dst, "wb").write(bytes(b))


def broken_files():
    wf = os.path.join(OUT, "synth_wf.tdms")
    wmap = open(os.path.join(OUT, "synth_wf.map.toml")).read()
    mat = os.path.join(OUT, "synth_table_v7.mat")
    mmap = open(os.path.join(OUT, "synth_table_v7.map.toml")).read()

    def tdms(name, fn, with_map=True):
        patched(wf, os.path.join(BROKEN, name + ".tdms"), fn)
        if with_map:
            open(os.path.join(BROKEN, name + ".map.toml"), "w").write(wmap)

    def mfile(name, fn, with_map=True, src=mat):
        patched(src, os.path.join(BROKEN, name + ".mat"), fn)
        if with_map:
            open(os.path.join(BROKEN, name + ".map.toml"), "w").write(mmap)

    data = open(wf, "rb").read()
    # Truncated in the middle of the first segment's raw data.
    tdms("tdms_truncated", lambda b: b.__delitem__(slice(len(data) // 3, None)))
    # The first segment flagged big-endian (ToC bit 6).
    tdms("tdms_big_endian", lambda b: b.__setitem__(slice(4, 8), struct.pack("<I", struct.unpack("<I", b[4:8])[0] | 0x40)))
    # The first segment flagged as DAQmx raw data (ToC bit 7).
    tdms("tdms_daqmx", lambda b: b.__setitem__(slice(4, 8), struct.pack("<I", struct.unpack("<I", b[4:8])[0] | 0x80)))

    # The length of the first property name (after the root path "/" and its
    # raw data index) set to 2^31.
    def corrupt_len(b):
        at = 28 + 4 + 4 + 1 + 4 + 4
        b[at:at + 4] = struct.pack("<I", 0x80000000)
    tdms("tdms_corrupt_length", corrupt_len)
    tdms("tdms_no_map", lambda b: None, with_map=False)

    mdata = open(mat, "rb").read()
    mfile("mat_truncated", lambda b: b.__delitem__(slice(len(mdata) // 2, None)))

    # The first variable's byte count set to 2^31.
    def mat_len(b):
        b[132:136] = struct.pack("<I", 0x80000000)
    mfile("mat_corrupt_length", mat_len)
    mfile("mat_no_map", lambda b: None, with_map=False)
    # x1 is text, not numbers.
    meta, cols = table(os.path.join(OUT, "synth_table.parquet"))
    d = {"t": cols["t"], "rig": meta, "log_x0": cols["x0"], "log_x1": "forty-two", "log_x2": cols["x2"]}
    p = os.path.join(BROKEN, "mat_wrong_type.mat")
    scipy.io.savemat(p, d, do_compression=True, oned_as="column")
    open(p.replace(".mat", ".map.toml"), "w").write(
        '[columns]\ntime = { name = "t" }\nx0 = { name = "log_x0" }\nx1 = { name = "log_x1" }\nx2 = { name = "log_x2" }\n')
    # A -v7.3 file: MATLAB's 512-byte user block, then the HDF5 signature.
    head = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 30 12:00:00 2026 HDF5 schema 1.00 ."
    head = head.ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0200) + b"IM"
    body = head.ljust(512, b"\0") + b"\x89HDF\r\n\x1a\n" + b"\0" * 504
    open(os.path.join(BROKEN, "mat_v73.mat"), "wb").write(body)
    open(os.path.join(BROKEN, "mat_v73.map.toml"), "w").write(mmap)


if __name__ == "__main__":
    sys.exit(main())

# SPDX-License-Identifier: LGPL-2.1-or-later
"""The instrument protocol parser, sequence tracking and calibration (core: numpy only)."""
from __future__ import annotations

import json
import time

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.instrument import (Acquisition, Calibration, Record, SequenceTracker, checksum,
                                        format_record, load_calibration, parse_line)


def test_checksum_matches_the_nmea_0183_example():
    line = b"$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47"
    assert checksum(line[1:-3]) == 0x47


def test_format_record_round_trips_every_kind():
    assert parse_line(format_record("P,7,1.5,-2,3.25,90,30.5")[:-2]) == Record("P", 7, (1.5, -2.0, 3.25, 90.0, 30.5))
    assert parse_line(format_record("P,8,1,2,3,4,")[:-2]) == Record("P", 8, (1.0, 2.0, 3.0, 4.0, None))
    assert parse_line(format_record("Q,9,1,2,3")[:-2]) == Record("Q", 9, (1.0, 2.0, 3.0))
    assert parse_line(format_record("S,10,hub")[:-2]) == Record("S", 10, ("hub",))
    assert parse_line(format_record("E,11")[:-2]) == Record("E", 11, ())


@pytest.mark.parametrize("body", ["P,1,1,2,3,4", "P,x,1,2,3,4,5", "P,1,1,2,nan,4,5", "Q,1,1,2", "S,1,",
                                  "S,1,a;b", "S,1,#x", "E", "E,-1", "Z,1", "P,1,1,2,3,4,5,6"])
def test_well_framed_but_unreadable_records_are_malformed(body):
    assert parse_line(format_record(body)[:-2]) == "malformed"


@pytest.mark.parametrize("line", [b"", b"$P,1", b"P,1,2*00", b"$P,1,2*G0", b"$P,1,2*0", b"\xff\xfe$*"])
def test_unframed_lines_are_malformed(line):
    assert parse_line(line) == "malformed"


def test_a_wrong_checksum_is_bad_checksum():
    good = format_record("Q,1,1,2,3")[:-2]
    assert parse_line(good[:-2] + b"00") == "bad_checksum"
    assert parse_line(good.replace(b"1,2", b"1,3")) == "bad_checksum"


def test_sequence_tracker_counts_gaps_and_drops_duplicates():
    t = SequenceTracker()
    assert [t.accept(s) for s in (1, 2, 5, 5, 3, 3, 9)] == [True, True, True, False, True, False, True]
    assert t.missing == 4  # 4, 6, 7, 8
    t2 = SequenceTracker()
    t2.accept(4)
    assert t2.missing == 3  # 1, 2, 3: the first record the reader saw was not seq 1


def test_known_calibration_with_synthetic_readings():
    cal = Calibration(beam_direction=(-2, 0, 0), sensor_offset=(1, 2, 3), rotary_axis_point=(10, 0, 0),
                      rotary_axis_direction=(0, 0, 5))
    # spot = (50+1-30, 0+2, 5+3) = (21, 2, 8); about the axis: (11, 2); turned by -90 deg: (2, -11)
    p = cal.to_points([50.0], [0.0], [5.0], [90.0], [30.0])
    np.testing.assert_allclose(p, [[12.0, -11.0, 8.0]], atol=1e-12)
    p0 = cal.to_points([50.0], [0.0], [5.0], [0.0], [30.0])
    np.testing.assert_allclose(p0, [[21.0, 2.0, 8.0]], atol=1e-12)


def test_calibration_inverse_round_trips_on_a_tilted_axis():
    rng = np.random.default_rng(3)
    cal = Calibration(beam_direction=(-1, 0.1, 0.05), sensor_offset=(0.5, -1.2, 3.0),
                      rotary_axis_point=(100, 20, -5), rotary_axis_direction=(0.02, -0.01, 1))
    pts = rng.normal(scale=30, size=(500, 3))
    W = rng.uniform(-180, 180, 500)
    D = rng.uniform(10, 40, 500)
    r = cal.to_readings(pts, W, D)
    np.testing.assert_allclose(r[:, 3:], np.column_stack([W, D]))
    np.testing.assert_allclose(cal.to_points(*r.T), pts, atol=1e-10)


def test_load_calibration_reads_json(tmp_path):
    f = tmp_path / "cal.json"
    f.write_text(json.dumps({"beam_direction": [0, -1, 0], "sensor_offset": [0, 0, 1],
                             "rotary_axis_point": [1, 2, 3], "rotary_axis_direction": [0, 0, 1],
                             "d_range": [5, 45]}))
    cal = load_calibration(f)
    assert cal.beam_direction == (0.0, -1.0, 0.0) and cal.d_range == (5.0, 45.0)


@pytest.mark.parametrize("content, words", [
    ('{"beam_direction": [0, -1, 0]}', "missing field(s) sensor_offset"),
    ("{not json", "line 1: not valid JSON"),
    ("[1, 2]", "expected a JSON object"),
    ('{"beam_direction": [0, 0, 0], "sensor_offset": [0, 0, 0], "rotary_axis_point": [0, 0, 0],'
     ' "rotary_axis_direction": [0, 0, 1]}', "beam_direction must be 3 finite numbers, not all zero"),
    ('{"beam_direction": [1, 0], "sensor_offset": [0, 0, 0], "rotary_axis_point": [0, 0, 0],'
     ' "rotary_axis_direction": [0, 0, 1]}', "beam_direction must be a list of 3 numbers"),
    ('{"beam_direction": [1, 0, 0], "sensor_offset": [0, 0, 0], "rotary_axis_point": [0, 0, 0],'
     ' "rotary_axis_direction": [0, 0, 1], "beam_dir": 1}', "unknown field(s) beam_dir"),
])
def test_bad_calibration_files_give_one_clear_message(tmp_path, content, words):
    f = tmp_path / "cal.json"
    f.write_text(content)
    with pytest.raises(BladeReconError) as err:
        load_calibration(f)
    assert str(f) in str(err.value) and words in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(BladeReconError, match="file not found"):
        load_calibration(tmp_path / "nope.json")


def _stream() -> bytes:
    lines = [format_record("S,1,hub"), format_record("P,2,50,0,5,90,30"), format_record("P,3,50,0,5,0,"),
             format_record("Q,4,1,2,3"), format_record("S,5,tip"), format_record("Q,6,4,5,6"),
             format_record("E,7")]
    return b"".join(lines)


def test_acquisition_is_the_same_in_any_chunking():
    data = b"START\r\n" + _stream()  # a host command echoed back is ignored
    whole = Acquisition()
    whole.feed(data)
    bytewise = Acquisition()
    for i in range(len(data)):
        bytewise.feed(data[i:i + 1])
    for acq in (whole, bytewise):
        assert acq.done and acq.section_names == ["hub", "tip"]
        assert acq.summary() == {"records": 7, "points": 3, "sections": 2, "bad_checksum": 0, "malformed": 0,
                                 "out_of_range": 1, "missing_seq": 0, "duplicates": 0, "reconnects": 0}
        pts, sec = acq.points()
        np.testing.assert_allclose(pts, [[0.0, -20.0, 5.0], [1, 2, 3], [4, 5, 6]], atol=1e-12)
        assert sec.tolist() == [0, 0, 1]


def test_a_record_cut_by_a_disconnect_costs_only_itself():
    acq = Acquisition()
    cut = format_record("Q,1,1,2,3")[:6]
    acq.feed(cut)
    acq.feed(format_record("Q,2,1,2,3") + format_record("Q,2,1,2,3") + format_record("E,3"))
    s = acq.summary()
    assert (s["malformed"], s["missing_seq"], s["duplicates"], s["points"]) == (1, 1, 1, 1)
    assert acq.section_names == ["0"]  # points before any $S


def test_garbage_without_line_ends_is_bounded():
    acq = Acquisition()
    junk = bytes(range(256)).replace(b"\n", b"") * 40
    for i in range(0, len(junk), 1000):
        acq.feed(junk[i:i + 1000])
        assert len(acq._pending) <= acq.max_line + 1000  # memory stays bounded
    acq.finish()
    assert acq.summary()["records"] == 0 and acq.summary()["malformed"] >= 2


def test_d_range_readings_outside_are_out_of_range():
    acq = Acquisition(Calibration(d_range=(10, 40)))
    acq.feed(format_record("P,1,0,0,0,0,5") + format_record("P,2,0,0,0,0,20") + format_record("P,3,0,0,0,0,45"))
    assert acq.summary()["out_of_range"] == 2 and acq.summary()["points"] == 1


def test_parser_speed_in_memory():
    """Parsing alone, no I/O: the floor the serial reader adds its transport cost to."""
    from bladerecon.acquire.simulator import sample_plan
    plan = sample_plan(4, 5000)
    data = b"".join(plan.lines)
    t = time.perf_counter()
    acq = Acquisition()
    acq.feed(data)
    acq.points()
    rate = len(plan.lines) / (time.perf_counter() - t)
    print(f"\nparser, in memory: {rate:,.0f} records/s")
    assert acq.summary()["points"] == 20000      # speed is printed, not asserted: make bench times it

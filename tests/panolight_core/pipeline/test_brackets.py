"""A bracket set through ``panolight estimate``: exposures from EXIF or --evs, merged, restored, recorded; bad sets
refused in one line naming the file."""
import json

import numpy as np
import pytest
from PIL import Image
from PIL.TiffImagePlugin import IFDRational

from panolight_core import metrics
from panolight_core.apps.cli import main
from panolight_core.camera import auto_exposure, hdr_to_ldr
from panolight_core.io import write_image
from tests.panolight_core.estimators.sources.test_restore import _clear_day


def _frame(path, ldr, time_s=None, f_number=None, iso=None, bias=None):
    """A JPEG with the exposure EXIF a camera writes (ExposureTime, FNumber, ISO, ExposureBiasValue)."""
    exif = Image.Exif()
    ifd = exif.get_ifd(0x8769)
    if time_s is not None:
        ifd[0x829A] = IFDRational(*(1, round(1 / time_s)) if time_s < 1 else (round(time_s), 1))
    if f_number is not None:
        ifd[0x829D] = IFDRational(round(10 * f_number), 10)
    if iso is not None:
        ifd[0x8827] = iso
    if bias is not None:
        ifd[0x9204] = IFDRational(round(6 * bias), 6)
    Image.fromarray(ldr).save(path, quality=95, exif=exif)
    return str(path)


def _city(rows: int) -> np.ndarray:
    """Blender's city panorama at ``rows`` x 2 rows: another scene than the clear day's."""
    from panolight_core.camera.resample import area_downsample
    from panolight_core.data import load_studio_hdri

    return area_downsample(load_studio_hdri("city"), rows).astype(np.float32)


@pytest.fixture(scope="module")
def day():
    return _clear_day()


def test_a_set_with_its_exif_is_merged_restored_and_recorded(tmp_path, day):
    """Three frames whose EXIF changes time and ISO (1/1000 s ISO 100, 1/250 ISO 100, 1/250 ISO 400: -2, 0, +2
    stops): the set's sun comes back where it is, as a light, and lighting.json names every frame."""
    truth, s, _ = day
    files = [_frame(tmp_path / f"f{i}.jpg", hdr_to_ldr(truth, ev), t, 8.0, iso)
             for i, (ev, t, iso) in enumerate(((-2, 1 / 1000, 100), (0, 1 / 250, 100), (2, 1 / 250, 400)))]
    assert main(["estimate", *files, "-o", str(tmp_path / "out"), "-q"]) == 0
    doc = json.loads((tmp_path / "out" / "lighting.json").read_text())
    b = doc["source"]["brackets"]
    assert b["exposures_from"].startswith("EXIF") and b["stops"] == pytest.approx([-2, 0, 2], abs=0.01)
    assert doc["source"]["path"] == files[1] and doc["source"]["dynamic_range"] == "hdr-merged-brackets"
    assert len(b["sha256"]) == 3 and b["ceiling"] == pytest.approx(4.0, rel=0.01)
    assert b["response"]["curve"] == "sRGB"  # the evaluation's camera: its own curve explains it no better
    assert doc["estimator"]["restoration"]["restored"]
    key = metrics.brightest_light(doc["lights"])
    assert metrics.angle_deg(key["direction"], s) < 1.0


def test_evs_give_the_exposures_where_the_files_have_none(tmp_path, day):
    truth, _, _ = day
    files = [_frame(tmp_path / f"g{i}.jpg", hdr_to_ldr(truth, ev)) for i, ev in enumerate((-2, 0, 2))]
    assert main(["estimate", *files, "-o", str(tmp_path / "a"), "-q", "--evs=-2,0,2"]) == 0
    doc = json.loads((tmp_path / "a" / "lighting.json").read_text())
    assert doc["source"]["brackets"]["exposures_from"] == "--evs"


@pytest.mark.parametrize("case, match", [
    ("no exif", r"g0.jpg: records no exposure .*--evs"),
    ("one with evs", r"g0.jpg: --evs gives a bracket set's exposures; one file"),
    ("evs count", r"--evs gives 2 exposure\(s\) for 3 file\(s\)"),
    ("same exposures", r"less than an eighth of a stop apart"),
    ("sizes", r"small.jpg: 32x16, but g0.jpg is .*one size"),
    ("hdr frame", r"frame.exr: a bracket frame must be an 8-bit picture"),
    ("listed out of order", r"g1.jpg \(exposed 2 stops more than g2.jpg\) is darker than g2.jpg over 100 % .*--evs"),
    ("another scene", r"city.jpg \(exposed 2 stops more than g0.jpg\) does not show the scene g0.jpg shows"),
])
def test_bad_sets_are_refused_in_one_line(tmp_path, day, capsys, case, match):
    truth, _, _ = day
    files = [_frame(tmp_path / f"g{i}.jpg", hdr_to_ldr(truth, ev)) for i, ev in enumerate((-2, 0, 2))]
    args = {"no exif": files, "one with evs": [files[0], "--evs=-2"], "evs count": [*files, "--evs=-2,0"],
            "same exposures": [*files, "--evs=0,0.1,2"],
            "sizes": [files[0], _frame(tmp_path / "small.jpg", np.zeros((16, 32, 3), np.uint8)), "--evs=-2,0"],
            "hdr frame": [files[0], str(write_image(tmp_path / "frame.exr", truth)), "--evs=-2,0"],
            "listed out of order": [files[2], files[1], files[0], "--evs=-2,0,2"],  # the files' order, not theirs
            "another scene": [files[0], _frame(tmp_path / "city.jpg", hdr_to_ldr(_city(truth.shape[0]), 0)),
                              "--evs=-2,0"]}[case]  # a pair: no set holds without one of them
    assert main(["estimate", *args, "-o", str(tmp_path / "out"), "-q"]) != 0
    err = capsys.readouterr().err
    assert len([line for line in err.splitlines() if line.startswith("panolight: error")]) == 1
    assert __import__("re").search(match, err), err
    assert not (tmp_path / "out").exists()  # nothing written, no folder left


def test_batch_groups_sorted_files_into_sets_and_resumes_them(tmp_path, day, capsys):
    """--brackets 3: six files, two sets (sorted by name), each merged into one output folder named after its first
    frame; a second run finds both up to date; a count that does not divide is refused before any work."""
    truth, _, _ = day
    shots = tmp_path / "shots"
    shots.mkdir()
    for scene in ("a", "b"):
        for i, ev in enumerate((-2, 0, 2)):
            _frame(shots / f"{scene}_{i}.jpg", hdr_to_ldr(truth, ev))
    out = tmp_path / "out"
    assert main(["batch", str(shots), "-o", str(out), "--brackets", "3", "--evs=-2,0,2", "--jobs", "1", "-q"]) == 0
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["a_0", "b_0"]
    doc = json.loads((out / "b_0" / "lighting.json").read_text())
    assert [p.rsplit("/", 1)[-1] for p in doc["source"]["brackets"]["files"]] == ["b_0.jpg", "b_1.jpg", "b_2.jpg"]
    assert main(["batch", str(shots), "-o", str(out), "--brackets", "3", "--evs=-2,0,2", "--jobs", "1", "-q"]) == 0
    report = json.loads((out / "batch_report.json").read_text())
    assert [r["status"] for r in report["results"]] == ["skipped", "skipped"]
    assert main(["batch", str(shots), "-o", str(tmp_path / "x"), "--brackets", "4"]) != 0
    assert "6 file(s) do not make whole sets of 4 frames" in capsys.readouterr().err
    assert main(["batch", str(shots), "-o", str(tmp_path / "y"), "--evs=-2,0,2"]) != 0
    assert "give --brackets N too" in capsys.readouterr().err


def test_batch_auto_groups_sets_of_any_size_by_their_exif_exposures(tmp_path, day, capsys):
    """--brackets auto: a 3-frame set, a 5-frame set and a lone shot in one folder (sorted by name, each camera
    sequence starting at ev 0): a new set where an exposure repeats, the lone shot estimated alone; a file with no
    EXIF exposure, or --evs given too, is refused before any work."""
    truth, _, _ = day
    shots = tmp_path / "shots"
    shots.mkdir()
    for scene, evs in (("a", (0, -2, 2)), ("b", (0, -2, 2, -4, 4)), ("c", (0,))):
        for i, ev in enumerate(evs):
            _frame(shots / f"{scene}_{i}.jpg", hdr_to_ldr(truth, ev), 2.0 ** ev / 250, 8.0, 100)
    out = tmp_path / "out"
    assert main(["batch", str(shots), "-o", str(out), "--brackets", "auto", "--jobs", "1", "-q"]) == 0
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == ["a_0", "b_0", "c_0"]
    frames = {d: json.loads((out / d / "lighting.json").read_text())["source"].get("brackets")
              for d in ("a_0", "b_0", "c_0")}
    assert len(frames["a_0"]["files"]) == 3 and frames["b_0"]["stops"] == pytest.approx([0, -2, 2, -4, 4], abs=0.05)
    assert frames["c_0"] is None  # the lone shot: one JPEG
    _frame(shots / "d_0.jpg", hdr_to_ldr(truth, 0))  # no EXIF
    assert main(["batch", str(shots), "-o", str(tmp_path / "x"), "--brackets", "auto"]) != 0
    err = capsys.readouterr().err
    assert "d_0.jpg: records no exposure (EXIF ExposureTime and FNumber), which --brackets auto" in err
    assert main(["batch", str(shots), "-o", str(tmp_path / "y"), "--brackets", "auto", "--evs=-2,0,2"]) != 0
    assert "--brackets auto groups the files by their EXIF exposures" in capsys.readouterr().err
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_batch_auto_takes_exif_in_legal_but_unexpected_shapes(tmp_path, day):
    """Trust round 4: an ExposureTime written as text, an ISOSpeedRatings of two values and a DateTimeOriginal in
    year 9999 at -12:00 reached an unguarded float() or astimezone and killed the whole batch before any input ran,
    good photos included. Now the set merges from its text exposures and every input gets its estimate."""
    truth, _, _ = day
    shots = tmp_path / "shots"
    shots.mkdir()
    for i, (ev, time_text) in enumerate(((0, "1/250"), (-2, "1/1000"), (2, "1/62.5"))):
        exif = Image.Exif()
        ifd = exif.get_ifd(0x8769)
        ifd[0x829A], ifd[0x829D], ifd[0x8827] = time_text, "8", (100, 200)
        ifd[0x9003], ifd[0x9011] = "9999:12:31 23:59:59", "-12:00"
        Image.fromarray(hdr_to_ldr(truth, ev)).save(shots / f"a_{i}.jpg", quality=95, exif=exif)
    _frame(shots / "b_0.jpg", hdr_to_ldr(truth, 0), 1 / 250, 8.0, 100)
    out = tmp_path / "out"
    assert main(["batch", str(shots), "-o", str(out), "--brackets", "auto", "--jobs", "1", "-q"]) == 0
    report = json.loads((out / "batch_report.json").read_text())
    assert [r["status"] for r in report["results"]] == ["ok", "ok"]
    doc = json.loads((out / "a_0" / "lighting.json").read_text())
    assert doc["source"]["brackets"]["stops"] == pytest.approx([0, -2, 2], abs=0.01)


def test_a_bracket_record_round_trips_and_any_other_text_is_refused_in_one_line():
    """BracketSet.record / from_record: what Blender keeps on a merged image (an ID property a user or a script can
    edit), validated through io.metadata; fuzzed with text of any shape."""
    from hypothesis import given, settings
    from hypothesis import strategies as st

    from panolight_core.errors import PanoLightError
    from panolight_core.pipeline.brackets import BracketSet

    for evs in (None, (-2.0, 0.0, 2.0)):
        s = BracketSet(["a.jpg", "b.jpg", "c.jpg"], evs)
        assert BracketSet.from_record(s.record()) == s

    values = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=10)),
                          lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                  st.dictionaries(st.sampled_from(["files", "evs"]), inner)),
                          max_leaves=12)

    @settings(max_examples=200, deadline=None)
    @given(st.one_of(values.map(json.dumps), st.text(max_size=50), values))
    def fuzz(raw):
        try:
            s = BracketSet.from_record(raw)
        except PanoLightError as exc:
            assert "load the set again" in str(exc)
        else:
            assert len(s.paths) >= 2 and (s.evs is None or len(s.evs) == len(s.paths))

    fuzz()


def test_a_tripod_set_is_merged_as_shot_with_no_align(tmp_path, day):
    """--no-align (estimate and batch; Blender's Align brackets): the frames are merged as they are, and
    lighting.json says so (source.brackets.aligned)."""
    truth, _, _ = day
    files = [_frame(tmp_path / f"t{i}.jpg", hdr_to_ldr(truth, ev)) for i, ev in enumerate((-2, 0, 2))]
    assert main(["estimate", *files, "--evs", "-2,0,2", "--no-align", "-o", str(tmp_path / "a"), "-q"]) == 0
    b = json.loads((tmp_path / "a" / "lighting.json").read_text())["source"]["brackets"]
    assert b["aligned"] is False and "shifts" not in b
    assert main(["estimate", *files, "--evs", "-2,0,2", "-o", str(tmp_path / "b"), "-q"]) == 0
    b = json.loads((tmp_path / "b" / "lighting.json").read_text())["source"]["brackets"]
    assert b["aligned"] is True and b["shifts"] == [[0, 0]] * 3
    assert main(["batch", *files, "-o", str(tmp_path / "c"), "--brackets", "3", "--evs", "-2,0,2", "--no-align",
                 "-q", "--jobs", "1"]) == 0
    doc = json.loads((tmp_path / "c" / "t0" / "lighting.json").read_text())
    assert doc["source"]["brackets"]["aligned"] is False


def _timed_frame(path, ldr, time_s, taken: str, subsec: str = "00", manual: bool = False):
    """A JPEG with an exposure time (f/8, ISO 100), the camera's DateTimeOriginal / SubSecTimeOriginal and, with
    ``manual``, ExposureMode 1 (the photographer set the exposure, as a phone app or a dial does; else auto, 0)."""
    exif = Image.Exif()
    ifd = exif.get_ifd(0x8769)
    ifd[0x829A] = IFDRational(*(1, round(1 / time_s)) if time_s < 1 else (round(time_s), 1))
    ifd[0x829D], ifd[0x8827], ifd[0x9003], ifd[0x9291] = IFDRational(8, 1), 100, taken, subsec
    ifd[0xA402] = 1 if manual else 0
    Image.fromarray(ldr).save(path, quality=95, exif=exif)
    return path


def test_a_set_shot_by_hand_a_stop_at_a_time_is_one_set_and_other_shots_stay_alone(tmp_path):
    """Real case: an iPhone set exposed by hand a stop apart, 7-27 s between frames (a tripod, an exposure app), became
    nine single shots. Frames exposed by hand, within SLOW_BRACKET_GAP_S, stepping on one way and shown to be the
    previous frame's scene make one set; an auto-exposed frame, another scene, a step back or a frame minutes later
    begins another (each checked here), and an auto-exposed sequence 20 s apart stays single shots."""
    from panolight_core.data import load_studio_hdri
    from panolight_core.pipeline.brackets import SLOW_BRACKET_GAP_S, BracketSet, group_by_exposure

    city, forest = load_studio_hdri("city"), load_studio_hdri("forest")
    shots = tmp_path / "shots"
    shots.mkdir()
    k = auto_exposure(city, 0.0, robust=True)
    plan = [  # name, scene, stop, seconds after 12:00:00, by hand
        ("a0", city, -2, 0, True), ("a1", city, -1, 20, True), ("a2", city, 0, 45, True), ("a3", city, 1, 60, True),
        ("b0", forest, 2, 80, True),  # another scene, by hand, the steps going on: a new set
        ("b1", forest, 1, 100, True),  # its own second frame
        ("c0", forest, 0, 120, False), ("c1", forest, -1, 140, False),  # auto-exposed 20 s apart: single shots
        ("d0", city, -2, 160, True), ("d1", city, -1, 180, True), ("d2", city, -2.5, 200, True),  # a step back
        ("e0", city, 0, 400, True), ("e1", city, 1, 420 + int(SLOW_BRACKET_GAP_S), True),  # too long after
    ]
    for name, scene, stop, t, manual in plan:
        taken = f"2024:06:21 12:{t // 60:02d}:{t % 60:02d}"
        _timed_frame(shots / f"{name}.jpg", hdr_to_ldr(scene, scale=k * 2.0 ** stop), 2.0 ** stop / 250, taken,
                     manual=manual)
    groups = group_by_exposure(sorted(shots.iterdir()))
    got = [[p.stem for p in g.paths] if isinstance(g, BracketSet) else g.stem for g in groups]
    assert got == [["a0", "a1", "a2", "a3"], ["b0", "b1"], "c0", "c1", ["d0", "d1"], "d2", "e0", "e1"]


def test_auto_grouping_reads_frames_in_the_order_they_were_taken_not_their_names(tmp_path):
    """Real case: a 12-frame set shot by hand and renamed by its exposures (1_1.jpg, 1_125.jpg, 1_15.jpg ...): in name
    order its exposures jump up and down, and it broke into pieces. Where every file records when it was taken, the
    frames are read in that order: one set."""
    from panolight_core.data import load_studio_hdri
    from panolight_core.pipeline.brackets import BracketSet, group_by_exposure

    city = load_studio_hdri("city")
    k = auto_exposure(city, 0.0, robust=True)
    for t, denominator in enumerate((250, 125, 60)):  # taken 20 s apart, darkest first; by name: 1_125, 1_250, 1_60
        _timed_frame(tmp_path / f"1_{denominator}.jpg", hdr_to_ldr(city, scale=k * 250 / denominator),
                     1 / denominator, f"2024:06:21 12:00:{20 * t:02d}", manual=True)
    (group,) = group_by_exposure(sorted(tmp_path.iterdir()))
    assert isinstance(group, BracketSet) and [p.stem for p in group.paths] == ["1_250", "1_125", "1_60"]


def test_auto_grouping_splits_shots_taken_minutes_apart(tmp_path, day, capsys):
    """Real case: four single shots of four scenes, ten minutes apart, at four exposures, were grouped into one set by
    exposure alone, then refused: none got an estimate. The capture time splits them; a bracket sequence shot within
    a second stays one set."""
    from panolight_core.pipeline.brackets import BracketSet, group_by_exposure

    truth, _, _ = day
    shots = tmp_path / "shots"
    shots.mkdir()
    for i, (ev, minute) in enumerate(((0, 0), (1, 10), (-1, 20), (2, 30))):  # auto-exposed: another exposure each
        _timed_frame(shots / f"a{i}.jpg", hdr_to_ldr(truth, 0), 2.0 ** ev / 250, f"2024:06:21 12:{minute:02d}:00")
    for i, ev in enumerate((0, -2, 2)):  # AEB: 0, -2, +2 in 0.4 s
        _timed_frame(shots / f"b{i}.jpg", hdr_to_ldr(truth, ev), 2.0 ** ev / 250, "2024:06:21 13:00:00", f"{4 * i}")
    groups = group_by_exposure(sorted(shots.iterdir()))
    assert [g.name for g in groups[:4]] == ["a0.jpg", "a1.jpg", "a2.jpg", "a3.jpg"]  # each alone
    assert isinstance(groups[4], BracketSet) and [p.name for p in groups[4].paths] == ["b0.jpg", "b1.jpg", "b2.jpg"]
    out = tmp_path / "out"
    assert main(["batch", str(shots), "-o", str(out), "--brackets", "auto", "--jobs", "1", "-q"]) == 0
    report = json.loads((out / "batch_report.json").read_text())
    assert [r["status"] for r in report["results"]] == ["ok"] * 5


def test_a_refused_set_falls_back_to_its_frames_alone(tmp_path, day, capsys):
    """A batch never ends with no output for a photo that could be estimated: a set the merge refuses (here its
    frames listed against their exposures) gets each frame estimated alone, in the set's folder, and says why."""
    truth, _, _ = day
    shots = tmp_path / "shots"
    shots.mkdir()
    for i, ev in enumerate((2, 0, -2)):  # named in the opposite order of the --evs given
        _frame(shots / f"s_{i}.jpg", hdr_to_ldr(truth, ev))
    out = tmp_path / "out"
    assert main(["batch", str(shots), "-o", str(out), "--brackets", "3", "--evs", "-2,0,2", "--jobs", "1"]) == 0
    (r,) = json.loads((out / "batch_report.json").read_text())["results"]
    assert r["status"] == "ok" and "the exposures are not the frames'" in r["note"]
    assert [f["status"] for f in r["frames"]] == ["ok"] * 3
    assert all((out / "s_0" / f"s_{i}" / "lighting.json").is_file() for i in range(3))
    assert "its frames were estimated alone" in capsys.readouterr().err


def test_one_picture_listed_under_two_exposures_is_left_out_and_said(tmp_path, day, capsys):
    """Three public sets list one frame under several exposures, and it was merged in silence (the brightest tenth
    came out 2.5x off). A frame that is the same picture as its neighbour in exposure is left out of the merge, with a
    warning naming both; a set left with one picture is refused in one line."""
    import shutil

    truth, _, _ = day
    a = _frame(tmp_path / "a.jpg", hdr_to_ldr(truth, 0))
    b = shutil.copy(a, tmp_path / "b.jpg")  # the same file under another exposure
    c = _frame(tmp_path / "c.jpg", hdr_to_ldr(truth, 2))
    assert main(["estimate", a, str(b), c, "--evs", "0,1,2", "-o", str(tmp_path / "out"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "b.jpg: the same picture as a.jpg though its exposure says 1 stops more: left out of the merge" in err
    record = json.loads((tmp_path / "out" / "lighting.json").read_text())["source"]["brackets"]
    assert [d["file"] for d in record["dropped"]] == [str(b)] and record["stops"] == pytest.approx([0, 1, 2], abs=1e-3)
    assert record["files"][record["reference"]] == json.loads((tmp_path / "out" / "lighting.json").read_text())["source"]["path"]
    assert main(["estimate", a, str(b), "--evs", "0,1", "-o", str(tmp_path / "none"), "-q"]) == 1
    assert "every frame of the set is the same picture" in capsys.readouterr().err


def test_a_set_writes_what_it_clipped_in_every_frame_as_a_mask(tmp_path, day):
    """clipped.png (the previews group, bracket sets only): white where the set clipped in every frame, the share
    lighting.json records; a single picture writes none, and a later single run into the folder removes a set's."""
    truth, s, _ = day
    files = [_frame(tmp_path / f"m{i}.jpg", hdr_to_ldr(truth, ev)) for i, ev in enumerate((-2, 0, 2))]
    assert main(["estimate", *files, "--evs", "-2,0,2", "-o", str(tmp_path / "out"), "-q"]) == 0
    mask = np.asarray(Image.open(tmp_path / "out" / "clipped.png"))[..., 0] > 127
    record = json.loads((tmp_path / "out" / "lighting.json").read_text())["source"]["brackets"]
    assert mask.sum() > 0 and mask.mean() == pytest.approx(record["clipped_in_every_frame"], abs=1e-6)
    from panolight_core import sh

    ys, xs = np.nonzero(mask)
    d = sh.pixel_directions(*mask.shape)[ys, xs]
    assert np.degrees(np.arccos(np.clip(d @ s, -1, 1))).max() < 10.0  # the sun, nothing else
    assert main(["estimate", files[1], "-o", str(tmp_path / "out"), "-q"]) == 0
    assert not (tmp_path / "out" / "clipped.png").exists()  # an earlier run's output this run does not write


def test_a_phone_s_compensation_series_is_timed_by_its_exposure_bias(tmp_path, day, capsys):
    """A phone's exposure-compensation series at -2, -1, 0 and +1 EV: past its shortest shutter and lowest ISO it
    records 1/1000 s at ISO 100 for both -2 and -1 (a gain it does not record). The EXIF's exposures repeat, its
    biases tell the frames apart: the set is timed by its bias, said in a warning naming the file, and recorded.
    Without the bias tags the same set is refused as before."""
    truth, _, _ = day
    shots = ((-2, 1 / 1000), (-1, 1 / 1000), (0, 1 / 500), (1, 1 / 250))
    files = [_frame(tmp_path / f"p{i}.jpg", hdr_to_ldr(truth, ev), t, 1.8, 100, bias=ev)
             for i, (ev, t) in enumerate(shots)]
    assert main(["estimate", *files, "-o", str(tmp_path / "out"), "-q"]) == 0
    assert "p1.jpg: records the exposure of p0.jpg though its exposure bias is -1 EV" in capsys.readouterr().err
    b = json.loads((tmp_path / "out" / "lighting.json").read_text())["source"]["brackets"]
    assert b["exposures_from"].startswith("EXIF exposure bias")
    assert b["stops"] == pytest.approx([-1, 0, 1, 2], abs=0.01)  # about the -1 EV frame
    bare = [_frame(tmp_path / f"q{i}.jpg", hdr_to_ldr(truth, ev), t, 1.8, 100) for i, (ev, t) in enumerate(shots)]
    assert main(["estimate", *bare, "-o", str(tmp_path / "bare"), "-q"]) != 0
    assert "less than an eighth of a stop apart" in capsys.readouterr().err


def _forest(rows: int) -> np.ndarray:
    """Blender's forest panorama at ``rows`` x 2 rows: another scene than the city's."""
    from panolight_core.camera.resample import area_downsample
    from panolight_core.data import load_studio_hdri

    return area_downsample(load_studio_hdri("forest"), rows).astype(np.float32)


def test_a_frame_of_another_scene_amid_a_set_is_left_out_named_and_recorded(tmp_path, capsys):
    """Blender's city at -2 and +2 with the forest at 0 between them (a set grouped across two scenes): the forest's
    frame contradicts both neighbours and the set holds without it, so it is left out, named in a warning and in
    lighting.json (``source.brackets.left_out``), and the city's two frames are merged and estimated."""
    city, forest = _city(128), _forest(128)
    files = [_frame(tmp_path / "c0.jpg", hdr_to_ldr(city, -2)), _frame(tmp_path / "forest.jpg", hdr_to_ldr(forest, 0)),
             _frame(tmp_path / "c2.jpg", hdr_to_ldr(city, 2))]
    assert main(["estimate", *files, "--evs=-2,0,2", "-o", str(tmp_path / "out"), "-q"]) == 0
    assert "forest.jpg: left out of the merge, the set holding without it: forest.jpg" in capsys.readouterr().err
    b = json.loads((tmp_path / "out" / "lighting.json").read_text())["source"]["brackets"]
    assert [d["file"] for d in b["left_out"]] == [files[1]] and "does not show the scene" in b["left_out"][0]["why"]
    assert b["stops"] == pytest.approx([0, 2, 4], abs=0.01) and b["shifts"][1] is None


def test_a_batch_estimates_a_frame_its_set_left_out_alone(tmp_path, capsys):
    """batch --brackets 3 over a set with another scene's frame amid it: the set is merged without it, and that frame,
    still a photo, is estimated alone in the set's folder; the report and the summary say so."""
    city = _city(128)
    shots = tmp_path / "shots"
    shots.mkdir()
    _frame(shots / "s_0.jpg", hdr_to_ldr(city, -2))
    _frame(shots / "s_1.jpg", hdr_to_ldr(_forest(128), 0))
    _frame(shots / "s_2.jpg", hdr_to_ldr(city, 2))
    out = tmp_path / "out"
    assert main(["batch", str(shots), "-o", str(out), "--brackets", "3", "--evs", "-2,0,2", "--jobs", "1"]) == 0
    (r,) = json.loads((out / "batch_report.json").read_text())["results"]
    assert r["status"] == "ok" and [f["input"] for f in r["frames"]] == [str(shots / "s_1.jpg")]
    assert (out / "s_0" / "lighting.json").is_file() and (out / "s_0" / "s_1" / "lighting.json").is_file()
    assert "1 frame(s) left out of the set were estimated alone" in capsys.readouterr().err


def test_a_set_whose_camera_undid_its_steps_is_refused_in_one_line_and_batch_estimates_its_frames_alone(tmp_path,
                                                                                                          capsys):
    """Real case: four public sets listed frames a stop apart that a camera's auto ISO had taken at one exposure; they
    were merged in silence into an HDR 0.4-0.96 off OpenCV's. Now ``estimate`` refuses the set naming the two frames
    and what to do; ``batch`` estimates each frame alone and its report says why."""
    from panolight_core.data import load_studio_hdri

    city = load_studio_hdri("city")
    k = auto_exposure(city, 0.0, robust=True)
    files = [_frame(tmp_path / f"u{i}.jpg", hdr_to_ldr(city, scale=k * 2.0 ** s, jpeg_quality=90,
                                                      noise=np.random.default_rng(i)))
             for i, s in enumerate((-1, 0, 0.03))]  # the third shot at the second's exposure, listed a stop over it
    assert main(["estimate", *files, "--evs", "-1,0,1", "-o", str(tmp_path / "out"), "-q"]) == 1
    err = capsys.readouterr().err
    assert "u2.jpg (exposed 1 stops more than u1.jpg) reads the same exposure as u1.jpg" in err and "--evs" in err
    assert "Traceback" not in err and not (tmp_path / "out" / "lighting.json").exists()
    out = tmp_path / "batch"
    assert main(["batch", *files, "-o", str(out), "--brackets", "3", "--evs", "-1,0,1", "--jobs", "1", "-q"]) == 0
    (r,) = json.loads((out / "batch_report.json").read_text())["results"]
    assert "reads the same exposure" in r["note"] and [f["status"] for f in r["frames"]] == ["ok"] * 3

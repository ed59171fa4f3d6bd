"""What a killed run left is cleaned only where PanoLight can prove it made it."""
import json
import subprocess
import sys

from panolight_core.io.staging import MARKER, clean_stale, make_stage


def _dead_pid() -> int:
    """The pid of a process that has exited (so it no longer runs)."""
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_users_files_that_look_like_temporaries_are_never_deleted(tmp_path):
    (tmp_path / ".draft.tmp4000000").write_text("a draft")
    (tmp_path / ".thesis.tmp4000001.docx").write_text("a thesis")
    (tmp_path / ".lighting.json.tmp4000003").write_text("my notes")  # our name, not our content
    user = tmp_path / ".panolight-4000002"
    user.mkdir()
    (user / "notes.txt").write_text("mine")
    assert clean_stale(tmp_path, {"lighting.json": "files"}) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == [".draft.tmp4000000", ".lighting.json.tmp4000003",
                                                           ".panolight-4000002", ".thesis.tmp4000001.docx"]
    assert (user / "notes.txt").read_text() == "mine"


def test_a_dead_runs_marked_staging_folder_and_its_record_temporaries_are_removed(tmp_path):
    pid = _dead_pid()
    stage = tmp_path / f".panolight-{pid}-abc"
    stage.mkdir()
    (stage / MARKER).write_text(json.dumps({"tool": "panolight", "pid": pid}))
    (stage / "hdr.exr").write_bytes(b"x" * 1000)
    (stage / f".hdr.exr.tmp{pid}.exr").write_bytes(b"x")
    (tmp_path / f"..panolight-files.json.tmp{pid}").write_text('{"files": {}}')  # atomic_path: .NAME.tmpPID
    (tmp_path / f".panolight-files.json.tmp{pid}").write_text('{"files": {}}')  # not a name atomic_path makes
    (tmp_path / "keep.txt").write_text("mine")
    removed = clean_stale(tmp_path, {".panolight-files.json": "files"})
    assert sorted(removed) == sorted([stage.name, f"..panolight-files.json.tmp{pid}"])
    assert sorted(p.name for p in tmp_path.iterdir()) == [f".panolight-files.json.tmp{pid}", "keep.txt"]


def test_a_marker_naming_another_pid_or_a_live_one_keeps_the_folder(tmp_path):
    import os

    for name, pid in ((f".panolight-{_dead_pid()}-x", 12345), (f".panolight-{os.getpid()}-y", os.getpid())):
        stage = tmp_path / name
        stage.mkdir()
        (stage / MARKER).write_text(json.dumps({"tool": "panolight", "pid": pid}))
    assert clean_stale(tmp_path) == [] and len(list(tmp_path.iterdir())) == 2


def test_a_staging_folder_with_a_users_subfolder_inside_is_kept(tmp_path):
    pid = _dead_pid()
    stage = tmp_path / f".panolight-{pid}"
    (stage / "sub").mkdir(parents=True)
    (stage / MARKER).write_text(json.dumps({"tool": "panolight", "pid": pid}))
    assert clean_stale(tmp_path) == [] and (stage / "sub").is_dir()


def test_make_stage_is_a_new_marked_folder(tmp_path):
    a, b = make_stage(tmp_path), make_stage(tmp_path)
    assert a != b and a.parent == tmp_path and json.loads((a / MARKER).read_text())["tool"] == "panolight"

"""The output folder's lock and small-file reads: nothing is ever written through a link, a FIFO or a
device named like PanoLight's own files."""
import os

import pytest

from panolight_core.errors import PanoLightError
from panolight_core.io.atomic import folder_lock, read_small_file


def test_a_symlinked_lock_is_refused_and_its_target_untouched(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "o"
    out.mkdir()
    (out / ".panolight.lock").symlink_to("../victim.txt")
    with pytest.raises(PanoLightError, match=r"\.panolight\.lock: is a symbolic link, not PanoLight's lock"):
        with folder_lock(out):
            pass
    assert victim.read_text() == "precious" and (out / ".panolight.lock").is_symlink()


def test_a_hard_linked_lock_is_refused_and_its_other_name_untouched(tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "o"
    out.mkdir()
    os.link(victim, out / ".panolight.lock")
    with pytest.raises(PanoLightError, match="a file with 2 names"):
        with folder_lock(out):
            pass
    assert victim.read_text() == "precious"


def test_a_fifo_lock_is_refused_in_one_line_naming_it(tmp_path):
    os.mkfifo(tmp_path / ".panolight.lock")
    with pytest.raises(PanoLightError, match=r"\.panolight\.lock: is a folder, FIFO, socket or device"):
        with folder_lock(tmp_path):
            pass


def test_the_lock_is_taken_and_released(tmp_path):
    with folder_lock(tmp_path) as lock:
        assert lock.path.read_text() == str(os.getpid())
        with pytest.raises(PanoLightError, match="another PanoLight process"):
            with folder_lock(tmp_path):
                pass
    assert not (tmp_path / ".panolight.lock").exists()


def test_a_lock_replaced_by_a_link_while_held_is_not_removed_on_release(tmp_path):
    target = tmp_path / "target.txt"
    target.write_text("keep")
    with folder_lock(tmp_path / "") as lock:
        lock.path.unlink()
        lock.path.symlink_to(target)
    assert lock.path.is_symlink() and target.read_text() == "keep"


def test_small_reads_refuse_links_fifos_and_large_files(tmp_path):
    (tmp_path / "ok.json").write_text("{}")
    assert read_small_file(tmp_path / "ok.json", 10) == "{}"
    assert read_small_file(tmp_path / "missing.json", 10) is None
    (tmp_path / "big.json").write_text("[" * 100)
    with pytest.raises(PanoLightError, match="big.json: is 100 bytes, more than PanoLight ever writes"):
        read_small_file(tmp_path / "big.json", 10)
    os.mkfifo(tmp_path / "fifo.json")  # opened without blocking: never a hang
    with pytest.raises(PanoLightError, match="fifo.json: is not a regular file"):
        read_small_file(tmp_path / "fifo.json", 10)
    (tmp_path / "link.json").symlink_to(tmp_path / "ok.json")
    with pytest.raises(PanoLightError, match="link.json: is a symbolic link"):
        read_small_file(tmp_path / "link.json", 10)

"""training.experiments.restore_previews: panolight estimate's previews of a clipped scene, as it is, restored and
true, stacked under their captions."""
import numpy as np

from panolight_core.data import load_studio_hdri
from training.experiments import restore_previews

from ..keylight.test_hidden_sun import _write_hdr


def test_three_strips_per_scene_stacked_under_their_captions(tmp_path, capsys):
    folder = tmp_path / "hdri"
    folder.mkdir()
    _write_hdr(folder, load_studio_hdri("city"))  # sky.exr: its sun clipped at +4 stops
    work = tmp_path / "work"
    work.mkdir()
    rows = restore_previews.strips(folder, "sky", 4.0, work)
    assert [c.split(": ", 1)[1] for c, _ in rows] == ["clipped at +4 stops, as it is (--restore none)",
                                                     "clipped at +4 stops, restored (default)", "the un-clipped truth"]
    assert all(img.dtype == np.uint8 and img.shape == rows[0][1].shape for _, img in rows)
    table = capsys.readouterr().out.splitlines()
    ratios = [float(line.split("|")[2]) for line in table]
    assert ratios[0] < 0.2 < 0.5 < ratios[1] and abs(ratios[2] - 1.0) < 0.05  # as it is: no sun; restored; the truth
    picture = restore_previews.sheet(rows)
    assert picture.shape == (3 * (restore_previews.CAPTION + rows[0][1].shape[0]), rows[0][1].shape[1], 3)

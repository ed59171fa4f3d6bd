"""sh.blobs: connected components on the equirect grid, joined across the seam and the poles."""
import numpy as np

from panolight_core.sh.blobs import component_at, label_blobs


def test_labels_join_across_seam_and_pole():
    m = np.zeros((6, 12), bool)
    m[3, 0] = m[3, 11] = True  # across u = 0
    m[0, 2] = m[0, 8] = True  # across the north pole (columns x and x + w/2)
    m[4, 5] = True  # alone
    labels, n = label_blobs(m)
    assert n == 3
    assert labels[3, 0] == labels[3, 11] and labels[0, 2] == labels[0, 8]
    assert len({labels[3, 0], labels[0, 2], labels[4, 5]}) == 3
    assert (labels[~m] == -1).all()


def test_component_at_is_label_blobs_component(rng):
    for trial in range(60):
        h = int(rng.integers(2, 24))
        w = 2 * h
        mask = rng.random((h, w)) < rng.uniform(0.2, 0.7)
        if trial % 3 == 0:  # regions touching the poles and the seam
            mask[0, :] |= rng.random(w) < 0.5
            mask[:, 0] |= rng.random(h) < 0.5
            mask[:, -1] |= rng.random(h) < 0.5
        labels, _ = label_blobs(mask)
        ys, xs = np.nonzero(mask)
        for k in rng.choice(len(ys), size=min(4, len(ys)), replace=False) if len(ys) else []:
            y, x = ys[k], xs[k]
            assert np.array_equal(component_at(mask, y, x), labels == labels[y, x]), (trial, y, x)
    assert not component_at(np.zeros((4, 8), bool), 1, 1).any()

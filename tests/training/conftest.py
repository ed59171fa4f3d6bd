import pytest


@pytest.fixture(scope="session")
def tiny_synth(tmp_path_factory):
    """Six Mitsuba samples at 64 x 32, 2 spp: enough to exercise data preparation and training."""
    from training.synth import store

    root = tmp_path_factory.mktemp("synth")
    store.synthesize(root, 6, height=32, spp=2)
    return root

"""io.ownership: a manifest PanoLight finds in a folder is outside data: fuzzed (hypothesis) with records of any
shape, it never raises but to refuse one too deep by name, and never makes a file PanoLight did not write its own."""
import json

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from panolight_core.errors import PanoLightError
from panolight_core.io import ownership

_json = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(min_value=-(2 ** 70), max_value=2 ** 70),
                               st.floats(allow_nan=False), st.text(max_size=70)),
                     lambda inner: st.one_of(st.lists(inner, max_size=3),
                                             st.dictionaries(st.sampled_from(["size", "sha256", "dev", "ino", "x"]),
                                                             inner, max_size=5)), max_leaves=25)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(entries=st.lists(_json, max_size=4), forge=st.booleans())
def test_a_manifest_of_any_shape_never_makes_a_users_file_ours(tmp_path, entries, forge):
    folder = tmp_path / "o"
    folder.mkdir(exist_ok=True)
    user = folder / "hdr.exr"
    user.write_text("mine")
    if forge:  # the user's file's own content digest, and the identity of another file
        other = ownership.written(tmp_path / "other") if (tmp_path / "other").write_text("x") else None
        entries = [*entries, {**ownership.digest(user), "dev": other["dev"], "ino": other["ino"]}]
    (folder / ownership.MANIFEST).write_text(json.dumps({"files": {"hdr.exr": entries}}))
    try:
        assert ownership.foreign(folder, ["hdr.exr"]) == ["hdr.exr"]
    except PanoLightError as exc:
        assert "nested too deeply" in str(exc)


def test_what_panolight_wrote_stays_its_own_and_a_rewrite_does_not(tmp_path):
    path = tmp_path / "lighting.json"
    path.write_text("{}")
    ownership.record(tmp_path, {"lighting.json": ownership.written(path)})
    assert not ownership.foreign(tmp_path, ["lighting.json"])
    other = tmp_path / "copy.json"
    other.write_text("{}")  # the same content, another file (made while the first exists: another inode) ...
    other.replace(path)  # ... put in its place
    assert ownership.foreign(tmp_path, ["lighting.json"]) == ["lighting.json"]

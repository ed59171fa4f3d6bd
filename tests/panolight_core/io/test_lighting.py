import json

import jsonschema
import numpy as np
import pytest

from panolight_core.errors import LightingFileError
from panolight_core.io.lighting import make_lighting, read_lighting, schema, validate, write_lighting

SUN = {"type": "sun", "direction": [0.0, 0.6, 0.8], "color": [1.0, 0.9, 0.8], "intensity": 5.0, "angle": 0.01}


def test_round_trip_and_schema_agree(tmp_path, rng):
    c = rng.normal(size=(16, 3))
    doc = make_lighting(c, lights=[SUN], source={"path": "x.exr"})
    jsonschema.validate(doc, schema())
    p = write_lighting(tmp_path / "lighting.json", doc)
    back, full = read_lighting(p)
    np.testing.assert_array_equal(back, c)
    assert full["lmax"] == 3 and full["lights"][0]["type"] == "sun"


BAD = [
    ({"lmax": 2}, "missing required key 'coefficients'"),
    ({"coefficients": [[0, 0, 0]] * 8}, r"\(lmax\+1\)\^2 = 9 rows"),
    ({"frame": "y-up"}, "'frame' must be"),
    ({"basis": "condon-shortley"}, "'basis' must be"),
    ({"lmax": -1}, "'lmax' must be an integer"),
    ({"coefficients": [[0, 0]] + [[0, 0, 0]] * 8}, "row 0 must be 3 finite numbers"),
    ({"lights": [dict(SUN, type="laser")]}, "type must be one of"),
    ({"lights": [dict(SUN, direction=[0, 0, 2])]}, "unit vector"),
    ({"lights": [dict(SUN, color=[-1, 0, 0])]}, "non-negative"),
    ({"lights": [dict(SUN, angle=4.0)]}, "angle"),
    ({"lights": [{"type": "sun"}]}, "missing 'direction'"),
]


@pytest.mark.parametrize("patch,message", BAD)
def test_invalid_documents_rejected_by_both_validators(tmp_path, patch, message):
    doc = make_lighting(np.zeros((9, 3)))
    doc.update(patch)
    for key in [k for k, v in patch.items() if v is None]:
        del doc[key]
    if "lmax" in patch and "coefficients" not in patch and patch["lmax"] == 2:
        del doc["coefficients"]
    p = tmp_path / "bad.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(LightingFileError, match=message) as e:
        read_lighting(p)
    assert str(p) in str(e.value)
    if "lmax" not in message.replace("'lmax'", "") and "unit vector" not in message:  # beyond JSON Schema
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate(doc, schema())


def test_not_json_and_missing(tmp_path):
    p = tmp_path / "l.json"
    p.write_text("{nope")
    with pytest.raises(LightingFileError, match="not valid JSON"):
        read_lighting(p)
    with pytest.raises(LightingFileError, match="not found"):
        read_lighting(tmp_path / "absent.json")
    p.write_text('{"coefficients": ' + "[" * 100000)  # trust round 4: a RecursionError traceback
    with pytest.raises(LightingFileError, match="l.json: nested deeper than 32 levels"):
        read_lighting(p)
    with pytest.raises(LightingFileError, match="finite"):
        validate({"lmax": 0, "coefficients": [[float("nan"), 0, 0]], "frame": "blender-world-z-up",
                  "basis": "real-orthonormal-no-condon-shortley"})


def test_area_lights_need_an_angle_and_source_must_be_an_object():
    import pytest

    from panolight_core.errors import PanoLightError
    from panolight_core.io.lighting import make_lighting, validate

    doc = make_lighting(np.zeros((1, 3)), lights=[{"type": "area", "direction": [0, 0, 1], "color": [1, 1, 1],
                                                   "intensity": 1.0, "angle": 0.2}])
    validate(doc)
    del doc["lights"][0]["angle"]
    with pytest.raises(PanoLightError, match="area light needs its angular diameter"):
        validate(doc, "x.json")
    doc = make_lighting(np.zeros((1, 3)))
    doc["source"] = "photo.jpg"
    with pytest.raises(PanoLightError, match="'source' must be an object"):
        validate(doc, "x.json")

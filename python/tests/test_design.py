"""Designs in memory: from a dict or TOML, replace with dotted paths, equality,
pickling, and the shipped designs inside the package."""

import pickle

import pytest

import fbgforge
from conftest import DESIGNS, MODULE


@pytest.mark.parametrize("name", sorted(p.stem for p in DESIGNS.glob("*.toml")))
def test_every_shipped_design_is_inside_the_package_and_equals_the_file(name):
    assert name in fbgforge.shipped_designs()
    shipped = fbgforge.shipped_design(name)
    from_file = fbgforge.load_design(DESIGNS / f"{name}.toml")
    assert shipped == from_file and shipped.name == name
    assert from_file.path == DESIGNS / f"{name}.toml"


def test_a_design_round_trips_through_a_dict_toml_and_pickle():
    d = fbgforge.load_design(MODULE)
    spec = d.to_dict()
    assert spec["name"] == d.name == "clip-on-34mm" and d.kind == "module"
    assert d.gratings == [g["name"] for g in spec["module"]["gratings"]]
    assert fbgforge.Design.from_dict(spec) == d
    assert fbgforge.Design.from_toml(d.to_toml()) == d
    back = pickle.loads(pickle.dumps(d))
    assert back == d and back.path == d.path and hash(back) == hash(d)
    assert "Design(name='clip-on-34mm'" in repr(d)
    array = fbgforge.shipped_design("tactile-array-60x80")
    assert array.kind == "array" and array.cells == list("ABCDEFGH") and array != d


def test_replace_edits_nested_fields_and_checks_the_result():
    d = fbgforge.load_design(MODULE)
    thin = d.replace({"module.cap_wall_mm": 1.2}, name="thin")
    assert thin.to_dict()["module"]["cap_wall_mm"] == 1.2 and thin.name == "thin"
    assert thin != d and thin.path is None and d.to_dict()["module"]["cap_wall_mm"] == 1.5
    # The edit reaches the model: a thinner cap raises |K| of Case II.
    k = lambda x: abs(fbgforge.predict(x, case="II", fidelity="closed-form").sensitivity_pm_per_n[0])
    assert k(thin) > k(d)
    # Lists are indexed by number.
    moved = d.replace(**{"module.gratings.0.center_height_mm": 14.0})
    assert moved.to_dict()["module"]["gratings"][0]["center_height_mm"] == 14.0
    # A value the checks refuse names the field, as a file would.
    with pytest.raises(fbgforge.DesignError) as e:
        d.replace({"module.cap_wall_mm": 30.0})
    assert e.value.field and "cap_wall_mm" in str(e.value) and isinstance(e.value, ValueError)
    with pytest.raises(fbgforge.DesignError, match="unknown field `colour`"):
        d.replace({"module.colour": "red"})
    with pytest.raises(KeyError, match="not an index"):
        d.replace({"module.gratings.x.center_height_mm": 1.0})


def test_an_in_memory_design_works_with_the_use_cases_that_read_files(synth_logs):
    d = fbgforge.load_design(MODULE).replace(name="renamed")
    r = fbgforge.verify(d, synth_logs / "log.txt", synth_logs / "force.csv")
    assert r.to_dict()["design"] == "renamed"

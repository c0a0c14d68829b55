"""The one schema (srs_ros/core/schema.py): fields, tables, the one error format, and every table that uses it."""

import copy
import re

import numpy as np
import pytest
import yaml

from srs_ros.backends import create_backend
from srs_ros.core.actuation.muscle_calibration import calibration_from_dict
from srs_ros.core.errors import ConfigurationError, InvalidInputError
from srs_ros.core.gait import library
from srs_ros.core.gait.fitting import FitSettings
from srs_ros.core.rig import rig_from_dict
from srs_ros.core.robot import config_dir, robot_from_dict
from srs_ros.core.schema import REQUIRED, Field, Table, read_csv_rows, refusal
from srs_ros.experiments.table import measured_table_from_dict
from srs_ros.sim.config import sim_config_from_dict

SEGMENTS = Field("segments_per_module", int, minimum=1, maximum=20, unit="segments")


# ------------------------------------------------------------------------------------------
# Fields: types, ranges, what is expected
# ------------------------------------------------------------------------------------------
def test_the_error_format_names_the_file_the_key_the_value_and_what_is_expected():
    with pytest.raises(ConfigurationError) as refused:
        SEGMENTS.check(-2, "config/sim.yaml", "sim.body.segments_per_module")
    assert str(refused.value) == ("config/sim.yaml: sim.body.segments_per_module is -2; "
                                  "expected an integer in [1, 20] (segments).")
    assert str(refusal("here", "a.b", "x", "y", InvalidInputError)) == "here: a.b is 'x'; expected y."
    assert isinstance(refusal("here", "a.b", "x", "y", InvalidInputError), InvalidInputError)


@pytest.mark.parametrize(("field", "accepted", "refused"), [
    (Field("n", int, minimum=1, maximum=20), [1, 20, np.int64(7)], [0, 21, 2.5, 3.0, True, "3", None]),
    (Field("x", float, minimum=0.0, maximum=1.0), [0, 1, 0.5, np.float32(0.25)], [-0.1, 1.1, float("nan"), True, "1"]),
    (Field("x", float, minimum=0.0, above_minimum=True), [1e-9, 1e9], [0.0, -1.0, float("inf")]),
    (Field("x", float), [-1e300, 0, 3], [float("inf"), float("-inf"), float("nan"), None, 10 ** 400, -(10 ** 400)]),
    (Field("b", bool), [True, False, np.bool_(True)], [1, 0, "true", None]),
    (Field("s", str), ["", "a"], [1, None, b"a"]),
    (Field("s", str, nonempty=True), ["a"], [""]),
    (Field("s", str, choices=("a", "b")), ["a", "b"], ["c", ""]),
    (Field("bgr", list, item=int, length=3, minimum=0, maximum=255), [[0, 1, 255], (1, 2, 3)],
     [[0, 1], [0, 1, 256], [0, 1, 2.0], "abc", 3, {"a": 1}]),
    (Field("names", list, item=str), [[], ["a"]], [[1], "a"]),
    (Field("m", dict), [{}, {"a": 1}], [[], "a"]),
    (Field("opt", int, None, minimum=0), [None, 0, 5], [-1, 1.5]),
])
def test_a_field_accepts_its_type_in_its_range_and_refuses_the_rest(field, accepted, refused):
    for value in accepted:
        assert field.reason(value) == "", value
    for value in refused:
        assert field.reason(value).startswith(f"{field.name} is "), value
        with pytest.raises(ConfigurationError):
            field.check(value, "test")


def test_a_csv_saved_by_a_spreadsheet_with_a_byte_order_mark_is_read(tmp_path):
    """Excel's "CSV UTF-8" begins with a BOM: the header was refused as '\\ufeffpressure_bar,...' (a review)."""
    table = Table("ruler", (Field("pressure_bar", float), Field("length_m", float)))
    path = tmp_path / "ruler.csv"
    path.write_bytes("pressure_bar,length_m\r\n1,0.01\r\n".encode("utf-8-sig"))
    assert read_csv_rows(path, table) == [{"pressure_bar": 1.0, "length_m": 0.01}]


def test_a_field_converts_to_its_type():
    assert SEGMENTS.check(np.int64(3), "test") == 3 and type(SEGMENTS.check(np.int64(3), "test")) is int
    assert Field("x", float).check(2, "test") == 2.0 and type(Field("x", float).check(2, "test")) is float
    assert Field("bgr", list, item=int).check([1, 2], "test") == (1, 2)
    assert Field("b", bool).check(np.bool_(True), "test") is True


@pytest.mark.parametrize(("field", "expected"), [
    (SEGMENTS, "an integer in [1, 20] (segments)"),
    (Field("p", float, minimum=0.0, maximum=4.0, above_minimum=True, unit="bar"), "a number in (0, 4] (bar)"),
    (Field("p", float, minimum=0.0, above_minimum=True), "a number > 0"),
    (Field("p", float, minimum=0.5), "a number >= 0.5"),
    (Field("p", float, maximum=1e-05), "a number <= 1e-05"),
    (Field("p", float), "a number (finite)"),
    (Field("b", bool), "true or false"),
    (Field("s", str, choices=("a", "b")), "one of ['a', 'b']"),
    (Field("l", list, item=int, length=3, minimum=0, maximum=255), "a list of 3 integers in [0, 255]"),
    (Field("r", float, minimum=1.0, maximum=1000.0, example="200.0"), "a number in [1, 1000], e.g. 200.0"),
    (Field("c", object, expected_text="a channel name or number"), "a channel name or number"),
])
def test_what_is_expected_is_said_once_from_the_type_range_and_unit(field, expected):
    assert field.expected == expected


# ------------------------------------------------------------------------------------------
# Tables: unknown keys, missing keys, defaults
# ------------------------------------------------------------------------------------------
TABLE = Table("sim.body", (SEGMENTS, Field("skin_radius_m", float, 0.02, 0.002, 0.2, "m"),
                           Field("marker", str, None)))


def test_a_table_fills_defaults_and_converts():
    assert TABLE.read({"segments_per_module": 4}, "f.yaml") == {"segments_per_module": 4, "skin_radius_m": 0.02,
                                                               "marker": None}
    assert TABLE.defaults == {"skin_radius_m": 0.02, "marker": None} and TABLE.names[0] == "segments_per_module"
    assert TABLE.with_defaults(skin_radius_m=0.03).read({"segments_per_module": 4}, "f")["skin_radius_m"] == 0.03


@pytest.mark.parametrize(("data", "message"), [
    ({"segments_per_module": 4, "segmnets": 5},
     "f.yaml: sim.body.segmnets is not a known key; expected one of [marker, segments_per_module, skin_radius_m]."),
    ({}, "f.yaml: sim.body.segments_per_module is missing; expected an integer in [1, 20] (segments)."),
    ({"segments_per_module": 4, "skin_radius_m": 1}, "f.yaml: sim.body.skin_radius_m is 1; expected a number in "
                                                      "[0.002, 0.2] (m)."),
    ([1, 2], "f.yaml: sim.body is [1, 2]; expected a mapping with keys"),
])
def test_a_table_refuses_unknown_and_missing_keys_and_bad_values_in_the_one_format(data, message):
    with pytest.raises(ConfigurationError) as refused:
        TABLE.read(data, "f.yaml")
    assert str(refused.value).startswith(message), str(refused.value)


def test_keys_the_caller_handles_itself_are_not_refused_nor_returned():
    assert "own" not in TABLE.read({"segments_per_module": 1, "own": 3}, "f", extra=("own",))


def test_a_table_moves_to_another_place_in_a_file():
    with pytest.raises(ConfigurationError, match=r"^f: per_muscle.m1_pma1.segments_per_module is 0;"):
        TABLE.at("per_muscle.m1_pma1").read({"segments_per_module": 0}, "f")


def test_a_required_field_has_no_default_and_a_table_names_each_field_once():
    assert SEGMENTS.required and SEGMENTS.default is REQUIRED and not TABLE["marker"].required
    with pytest.raises(ValueError, match="twice"):
        Table("t", (SEGMENTS, SEGMENTS))


# ------------------------------------------------------------------------------------------
# Every table of the package refuses an unknown key and a bad value in the one format
# ------------------------------------------------------------------------------------------
def _yaml(name):
    return yaml.safe_load((config_dir() / name).read_text())


def _gaits_file(tmp_path, change):
    data = copy.deepcopy(_yaml("gaits.yaml"))
    change(data)
    path = tmp_path / "gaits.yaml"
    path.write_text(yaml.safe_dump(data))
    library._load_config.cache_clear()
    return path


def _paper_table():
    return _yaml("paper_table1.yaml")


def _calibration():
    muscle = {"deadzone_bar": 1.0, "extension_per_bar_m": 0.02, "saturation_bar": 4.0}
    return {"muscle_calibration": {"muscles": {f"m{i}_pma{j}": dict(muscle) for i in (1, 2, 3) for j in (1, 2, 3)}}}


def _set(data, path, value):
    *parents, last = path
    for key in parents:
        data = data[key]
    data[last] = value


#: (what, a valid document, its loader, the place of a key) for every file format with a table.
FILES = {
    "robot": (lambda: _yaml("robot.yaml"), lambda d: robot_from_dict(d, "f.yaml"), ("robot",)),
    "actuation": (lambda: _yaml("robot.yaml"), lambda d: robot_from_dict(d, "f.yaml"), ("actuation",)),
    "regulator": (lambda: _yaml("robot.yaml"), lambda d: robot_from_dict(d, "f.yaml"),
                  ("regulator_models", "ITV3050")),
    "rig": (lambda: _yaml("rigs/mock.yaml"), lambda d: rig_from_dict(d, source="f.yaml"), ("rig",)),
    "sim": (lambda: _yaml("sim.yaml"), lambda d: sim_config_from_dict(d, source="f.yaml"), ("sim", "physics")),
    "sim muscles": (lambda: _yaml("sim.yaml"), lambda d: sim_config_from_dict(d, source="f.yaml"),
                    ("sim", "muscles")),
    "measured table": (_paper_table, lambda d: measured_table_from_dict(d, "f.yaml"), ("measured_table",)),
    "calibration": (_calibration, lambda d: calibration_from_dict(d, source="f.yaml"),
                    ("muscle_calibration", "muscles", "m1_pma1")),
    "fitting": (lambda: {"fitting": {}}, lambda d: FitSettings.from_config(d["fitting"], "f.yaml"), ("fitting",)),
}


@pytest.mark.parametrize("what", FILES)
def test_every_file_refuses_an_unknown_key_in_the_one_format(what):
    make, load, place = FILES[what]
    data = make()
    load(copy.deepcopy(data))  # the document itself is valid
    _set(data, (*place, "no_such_key"), 1)
    with pytest.raises(ConfigurationError) as refused:
        load(data)
    assert re.match(rf"f\.yaml: {re.escape('.'.join(place))}\.no_such_key is not a known key; expected one of \[",
                    str(refused.value)), str(refused.value)


@pytest.mark.parametrize(("what", "key", "value"), [
    ("robot", "mass_kg", -1.0), ("actuation", "max_pressure_bar", 4.5), ("regulator", "command_full_scale_v", "10"),
    ("rig", "command_rate_hz", 0.5), ("sim", "solver_iterations", 0), ("sim muscles", "transport_delay_s", 3.0),
    ("measured table", "duration_s", -15), ("calibration", "saturation_bar", 101.0), ("fitting", "seed", -7),
])
def test_every_file_refuses_a_bad_value_in_the_one_format(what, key, value):
    make, load, place = FILES[what]
    data = make()
    _set(data, (*place, key), value)
    with pytest.raises(ConfigurationError) as refused:
        load(data)
    assert str(refused.value).startswith(f"f.yaml: {'.'.join((*place, key))} is {value!r}; expected "), \
        str(refused.value)


def test_a_gait_parameter_block_and_a_gait_value_are_checked_by_the_schema(tmp_path):
    path = _gaits_file(tmp_path, lambda d: d["gaits"]["serpentine"]["parameters"]["a_rad"].update(units="rad"))
    with pytest.raises(ConfigurationError, match=rf"^{re.escape(str(path))}: gaits.serpentine.parameters.a_rad.units "
                                                 r"is not a known key"):
        library.list_gaits(path)
    path = _gaits_file(tmp_path, lambda d: d["gaits"]["serpentine"]["parameters"]["a_rad"].update(default=9.0))
    with pytest.raises(ConfigurationError, match=r"gaits.serpentine.parameters.a_rad.default is 9.0; expected a "
                                                 r"number in \[-1.5, 1.5\] \(rad\)"):
        library.list_gaits(path)
    library._load_config.cache_clear()
    with pytest.raises(InvalidInputError, match=r"^gait parameters: serpentine.a_rad is 2.0; expected a number in "):
        library.gait_spec("serpentine").resolve({"a_rad": 2.0})


@pytest.mark.parametrize(("backend", "key", "value"), [
    ("mock", "transport_delay_s", -1.0), ("mock", "fail_after_writes", -2), ("sim", "readback_timeout_s", 9.0),
    ("can", "board_timeout_s", 9.0), ("daq", "require_watchdog", "yes"),
])
def test_every_backend_refuses_a_bad_option_and_an_unknown_one_in_the_one_format(backend, key, value):
    base = {"interface": "virtual", "channel": "x"} if backend == "can" else {}
    with pytest.raises(ConfigurationError) as refused:
        create_backend(backend, options={**base, key: value})
    assert str(refused.value).startswith(f"{backend} backend_options: {key} is {value!r}; expected "), \
        str(refused.value)
    with pytest.raises(ConfigurationError) as refused:
        create_backend(backend, options={**base, "no_such_option": 1})
    assert str(refused.value).startswith(f"{backend} backend_options: no_such_option is not a known key; "
                                         "expected one of ["), str(refused.value)


def test_node_parameters_are_checked_by_the_schema():
    from srs_ros.ros.parameters import ParameterSpec

    rate = ParameterSpec("rate_hz", 200.0, "setpoint rate, Hz", 10.0, 1000.0)
    assert rate.field == Field("rate_hz", float, 200.0, 10.0, 1000.0, description="setpoint rate, Hz",
                               example="200.0")
    assert rate.check(500) == "" and rate.check(500.0) == ""
    assert rate.check(5.0) == "rate_hz is 5.0; expected a number in [10, 1000], e.g. 200.0; setpoint rate, Hz."
    assert rate.check(True).startswith("rate_hz is True;")
    cycles = ParameterSpec("cycles", 0, "cycles", 0, 10)
    assert cycles.check(2.0).startswith("cycles is 2.0; expected an integer in [0, 10]")
    hsv = ParameterSpec("hsv", [1, 2, 3], "bounds")
    assert hsv.check([4, 5, 6]) == "" and hsv.check(["a"]).startswith("hsv is ['a']; expected a list of integers")
    gait = ParameterSpec.from_field(Field("gait", str, "a", choices=("a", "b"), description="gait"))
    assert gait.check("c") == "gait is 'c'; expected one of ['a', 'b']; gait."
    assert gait.additional_constraints == "one of ['a', 'b']"


#: The files that hold one top-level block: a section written beside it instead of under it is refused.
SINGLE_BLOCK_FILES = ("sim", "measured table", "calibration")


@pytest.mark.parametrize("what", SINGLE_BLOCK_FILES)
def test_a_section_written_at_the_top_instead_of_under_the_files_block_is_refused_not_ignored(what):
    make, load, place = FILES[what]
    data = make()
    data["muscles"] = {"max_pressure_rate_bar_per_s": 5.0}  # meant to be indented under the block
    with pytest.raises(ConfigurationError) as refused:
        load(data)
    block = place[0]  # muscles is a section of sim: and of muscle_calibration:, not of measured_table:
    known = f"'muscles' belongs to the {block} block: indent it under {block}:" if what != "measured table" else \
        f"move it under {block}: if it belongs there, or remove it"
    assert str(refused.value) == (f"f.yaml: the top-level key 'muscles' is not known; expected only {place[0]}: at "
                                  f"the top ({known}).")

"""Output paths are checked before the work: a run (or real air) is never lost to a path unwritable at the end."""

import pytest

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.robot import config_dir
from srs_ros.tools import identify, sim_cli, turning_cli
from srs_ros.tools.output import prepare_output, prepare_output_file


def test_a_folder_or_an_unwritable_place_is_refused_and_a_new_folder_is_made(tmp_path):
    assert prepare_output_file(None, "--plot") is None
    assert prepare_output_file(tmp_path / "new" / "run.csv", "--out") == tmp_path / "new" / "run.csv"
    assert (tmp_path / "new").is_dir()
    with pytest.raises(ConfigurationError, match=r"--out .*: is a folder; expected a file path in it"):
        prepare_output_file(tmp_path, "--out")
    with pytest.raises(ConfigurationError, match=r"--plot /proc/x.png: cannot write there"):
        prepare_output_file("/proc/x.png", "--plot")
    with pytest.raises(ConfigurationError, match=r"--out /proc/srs: cannot write there"):
        prepare_output("/proc/srs")


def test_srs_identify_refuses_an_unwritable_out_before_any_air(capsys):
    """It ran the whole identification (real air on a real rig), then failed to write (a helper's review)."""
    code = identify.main(["--rig", str(config_dir() / "rigs" / "mock.yaml"), "--out", "/proc/x.yaml"])
    captured = capsys.readouterr()
    assert code == 2 and "--out /proc/x.yaml: cannot write there" in captured.err
    assert "step" not in captured.out  # refused before the plan started


@pytest.mark.parametrize(("main", "args"), [
    (turning_cli.main, ["--write-map", "/proc/map.yaml"]),
    (sim_cli.main, ["--gait", "inward_rolling", "--amplitude-bar", "3", "--frequency-hz", "1", "--duration-s", "30",
                    "--out", "/proc/run.csv"]),
])
def test_the_simulation_tools_refuse_an_unwritable_output_before_they_run(main, args, capsys):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "/proc/" in err and "cannot write there" in err

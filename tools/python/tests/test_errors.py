"""Bad input raises the documented exceptions with the CLI's messages; no panic."""

import json
import subprocess

import numpy as np
import pytest

import lobe
from conftest import MODELS


def cli_error(lobe_bin, args):
    p = subprocess.run([lobe_bin] + args, capture_output=True, text=True)
    assert p.returncode != 0
    return p.stderr.strip().removeprefix("lobe: error: ")


def test_bad_parameter_is_value_error_with_cli_message(lobe_bin):
    desc = {"type": "ward", "alpha": -1}
    with pytest.raises(ValueError) as e:
        lobe.Material(desc)
    cli = cli_error(lobe_bin, ["eval", "--material", json.dumps(desc), "--grid", "0,0,0,0"])
    assert str(e.value).split(": ", 1)[1] == cli.split(": ", 1)[1]
    with pytest.raises(ValueError, match="unknown|expected"):
        lobe.Material({"type": "no-such-model"})
    with pytest.raises(ValueError):
        lobe.Material("{not json")


def test_missing_files_are_file_not_found(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.bsdf"):
        lobe.Material({"type": "rgl", "file": str(tmp_path / "nope.bsdf")})
    for f in (lobe.read_merl, lobe.read_binned, lobe.read_rgl, lobe.read_fit_report, lobe.read_image):
        with pytest.raises(FileNotFoundError):
            f(tmp_path / "missing")
    with pytest.raises(FileNotFoundError):
        lobe.fit(tmp_path / "missing.binary", progress=False)
    with pytest.raises(FileNotFoundError):
        lobe.render(tmp_path / "missing.json")


def test_malformed_files_are_value_errors(tmp_path, lobe_bin):
    bad = tmp_path / "bad.binary"
    bad.write_bytes(b"\x5a\x00\x00\x00" * 3 + b"\x00" * 100)
    with pytest.raises(ValueError) as e:
        lobe.read_merl(bad)
    cli = cli_error(lobe_bin, ["eval", "--material", json.dumps({"type": "merl", "file": str(bad)}), "--grid", "0,0,0,0"])
    assert "dimensions [90, 90, 90]" in str(e.value) and cli.endswith(str(e.value))
    with pytest.raises(ValueError):
        lobe.read_binned(bad)
    with pytest.raises(ValueError, match="shape"):
        lobe.write_merl(tmp_path / "x.binary", np.zeros((3, 3)))
    assert not (tmp_path / "x.binary").exists()


def test_bad_arrays_and_options_are_value_errors():
    m = lobe.Material(MODELS["ward"])
    with pytest.raises(ValueError, match=r"wo: expected an array of shape \(N, 3\)"):
        m.eval(np.zeros((4, 2)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="rows"):
        m.eval(np.zeros((4, 3)), np.zeros((5, 3)))
    with pytest.raises(ValueError, match="uc"):
        m.sample(np.zeros((4, 3)), np.zeros((4, 2)), np.zeros(3))
    with pytest.raises(ValueError, match="theta_o"):
        m.albedo(95.0)
    with pytest.raises(ValueError, match="metric"):
        lobe.fit(m, metric="l2", progress=False)
    with pytest.raises(ValueError, match="envs: only for metric='image'"):
        lobe.fit(m, metric="log", envs=["builtin:studio"], progress=False)
    with pytest.raises(ValueError, match="resolution"):
        lobe.fit(m, resolution=0.0, progress=False)
    with pytest.raises(ValueError, match="models|model"):
        lobe.fit(m, models="no-such", progress=False)
    with pytest.raises(ValueError, match="spp"):
        lobe.render({"shapes": []}, spp=0)
    with pytest.raises(ValueError, match="shape"):
        lobe.compare(np.zeros((4, 4)), np.zeros((4, 4, 3)))
    with pytest.raises(ValueError, match="finite|NaN|non-finite"):
        lobe.compare(np.full((4, 4, 3), np.nan, dtype=np.float32), np.zeros((4, 4, 3)))


def test_a_study_budget_out_of_range_is_a_value_error_as_in_the_cli(tmp_path, lobe_bin):
    with pytest.raises(ValueError, match="--error-spp: expected a mean of 32 to 16384") as e:
        lobe.study([], tmp_path / "s", quick=True, envs=["builtin:studio"], progress=False, error_spp=16)
    cli = cli_error(lobe_bin, ["study", "--quick", "--error-spp", "16", "-o", str(tmp_path / "c")])
    assert cli.endswith(str(e.value))
    with pytest.raises(ValueError, match="error_spp"):
        lobe.study([], tmp_path / "s", quick=True, progress=False, error_spp=-1)
    assert not (tmp_path / "s").exists() and not (tmp_path / "c").exists()

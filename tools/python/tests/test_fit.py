"""lobe.fit against `lobe fit`: the same report (timings aside)."""

import copy
import json

import lobe
from conftest import MODELS, run


def strip_times(r):
    r = copy.deepcopy(r)
    for m in r["models"].values():
        m.pop("seconds")
    return r


def test_fit_equals_cli_report(lobe_bin, tmp_path):
    table = tmp_path / "lafortune.binary"
    run([lobe_bin, "tabulate", "--material", json.dumps(MODELS["cook-torrance"]), "--retro-exclusion", "3", "-o", str(table)])
    out = tmp_path / "cli.fit.json"
    run([lobe_bin, "fit", str(table), "--models", "ward,cook-torrance", "--resolution", "4", "--max-evals", "60", "-o", str(out)])
    cli = json.loads(out.read_text())
    r = lobe.fit(table, models=["ward", "cook-torrance"], resolution=4, max_evals=60, progress=False)
    assert isinstance(r, lobe.FitReport) and isinstance(r.models["ward"], lobe.ModelFit)
    assert strip_times(r.to_json()) == strip_times(cli)
    assert r.models["cook-torrance"].error_normalized < r.models["ward"].error_normalized
    # The report saves as lobe writes it and loads back.
    r.save(tmp_path / "py.fit.json")
    assert strip_times(lobe.read_fit_report(tmp_path / "py.fit.json").to_json()) == strip_times(cli)
    m = lobe.Material({"type": "fit", "file": str(out), "model": "cook-torrance"})
    assert m.name == "cook-torrance"


def test_fit_of_a_material_equals_cli(lobe_bin, tmp_path):
    out = tmp_path / "cli.fit.json"
    desc = MODELS["blinn-phong"]
    run([lobe_bin, "fit", "--material", json.dumps(desc), "--models", "blinn-phong", "--resolution", "5", "--max-evals", "40", "-o", str(out)])
    r = lobe.fit(lobe.Material(desc), models="blinn-phong", resolution=5, max_evals=40, progress=False)
    assert strip_times(r.to_json()) == strip_times(json.loads(out.read_text()))


def test_fit_metrics_equal_cli_and_keep_the_eq1_error(lobe_bin, tmp_path):
    desc = MODELS["cook-torrance"]
    reports = {}
    for metric, envs in (("eq1", ()), ("log", ()), ("image", ("builtin:studio",))):
        out = tmp_path / f"{metric}.fit.json"
        env_args = [a for e in envs for a in ("--env", e)]
        run([lobe_bin, "fit", "--material", json.dumps(desc), "--models", "ward", "--resolution", "10", "--max-evals", "40", "--metric", metric, *env_args, "-o", str(out)])
        r = lobe.fit(lobe.Material(desc), models="ward", metric=metric, envs=envs, resolution=10, max_evals=40, progress=False)
        assert strip_times(r.to_json()) == strip_times(json.loads(out.read_text()))
        assert r.metric == metric
        reports[metric] = r.models["ward"]
    # "ngan2005" is Eq. 1 by its old name.
    old = lobe.fit(lobe.Material(desc), models="ward", metric="ngan2005", resolution=10, max_evals=40, progress=False)
    assert old.metric == "eq1" and old.models["ward"].error == reports["eq1"].error
    assert reports["eq1"].metric_error is None
    for metric in ("log", "image"):
        # Each fit's error is its Eq. 1 error: never below the Eq. 1 fit's.
        assert reports[metric].error > reports["eq1"].error
        assert reports[metric].metric_error > 0.0


def test_a_report_without_a_metric_reads_as_eq1(lobe_bin, tmp_path):
    out = tmp_path / "r.fit.json"
    run([lobe_bin, "fit", "--material", json.dumps(MODELS["ward"]), "--models", "ward", "--resolution", "10", "--max-evals", "20", "-o", str(out)])
    v = json.loads(out.read_text())
    del v["metric"]
    v["format_version"] = 2
    out.write_text(json.dumps(v))
    r = lobe.read_fit_report(out)
    assert r.metric == "eq1" and r.models["ward"].metric_error is None

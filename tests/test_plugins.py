"""Effects, predictors and dialects from outside the package (issue 26).

The plugin files live in tests/plugins/user_*.py. ``user_wrist_cable`` was written by
``postproc effect new`` and edited (its texts and one line of physics); its effect is not
in the catalog. Each way of loading is tested: ``--plugins`` / a path, ``POSTPROC_PLUGINS``
and an entry point of an installed distribution (a dist-info folder on sys.path).
"""

from __future__ import annotations

import difflib
import json
import os
import pickle
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from postproc.cli import app
from postproc.errors import ModelFileError
from postproc.model import effects as effect_catalog
from postproc.model import predictor_plugins as predictors
from postproc.model.effect_check import check_effect
from postproc.model.effect_template import write_template
from postproc.model.effects import CATALOG, parse_effects
from postproc.model.identify import Stats, fit, fit_predictor, residuals
from postproc.model.measurements import write_measurements
from postproc.model.model_io import load_model, model_document, model_from_document, save_model
from postproc.model.sim import parse_region, random_truth, sample_poses, simulate
from postproc.plugins import ENV, PluginError, load_plugins, loaded_plugin_files, plugin_arguments
from postproc.programs import dialects
from postproc.robot.robots import load_robot

PLUGINS = Path(__file__).parent / "plugins"
EFFECT_FILE = PLUGINS / "user_wrist_cable.py"
PREDICTOR_FILE = PLUGINS / "user_mean_predictor.py"
DIALECT_FILE = PLUGINS / "user_krl_alias.py"
BROKEN_FILE = PLUGINS / "user_broken.py"
ROBOT = "irb6660_205_190"  # the robot the bundled examples/data programs are placed for
# The measured region around block_pass's targets (radius 1365..1371 mm, z 1270..1320 mm in the
# robot's base frame): compensate refuses targets outside the region a model was measured in.
PROGRAM_REGION = "theta1=-30:30;radius=1150:1450;z=1150:1450"
KUKA = "kr160_r1570"  # a KRL program streamed in chunks is for a KUKA robot (compensate refuses another maker's model)
TOOL = np.array([0.0, 0.0, 250.0])  # the bundled examples/data programs' tool
NOISE_MM = 0.02  # per axis: the 3-D noise floor is NOISE_MM * sqrt(3)
REPO = Path(__file__).resolve().parents[1]
KRL = REPO / "examples/data/block_pass.src"  # a KRL program placed for ROBOT: compensated for it as RAPID (rapid_program)
runner = CliRunner()


@pytest.fixture(autouse=True)
def builtins_only(monkeypatch):
    """Each test starts from the built-ins and leaves them so: the name tables are module-level."""
    tables = (CATALOG, dialects.REGISTRY, predictors.PREDICTORS)
    saved = [dict(t) for t in tables]
    monkeypatch.delenv(ENV, raising=False)
    for table, copy in zip(tables, saved):
        table.clear()
        table.update({k: v for k, v in copy.items() if k in _builtin_names(table)})
    yield
    for table, copy in zip(tables, saved):
        table.clear()
        table.update(copy)


def _builtin_names(table) -> frozenset:
    return {id(CATALOG): effect_catalog.BUILTIN, id(dialects.REGISTRY): dialects.BUILTIN, id(predictors.PREDICTORS): frozenset()}[id(table)]


def _installed(tmp_path: Path, group: str, name: str, source: Path) -> Path:
    """A distribution 'userplugins' installed into tmp_path: the module, and a dist-info whose
    entry point in ``group`` names it."""
    site = tmp_path / "site"
    site.mkdir(exist_ok=True)
    module = f"userplugins_{source.stem}"
    shutil.copy(source, site / f"{module}.py")
    info = site / "userplugins-0.1.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: userplugins\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[{group}]\n{name} = {module}\n")
    return site


def _load(way: str, source: Path, group: str, tmp_path: Path, monkeypatch) -> None:
    if way == "path":
        load_plugins([source], environ={})
    elif way == "environment":
        monkeypatch.setenv(ENV, os.pathsep.join(["", str(source)]))  # an empty item is skipped
        load_plugins()
    else:
        monkeypatch.syspath_prepend(str(_installed(tmp_path, group, "user", source)))
        load_plugins(environ={})


def _simulated(spec: str, n: int, seed: int, robot: str = ROBOT, region: str | None = None):
    """A simulated set (in the cylinder ``region``; None: seed 001's); the user effect's true coefficient is set (0.6 deg/rad)."""
    robot = load_robot(robot)
    rng = np.random.default_rng(seed)
    truth = random_truth(robot, TOOL, parse_effects(spec), rng)
    if "user_wrist_cable" in spec:
        truth = truth.with_values({"user_wrist_cable.k4": 0.6})
    q = sample_poses(robot, TOOL, n, parse_region("cylinder", region), rng)
    return robot, truth, simulate(truth, q, rng, noise_mm=NOISE_MM)


# ------------------------------------------------------------------ contract


def test_template_is_a_working_effect_but_asks_for_its_texts(tmp_path):
    path = write_template("my_effect", tmp_path)
    records = load_plugins([path], environ={})
    assert [r.name for r in records] == ["my_effect"]
    checks = {c.name: c for c in check_effect(CATALOG["my_effect"])}
    assert not checks["texts"].ok and "EDIT" in checks["texts"].detail
    assert all(c.ok for name, c in checks.items() if name != "texts")


def test_the_user_effect_is_the_template_with_a_few_lines_edited(tmp_path):
    """tests/plugins/user_wrist_cable.py stays what `effect new` writes, edited: if the
    template changes, regenerate it (and docs/own-effect.md's diff)."""
    fresh = write_template("user_wrist_cable", tmp_path).read_text().splitlines()
    mine = EFFECT_FILE.read_text().splitlines()
    changed = [line for line in difflib.unified_diff(fresh, mine, lineterm="", n=0) if line[:1] in "+-" and line[:3] not in ("+++", "---")]
    assert 0 < len(changed) <= 16, changed


def test_effect_new_refuses_to_overwrite_and_bad_names(tmp_path):
    assert runner.invoke(app, ["effect", "new", "wrist_cable", "-o", str(tmp_path)]).exit_code == 0
    before = (tmp_path / "wrist_cable.py").read_text()
    again = runner.invoke(app, ["effect", "new", "wrist_cable", "-o", str(tmp_path)])
    assert again.exit_code == 2 and "already exists" in again.stderr
    assert (tmp_path / "wrist_cable.py").read_text() == before
    for bad in ("geometric", "Wrist", "2x"):
        assert runner.invoke(app, ["effect", "new", bad, "-o", str(tmp_path)]).exit_code == 2
    named = runner.invoke(app, ["effect", "new", "cable", "-o", str(tmp_path / "my_cable.py")])  # spec/cli.md: -o FILE.py
    assert named.exit_code == 0 and 'name = "cable"' in (tmp_path / "my_cable.py").read_text()
    assert runner.invoke(app, ["effect", "new", "cable", "-o", str(tmp_path / "no" / "x.py")]).exit_code == 2


def test_effect_check_passes_the_user_effect_and_lists_failures():
    good = runner.invoke(app, ["effect", "check", str(EFFECT_FILE)])
    assert good.exit_code == 0, good.stderr
    assert "analytic Jacobian" in good.stdout and "FAILED" not in good.stdout
    bad = runner.invoke(app, ["effect", "check", str(BROKEN_FILE)])
    assert bad.exit_code == 2
    assert "texts: missing: identifiability" in bad.stderr
    assert "analytic Jacobian = finite differences" in bad.stderr and "user_broken.grow" in bad.stderr


# ------------------------------------------------------------------ loading


@pytest.mark.parametrize("way", ["path", "environment", "entry point"])
def test_user_effect_loaded_each_way_brings_validation_rms_to_the_noise_floor(way, tmp_path, monkeypatch):
    _load(way, EFFECT_FILE, "postproc.effects", tmp_path, monkeypatch)
    assert "user_wrist_cable" in CATALOG
    robot, _, data = _simulated("geometric,user_wrist_cable", 220, seed=3)
    train, held_out = data.subset(np.arange(140)), data.subset(np.arange(140, 220))
    floor = NOISE_MM * np.sqrt(3)
    catalog_only = fit(robot, TOOL, parse_effects("geometric"), train, cv_folds=0)
    with_user = fit(robot, TOOL, parse_effects("geometric,user_wrist_cable"), train, cv_folds=0)
    rms_catalog = Stats.of(residuals(catalog_only.model, held_out)).rms_mm
    rms_user = Stats.of(residuals(with_user.model, held_out)).rms_mm
    assert rms_catalog > 2 * floor  # the catalog cannot explain it
    assert rms_user < 1.15 * floor, (rms_user, floor)


def test_folder_and_idempotent_loading(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    shutil.copy(EFFECT_FILE, folder)
    shutil.copy(PREDICTOR_FILE, folder)
    first = load_plugins([folder], environ={})
    assert sorted(r.name for r in first) == ["user_plane", "user_wrist_cable"]
    cls = CATALOG["user_wrist_cable"]
    load_plugins([folder, folder / EFFECT_FILE.name], environ={})
    assert CATALOG["user_wrist_cable"] is cls  # the same file again is a no-op
    assert loaded_plugin_files() == sorted(str((folder / f).resolve()) for f in (EFFECT_FILE.name, PREDICTOR_FILE.name))


def test_plugin_arguments_repeat_the_loaded_files_for_suggested_commands(tmp_path):
    assert plugin_arguments() == ""
    spaced = tmp_path / "my plugins"
    spaced.mkdir()
    shutil.copy(EFFECT_FILE, spaced)
    load_plugins([spaced / EFFECT_FILE.name, PREDICTOR_FILE], environ={})
    arguments = plugin_arguments()
    assert f"'{(spaced / EFFECT_FILE.name).resolve()}'" in arguments  # quoted for the shell
    words = shlex.split(arguments)
    assert words[::2] == ["--plugins"] * 2 and sorted(words[1::2]) == sorted(str(f.resolve()) for f in (spaced / EFFECT_FILE.name, PREDICTOR_FILE))


def test_bad_plugins_are_input_errors(tmp_path):
    (tmp_path / "syntax.py").write_text("def broken(:\n")
    (tmp_path / "empty.py").write_text("X = 1\n")
    (tmp_path / "clash.py").write_text(EFFECT_FILE.read_text().replace('name = "user_wrist_cable"', 'name = "geometric"'))
    with pytest.raises(PluginError, match=r"syntax.py, line 1"):
        load_plugins([tmp_path / "syntax.py"], environ={})
    with pytest.raises(PluginError, match="defines no Effect"):
        load_plugins([tmp_path / "empty.py"], environ={})
    with pytest.raises(PluginError, match="built-in effect's name"):
        load_plugins([tmp_path / "clash.py"], environ={})
    with pytest.raises(PluginError, match="no such file"):
        load_plugins([tmp_path / "absent.py"], environ={})
    bad = runner.invoke(app, ["evaluate", "m.json", "d.csv", "--plugins", str(tmp_path / "absent.py")])
    assert bad.exit_code == 2 and "absent.py: no such file or folder" in bad.stderr


# ------------------------------------------------------------- model files


def _user_model(path: Path, robot: str, region: str | None) -> Path:
    """A model with the user effect, fitted and saved; the plugin then unloaded."""
    load_plugins([EFFECT_FILE], environ={})
    fitted_robot, _, data = _simulated("geometric,user_wrist_cable", 120, seed=4, robot=robot, region=region)
    result = fit(fitted_robot, TOOL, parse_effects("geometric,user_wrist_cable"), data, cv_folds=0)
    save_model(path, result.model, result)
    del CATALOG["user_wrist_cable"]
    return path


@pytest.fixture
def user_model(tmp_path):
    """The IRB6660 measured around block_pass's targets."""
    return _user_model(tmp_path / "model.json", ROBOT, PROGRAM_REGION)


@pytest.fixture
def rapid_program(tmp_path):
    """block_pass.src written in RAPID, the language of the ABB robot the model is for."""
    path = tmp_path / "block_pass.mod"
    res = runner.invoke(app, ["convert", str(KRL), "--to", "rapid", "-o", str(path)])
    assert res.exit_code == 0, res.stderr
    return path


def test_model_records_the_plugin_and_refuses_without_it(user_model, rapid_program, tmp_path):
    doc = json.loads(user_model.read_text())
    [record] = doc["plugins"]
    assert record["name"] == "user_wrist_cable" and record["file"] == str(EFFECT_FILE.resolve())
    assert len(record["sha256"]) == 64
    for command in (["evaluate", str(user_model), "x.csv"], ["compensate", str(rapid_program), "--model", str(user_model), "-o", str(tmp_path / "o.mod")]):
        res = runner.invoke(app, command)
        assert res.exit_code == 2, res.stdout
        assert "plugin effect 'user_wrist_cable'" in res.stderr and f"--plugins {EFFECT_FILE.resolve()}" in res.stderr
        assert "POSTPROC_PLUGINS" in res.stderr
    assert not (tmp_path / "o.mod").exists()


def test_diagnose_suggests_commands_that_load_the_same_plugins(user_model, tmp_path):
    """A command diagnose suggests reads the model, so it repeats the --plugins it was given."""
    load_plugins([EFFECT_FILE], environ={})
    _, _, data = _simulated("geometric,user_wrist_cable", 120, seed=5, region=PROGRAM_REGION)
    del CATALOG["user_wrist_cable"]
    write_measurements(tmp_path / "meas.csv", data)
    res = runner.invoke(app, ["diagnose", str(user_model), str(tmp_path / "meas.csv"), "--plugins", str(EFFECT_FILE)])
    assert res.exit_code == 0, res.stderr
    runs = [line for line in res.stdout.splitlines() if line.strip().startswith("run: ")]
    assert runs and all(f"--plugins {EFFECT_FILE.resolve()}" in line for line in runs), res.stdout


def test_model_refuses_a_changed_plugin(user_model, tmp_path):
    changed = tmp_path / "user_wrist_cable.py"
    changed.write_text(EFFECT_FILE.read_text().replace("np.deg2rad(ctx.q_deg[:, self.by - 1])", "2 * np.deg2rad(ctx.q_deg[:, self.by - 1])"))
    load_plugins([changed], environ={})
    with pytest.raises(ModelFileError, match=r"has changed since the model was fitted \(sha256 [0-9a-f]{12} recorded"):
        load_model(user_model)
    CATALOG.pop("user_wrist_cable")
    load_plugins([EFFECT_FILE], environ={})
    model, _ = load_model(user_model)
    assert "user_wrist_cable" in model.effects.names()


@pytest.mark.slow
def test_compensate_with_a_plugin_model_in_fresh_processes(user_model, rapid_program, tmp_path):
    """The command line (--plugins) and the CAM hook (POSTPROC_PLUGINS) in new interpreters."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    env.pop(ENV, None)
    cli = subprocess.run([sys.executable, "-c", "from postproc.cli import main; main()", "compensate", str(rapid_program), "--model", str(user_model),
                          "-o", str(tmp_path / "out.mod"), "--plugins", str(EFFECT_FILE)], env=env, capture_output=True, text=True, timeout=300)
    assert cli.returncode == 0, cli.stderr
    assert "6 of 6 targets compensated" in cli.stdout
    # The CAM hook converts the KRL program to RAPID for the ABB robot and compensates it.
    hook = ("import postproc, sys; files = postproc.post(open(sys.argv[1]).read(), sys.argv[2], to='rapid', output='cam.mod'); "
            "print(sorted(files))")
    cam = subprocess.run([sys.executable, "-c", hook, str(KRL), str(user_model)], env={**env, ENV: str(EFFECT_FILE)},
                         capture_output=True, text=True, timeout=300)
    assert cam.returncode == 0, cam.stderr
    assert "cam.mod" in cam.stdout
    refused = subprocess.run([sys.executable, "-c", hook, str(KRL), str(user_model)], env=env, capture_output=True, text=True, timeout=300)
    assert refused.returncode != 0 and "which is not loaded" in refused.stderr


# ------------------------------------------------------------- predictors, dialects


def test_feature_kinds_agree_with_the_learners():
    from postproc.model.learn.features import KINDS  # here only: postproc.model.learn loads scikit-learn (seconds)

    assert predictors.FEATURE_KINDS == KINDS


@pytest.mark.parametrize("way", ["path", "environment", "entry point"])
def test_predictor_plugin_loads_each_way_fits_and_round_trips(way, tmp_path, monkeypatch):
    _load(way, PREDICTOR_FILE, "postproc.predictors", tmp_path, monkeypatch)
    assert "user_plane" in predictors.predictor_names()
    robot, truth, data = _simulated("geometric", 80, seed=5)
    physics = fit(robot, TOOL, parse_effects("geometric"), data, cv_folds=0).model
    hybrid = fit_predictor(physics, data, "user_plane")
    doc = json.loads(json.dumps(model_document(hybrid)))
    assert doc["predictor"]["estimator"]["type"] == "user_plane" and doc["plugins"][0]["kind"] == "predictor"
    again = model_from_document(doc, "m.json")
    np.testing.assert_array_equal(again.predict(data), hybrid.predict(data))
    del predictors.PREDICTORS["user_plane"]
    with pytest.raises(ModelFileError, match="predictor 'user_plane'.*not loaded"):
        model_from_document(doc, "m.json")


def test_fit_command_takes_a_plugin_predictor(tmp_path):
    robot, _, data = _simulated("geometric", 60, seed=6)
    write_measurements(tmp_path / "d.csv", data)
    res = runner.invoke(app, ["fit", str(tmp_path / "d.csv"), "--robot", ROBOT, "--tool", "0,0,250", "--effects", "geometric",
                              "--predictor", "user_plane", "-o", str(tmp_path / "m.json"), "--plugins", str(PREDICTOR_FILE)])
    assert res.exit_code == 0, res.stderr
    unknown = runner.invoke(app, ["fit", str(tmp_path / "d.csv"), "--robot", ROBOT, "--tool", "0,0,250", "--effects", "geometric", "--predictor", "user_plane2",
                                  "-o", str(tmp_path / "n.json")])
    assert unknown.exit_code == 2 and "user_plane" in unknown.stderr


@pytest.mark.parametrize("way", ["path", "environment", "entry point"])
def test_dialect_plugin_loads_each_way_and_reads_programs(way, tmp_path, monkeypatch):
    from postproc.programs import parse_program

    _load(way, DIALECT_FILE, "postproc.dialects", tmp_path, monkeypatch)
    assert dialects.get("user_krl").name == "user_krl"
    program = tmp_path / "pass.usrc"
    shutil.copy(REPO / "examples/data/block_pass.src", program)
    assert dialects.sniff(program).name == "user_krl"
    assert len(parse_program(program, None)) == len(parse_program(REPO / "examples/data/block_pass.src", None))


def test_dialect_plugin_on_the_command_line(tmp_path):
    res = runner.invoke(app, ["inspect", str(REPO / "examples/data/block_pass.src"), "--dialect", "user_krl", "--plugins", str(DIALECT_FILE)])
    assert res.exit_code == 0, res.stderr
    del dialects.REGISTRY["user_krl"]  # as in a new process without --plugins
    without = runner.invoke(app, ["inspect", str(REPO / "examples/data/block_pass.src"), "--dialect", "user_krl"])
    assert without.exit_code == 2 and "user_krl" in without.stderr


@pytest.mark.slow
def test_batch_workers_load_the_plugins_the_command_was_given(user_model, rapid_program, tmp_path):
    """Dask worker processes load the --plugins files before the model (batch.ModelPlugin)."""
    inputs, out_dir = tmp_path / "in", tmp_path / "out"
    inputs.mkdir()
    out_dir.mkdir()
    programs = [shutil.copy(rapid_program, inputs / f"pass{k}.mod") for k in range(2)]
    res = runner.invoke(app, ["compensate", *map(str, programs), "--model", str(user_model), "--out-dir", str(out_dir), "--jobs", "1",
                              "--plugins", str(EFFECT_FILE)])
    assert res.exit_code == 0, res.stdout + res.stderr
    assert sorted(p.name for p in out_dir.iterdir()) == ["pass0.mod", "pass1.mod"]


@pytest.mark.slow
def test_streamed_workers_compensate_with_a_plugin_model(tmp_path):
    """compensate --stream's forked workers resolve the plugin effect as this process does.

    Streaming reads KRL, so the robot is a KUKA measured in seed 001's cylinder, and the
    program is block_pass's header with $BASE moved into that region."""
    from postproc.jobs.compensate import compensate
    from postproc.jobs.program_check import check_model_fits
    from postproc.jobs.stream import compensate_streamed
    from postproc.programs import emit_texts, parse_program

    user_model = _user_model(tmp_path / "kuka.json", KUKA, None)
    head = [line.replace("$BASE = {X 1400, Y 200, Z 1170,", "$BASE = {X 950, Y -100, Z 300,") for line in KRL.read_text().splitlines()[:6]]
    assert any(line.startswith("$BASE = {X 950,") for line in head)
    moves = [f"LIN {{X {0.2 * i:.1f}, Y {50 + 10 * np.sin(i / 9):.3f}, Z 100, A 0, B 180, C 0}}" for i in range(240)]
    program = tmp_path / "long.src"
    program.write_text("\n".join(head + ["PTP {X 0, Y 50, Z 150, A 0, B 180, C 0}"] + moves + ["END"]) + "\n", encoding="latin-1")
    load_plugins([EFFECT_FILE], environ={})
    model, _ = load_model(user_model)
    tp = parse_program(program)
    check_model_fits(tp, model, str(user_model))  # the robot is the program's (raises if not)
    new, rep = compensate(tp, model)
    assert not rep.failed.any()
    result = compensate_streamed(program, model, tmp_path / "streamed.src", chunk_lines=50, workers=2)
    assert result.summary["chunks"] > 3
    assert (tmp_path / "streamed.src").read_text(encoding="latin-1") == emit_texts(tp, new)[0]


def test_a_plugin_effect_unpickles_in_a_process_that_never_loaded_it(tmp_path):
    """A spawned worker (stream, Dask) gets the model pickled: the plugin file is loaded on unpickling."""
    load_plugins([EFFECT_FILE], environ={})
    effect = parse_effects("user_wrist_cable[joints=4,6;by=5]").effects[0]
    (tmp_path / "effect.pickle").write_bytes(pickle.dumps(effect))
    code = "import pickle, sys; e = pickle.loads(open(sys.argv[1], 'rb').read()); print(e.spec(), e.joints)"
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "effect.pickle")], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "user_wrist_cable[joints=4,6;by=5] (4, 6)"

"""The built-in scenarios, models and worlds: at the top level of kartci's repository (a kartci
project like any team's), carried inside the package by the wheel, found by one resolver."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from kartci import project
from kartci.errors import SpecError

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("scenarios", "models", "sims")


def test_a_checkout_finds_the_builtin_folders_at_its_top_level(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert project.shipped_root() == project.SHIPPED == ROOT
    assert not project.PACKAGED.exists()  # only a wheel has it
    monkeypatch.setenv("KARTCI_ROOT", str(tmp_path))  # an empty project: built-ins only
    proj = project.find_project()
    assert proj.scenario_path[-1] == project.BUILTIN_SCENARIOS == ROOT / "scenarios"
    assert proj.world_path[-1] == project.BUILTIN_SIMS == ROOT / "sims"
    assert proj.model_path[-1] == project.BUILTIN_MODELS == ROOT / "models"
    assert proj.find_scenario("line_straight") == ROOT / "scenarios" / "line_straight.yaml"
    assert proj.find_world("winti/hall") == ROOT / "sims" / "winti" / "hall.yaml"
    assert proj.find_model("gokart") == ROOT / "models" / "gokart" / "params.yaml"
    assert proj.origin_of(proj.find_scenario("line_straight")) is project.Origin.BUILTIN


def test_an_installed_wheel_finds_them_inside_the_package(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    packaged = tmp_path / "site-packages" / "kartci" / "data" / "builtin"
    for name in FOLDERS:
        (packaged / name).mkdir(parents=True)
    monkeypatch.setattr(project, "PACKAGED", packaged)
    assert project.shipped_root() == packaged


def _tracked(folder: str) -> list[str]:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: its files cannot be listed")
    out = subprocess.run(["git", "ls-files", "-z", "--", folder], cwd=ROOT, check=True,
                         capture_output=True).stdout.decode()
    return sorted(p for p in out.split("\0") if p)


@pytest.mark.parametrize("folder", FOLDERS)
def test_the_wheel_carries_every_data_file_where_the_resolver_looks(folder: str) -> None:
    """pyproject.toml's packaging rule, applied by the build backend itself (no wheel built):
    every file of the folder lands under `project.PACKAGED`, but the scripts that generated
    the data files."""
    wheel = pytest.importorskip("hatchling.builders.wheel",
                                reason='hatchling not installed: pip install -e ".[dev]"')
    shipped = {f.relative_path.replace("\\", "/"): f.distribution_path.replace("\\", "/")
               for f in wheel.WheelBuilder(str(ROOT)).recurse_included_files()}
    inside = project.PACKAGED.relative_to(ROOT).as_posix()
    files = _tracked(folder)
    assert files
    expected = {rel: f"{inside}/{rel}" for rel in files if not rel.endswith(".py")}
    assert {rel: shipped.get(rel) for rel in files} == {
        rel: expected.get(rel) for rel in files}


def test_a_scenario_is_loaded_in_the_project_handed_in_and_carries_it(tmp_path: Path) -> None:
    """No lookup of the working directory below the entry points (issue 41): the scenario is
    found in the project handed in, a URDF named relative to its kind (here by `--set`) is
    resolved on that project's model path when it loads, and the scenario carries the project
    to what runs it (across a pickle: a worker process, a Ray task), outside its value."""
    import pickle

    from kartci.scenario import load_scenario
    from kartci.sim.session import build_world

    (tmp_path / "kartci.toml").write_text("")
    (tmp_path / "scenarios").mkdir()
    shutil.copy(ROOT / "scenarios" / "line_straight.yaml", tmp_path / "scenarios" / "mine.yaml")
    urdf = tmp_path / "models" / "line_tracker" / "ours.urdf"
    urdf.parent.mkdir(parents=True)
    shutil.copy(ROOT / "models" / "line_tracker" / "line_tracker.urdf", urdf)
    proj = project.find_project(tmp_path)
    spec = load_scenario("mine", ["agents.lt0.model.urdf=ours.urdf"], project=proj)
    assert spec.project == proj
    assert spec.agents["lt0"].model.urdf == str(urdf)
    assert pickle.loads(pickle.dumps(spec)).project == proj
    assert "project" not in spec.model_dump()
    assert spec == spec.model_validate_json(spec.model_dump_json(), context=spec_context())
    with pytest.raises(SpecError, match="unknown scenario 'mine'"):
        load_scenario("mine", project=project.find_project(ROOT))
    world = build_world(spec)
    try:
        assert [r.name for r in world.robots] == ["lt0"]
    finally:
        world.close()


def spec_context() -> dict[str, object]:
    """The validation context a recorded scenario is read back with (every registry)."""
    from kartci.core import DEFAULT_REGISTRIES
    from kartci.scenario.dispatch import context

    return context(DEFAULT_REGISTRIES)

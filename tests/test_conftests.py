"""Each test folder's fixtures live in its own conftest.py, which must be inside a package:
two conftest.py files outside packages are both the module `conftest` to mypy ("Duplicate module
named 'conftest'"), and pytest would import them under one name."""

from __future__ import annotations

from pathlib import Path

TESTS = Path(__file__).resolve().parent


def conftests_outside_packages(root: Path = TESTS) -> list[str]:
    """Every conftest.py below `root` (not `root`'s own) in a folder that is not a package,
    or below a folder between it and `root` that is not one."""
    found = []
    for path in sorted(root.rglob("conftest.py")):
        folders = path.relative_to(root).parents
        if path.parent != root and any(not (root / f / "__init__.py").is_file()
                                       for f in list(folders)[:-1]):
            found.append(path.relative_to(root).as_posix())
    return found


def test_every_folder_conftest_is_in_a_package() -> None:
    assert (TESTS / "conftest.py").is_file()
    assert conftests_outside_packages() == []


def test_the_scan_finds_what_it_looks_for(tmp_path: Path) -> None:
    """A conftest in a plain folder, or in a package below a plain folder, is caught."""
    for folder in ("a", "b/c", "d/e"):
        (tmp_path / folder).mkdir(parents=True)
        (tmp_path / folder / "conftest.py").write_text("")
    for package in ("a", "b/c", "d", "d/e"):
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "conftest.py").write_text("")
    (tmp_path / "f").mkdir()
    (tmp_path / "f/conftest.py").write_text("")
    assert conftests_outside_packages(tmp_path) == ["b/c/conftest.py", "f/conftest.py"]

"""Plugin discovery through real installed entry points, collisions, broken plugins, `list`."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from gdabench import DesignerSpec, hookimpl
from gdabench.errors import PluginError, UnknownPluginError
from gdabench.plugins import Registry

FIXTURE = Path(__file__).parent / "fixtures" / "hello_plugin"


def pip_install(source: Path, target: Path) -> Path:
    """Install a plugin package with pip into ``target`` (a directory put on PYTHONPATH)."""
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(target),
            str(source),
        ],
        check=True,
        capture_output=True,
    )
    return target


def gdabench_cli(*args: str, path: Path | None = None, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200")
    if path is not None:
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(path), env.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "gdabench", *args], capture_output=True, text=True, env=env, cwd=cwd)


def make_package(root: Path, dist: str, module: str, body: str) -> Path:
    (root / module).mkdir(parents=True)
    (root / module / "__init__.py").write_text(textwrap.dedent(body))
    (root / "pyproject.toml").write_text(
        textwrap.dedent(
            f"""
            [build-system]
            requires = ["setuptools>=68"]
            build-backend = "setuptools.build_meta"
            [project]
            name = "{dist}"
            version = "0.0.1"
            [project.entry-points.gdabench]
            {module} = "{module}"
            [tool.setuptools]
            packages = ["{module}"]
            """
        )
    )
    return root


@pytest.fixture(scope="module")
def hello_site(tmp_path_factory) -> Path:
    src = tmp_path_factory.mktemp("src") / "hello_plugin"
    shutil.copytree(FIXTURE, src)
    return pip_install(src, tmp_path_factory.mktemp("site"))


def test_installed_entry_point_is_discovered_with_its_package(hello_site, tmp_path):
    listing = gdabench_cli("list", path=hello_site)
    assert listing.returncode == 0, listing.stderr
    line = next(ln for ln in listing.stdout.splitlines() if "hello-climber" in ln)
    assert "gdabench-hello-plugin 1.2.3" in line and "Hill climber from a third-party package" in line
    assert "hello-count" in listing.stdout
    ga_line = next(ln for ln in listing.stdout.splitlines() if ln.strip().startswith("ga "))
    assert "gdabench" in ga_line
    out = tmp_path / "run"
    run = gdabench_cli(
        "compare",
        "--designers",
        "hello-climber,ga",
        "--env",
        "hello-count",
        "--budget",
        "50",
        "--out",
        str(out),
        "-q",
        path=hello_site,
    )
    assert run.returncode == 0, run.stderr
    import json

    meta = json.loads((out / "run.json").read_text())
    assert meta["versions"]["plugins"]["gdabench-hello-plugin"] == "1.2.3"


def test_list_does_not_import_torch(hello_site):
    code = "import sys, gdabench.cli as c; c.app(['list'], standalone_mode=False); print('torch' in sys.modules)"
    env = dict(os.environ, PYTHONPATH=str(hello_site))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "False"


def test_broken_plugin_gives_one_line_naming_it(tmp_path):
    src = make_package(tmp_path / "src", "gdabench-broken", "broken_plugin", "raise ImportError('needs libfoo')\n")
    site = pip_install(src, tmp_path / "site")
    result = gdabench_cli("list", path=site)
    assert result.returncode == 2
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1
    assert "plugin 'broken_plugin' from package gdabench-broken failed to import" in lines[0]
    assert "ImportError: needs libfoo" in lines[0] and "Traceback" not in result.stderr
    skipped = subprocess.run(
        [sys.executable, "-m", "gdabench", "list"],
        capture_output=True,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(site), GDABENCH_DISABLE_PLUGINS="broken_plugin"),
    )
    assert skipped.returncode == 0


def test_name_collision_names_both_packages(tmp_path):
    body = """
        import gdabench
        @gdabench.hookimpl
        def gdabench_designers():
            return [gdabench.DesignerSpec("ga", "gdabench.designers.ga:GeneticAlgorithm", "a copy")]
        """
    site = pip_install(make_package(tmp_path / "src", "gdabench-clash", "clash_plugin", body), tmp_path / "site")
    result = gdabench_cli("list", path=site)
    assert result.returncode == 2
    assert "designer name 'ga' is provided twice" in result.stderr
    assert "package gdabench)" in result.stderr and "package gdabench-clash)" in result.stderr


def test_a_misspelt_hook_is_one_line_naming_plugin_and_function(tmp_path):
    body = """
        import gdabench
        @gdabench.hookimpl
        def gdabench_designer():
            return []
        """
    site = pip_install(make_package(tmp_path / "src", "gdabench-typo", "typo_plugin", body), tmp_path / "site")
    result = gdabench_cli("list", path=site)
    lines = [ln for ln in result.stderr.splitlines() if ln.strip()]
    assert result.returncode == 2 and len(lines) == 1, result.stderr
    assert "plugin 'typo_plugin' from package gdabench-typo: gdabench_designer() is not a gdabench hook" in lines[0]
    assert "gdabench_designers" in lines[0]  # the hooks it could have meant


def test_a_hook_without_its_marker_is_refused():
    class Unmarked:
        def gdabench_designers(self):
            return []

    with pytest.raises(
        PluginError,
        match=r"plugin 'quiet' from package <in-process>: gdabench_designers\(\) lacks the @gdabench.hookimpl marker",
    ):
        Registry(entry_points=False, extra_plugins={"quiet": Unmarked()})


def test_registry_checks_spec_types_and_lookup():
    class Wrong:
        @hookimpl
        def gdabench_designers(self):
            return ["not a spec"]

    with pytest.raises(PluginError, match="returned str, expected DesignerSpec"):
        Registry(entry_points=False, extra_plugins={"wrong": Wrong()})

    class Raising:
        @hookimpl
        def gdabench_designers(self):
            raise RuntimeError("oops")

    with pytest.raises(PluginError, match="plugin 'raising'.*raised RuntimeError: oops"):
        Registry(entry_points=False, extra_plugins={"raising": Raising()})

    reg = Registry(entry_points=False)
    assert {"ga", "random"} <= set(reg.names("designer")) and "simple" in reg.names("environment")
    assert reg.get("designer", "ga").distribution == "gdabench"
    with pytest.raises(UnknownPluginError, match="unknown designer 'gaa'.*Did you mean 'ga'"):
        reg.get("designer", "gaa")


def test_bad_factory_strings_are_reported():
    with pytest.raises(PluginError, match="must look like 'package.module:attribute'"):
        DesignerSpec("x", "no_colon", "d")
    with pytest.raises(PluginError, match="cannot load 'nowhere.module:Thing'"):
        DesignerSpec("x", "nowhere.module:Thing", "d").load()
    with pytest.raises(PluginError, match="invalid designer name"):
        DesignerSpec("has space", "a:b", "d")

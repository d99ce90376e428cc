"""vto_core must load without bpy and torch, so the CLI and ONNX inference stay light."""

import subprocess
import sys

import pytest

from vto_core import cli


def test_importing_vto_core_loads_neither_bpy_nor_torch():
    code = (
        "import sys, pkgutil, importlib, vto_core\n"
        "for m in pkgutil.iter_modules(vto_core.__path__): importlib.import_module('vto_core.' + m.name)\n"
        "bad = [m for m in ('bpy', 'torch', 'mathutils') if m in sys.modules]\n"
        "print(','.join(bad)); sys.exit(1 if bad else 0)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, f"vto_core imported {done.stdout.strip()} {done.stderr[-500:]}"


def test_cli_errors_are_one_line_and_nonzero(capsys):
    assert cli.run(["spec", "lipstick", "--params", "red,nope"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown lipstick parameter(s) nope" in err[0]
    assert cli.run(["frobnicate"]) == 2


def test_cli_spec_and_sample_output(capsys):
    import json

    assert cli.run(["spec", "hair", "--params", "shine,hue"]) == 0
    spec = json.loads(capsys.readouterr().out)
    assert spec["vector_order"] == ["hue", "shine"]
    assert cli.run(["sample", "hair", "--n", "2", "--seed", "4", "--params", "hue"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [line["index"] for line in lines] == [0, 1] and 0 <= lines[0]["params"]["hue"] < 1
    assert cli.run(["sample", "hair", "--n", "0"]) == 2


@pytest.mark.parametrize("argv", [["--help"]])
def test_cli_help_lists_commands(argv, capsys):
    assert cli.run(argv) == 0
    assert "spec" in capsys.readouterr().out


def test_a_command_whose_layer_is_missing_is_one_line(capsys, monkeypatch):
    """Inside Blender the pipeline and training layers are absent: `vto eval` says what it needs, exit 2."""
    monkeypatch.setitem(sys.modules, "pipeline", None)
    monkeypatch.delitem(sys.modules, "pipeline.cli", raising=False)
    assert cli.run(["eval", "--model", "m.onnx", "--out", "x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "needs the module 'pipeline'" in err[0]

"""scripts/train_encoder.sh runs each product's declared Recipe (vto_core.products): its dry run (DRY_RUN=1) prints the
vto commands with the recipe's values; an unknown product is one usage line naming the registry's products, exit 2."""

import os
import shlex
import subprocess
from pathlib import Path

import pytest

from vto_core.products import PRODUCTS

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = ROOT / "scripts" / "train_encoder.sh"
RECIPES = {name: product.recipe for name, product in PRODUCTS.items() if product.recipe is not None}


def dry_run(*args: str, **env: str) -> subprocess.CompletedProcess:
    clean = {k: v for k, v in os.environ.items() if k not in ("N", "STEPS", "WORKERS", "REFINE")}
    return subprocess.run(["bash", str(SCRIPT), *args], capture_output=True, text=True, timeout=120,
                          env={**clean, "DRY_RUN": "1", **env})


@pytest.mark.parametrize("name", RECIPES)
def test_the_dry_run_prints_the_recipes_commands(name):
    recipe = RECIPES[name]
    done = dry_run(name)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert all(line.startswith("vto ") for line in lines), lines
    datasets = [line for line in lines if line.startswith("vto dataset ")]
    main = datasets[0]
    assert f"--out {recipe.data} " in main and f"--seed {recipe.seed} " in main
    assert f"--n {recipe.looks} " in main and f"--workers {recipe.workers}" in main
    assert main.endswith(f" {recipe.data_args}" if recipe.data_args else f"--workers {recipe.workers}")
    train = next(line for line in lines if line.startswith("vto train encoder "))
    assert f"--data {(recipe.varied + ' ') if recipe.varied else ''}{recipe.data} " in train
    assert recipe.train_args in train and f"--set steps={recipe.steps} " in train
    if recipe.varied:
        assert any(f"--out {recipe.varied} " in line and line.endswith(recipe.varied_args) for line in datasets)
    colour = [line for line in lines if line.startswith("vto train colour ")]
    if recipe.colour == "none":
        assert colour == [] and len(datasets) == 1 + bool(recipe.varied)
    else:
        own = shlex.split(recipe.colour_args)
        expected = own[own.index("--out") + 1] if recipe.colour == "own" else f"{recipe.varied} {recipe.data}".strip()
        assert len(colour) == 1 and f"--data {expected} " in colour[0]
        assert colour[0].endswith(f"--set steps={recipe.colour_steps}")
        if recipe.colour == "own":
            assert any(recipe.colour_args in line for line in datasets)
    assert lines[-1].startswith("vto eval ") and f"--refine {recipe.refine} " in lines[-1]


def test_the_environment_overrides_looks_steps_and_workers():
    name = next(iter(RECIPES))
    lines = dry_run(name, N="10", STEPS="7", WORKERS="3").stdout.splitlines()
    assert "--n 10 " in lines[0] and "--workers 3" in lines[0]
    assert any(line.startswith("vto train encoder ") and "--set steps=7 " in line for line in lines)


@pytest.mark.parametrize("args", [("nail",), ()], ids=["unknown", "none"])
def test_an_unknown_product_is_one_usage_line_and_exit_2(args):
    done = dry_run(*args)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.strip().splitlines() == [f"usage: scripts/train_encoder.sh {'|'.join(RECIPES)}"]

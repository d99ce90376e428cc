"""`vto demo`: the paper's whole pipeline on the default scene, from renders to an evaluated ONNX encoder and a report.

Stages (each reused on a rerun when its stamp holds the same settings, redone when they changed; an unfinished
stage resumes, as datasets and training runs do):

    1. imitator data   `vto dataset R --sensitivity` (small: (m + 2) renders a look)
    2. encoder data    `vto dataset R` (more looks, 2 renders each; same size and spp)
    3. imitator        `vto train imitator` (imitation + sensitivity + adversarial terms)
    4. encoder         `vto train encoder --set loss=both` through the frozen imitator
    5. export          `vto export` -> DIR/encoder.onnx
    6. evaluation      `vto eval` on fresh looks: encoder, mean and nearest preset, refinements, and the shipped
                       model of the same spec where there is one (`--compare`)
    7. report          DIR/report/index.html, self-contained (images as data URIs); its path is the last line printed
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import json
import shutil
import sys
import time
from pathlib import Path

from vto_core.cli import ArgumentParser
from vto_core.errors import VtoError
from vto_core.products import product_names

from .demo_sizes import COMMON, SIZES, DemoSize

IMITATOR_DATA_SEED, ENCODER_DATA_SEED = 1, 2  # two disjoint sets of looks and sources
EVAL_SEED = 777  # `vto eval`'s default: looks and sources no dataset draws


def banner(text: str) -> None:
    """A stage line on stderr, flushed so it shows between progress bars."""
    print(f"\n== vto demo: {text}", file=sys.stderr, flush=True)


class Stages:
    """Runs named stages once per settings: DIR/stamps/<name>.json records the settings, whether it finished, and
    how long it took."""

    def __init__(self, out: Path, total: int):
        self.stamps, self.total, self.timings = out / "stamps", total, []
        self.stamps.mkdir(parents=True, exist_ok=True)

    def run(self, name: str, title: str, settings: dict, outputs: list[Path], work) -> None:
        """work() unless a finished stamp has the same settings and the outputs exist; changed settings: outputs
        removed first."""
        settings = json.loads(json.dumps(settings))
        path = self.stamps / f"{name}.json"
        stamp = json.loads(path.read_text()) if path.is_file() else None
        number = len(self.timings) + 1
        if stamp and stamp["settings"] == settings and stamp["finished"] and all(p.exists() for p in outputs):
            banner(f"[{number}/{self.total}] {title}: reused ({stamp['seconds']:.0f} s when made)")
            self.timings.append({"stage": title, "reused": True, "seconds": stamp["seconds"]})
            return
        if stamp is None or stamp["settings"] != settings:  # made with other settings (or by hand): start over
            for output in outputs:
                if output.is_dir():
                    shutil.rmtree(output)
                else:
                    output.unlink(missing_ok=True)
        resumed = stamp is not None and stamp["settings"] == settings
        _write_json(path, {"settings": settings, "finished": False, "seconds": None})
        banner(f"[{number}/{self.total}] {title}{' (resumed)' if resumed else ''}")
        started = time.perf_counter()
        with contextlib.redirect_stdout(sys.stderr):  # the commands' JSON lines; stdout ends with the page's path
            work()
        seconds = time.perf_counter() - started
        _write_json(path, {"settings": settings, "finished": True, "seconds": seconds})
        self.timings.append({"stage": title, "reused": False, "seconds": seconds})
        banner(f"[{number}/{self.total}] {title}: done in {seconds:.0f} s")


def _write_json(path: Path, value) -> None:
    temporary = path.with_name(path.name + ".tmp")
    temporary.write_text(json.dumps(value, indent=1) + "\n")
    temporary.replace(path)


def shipped_model(renderer: str) -> Path | None:
    """blender_addon/models/<renderer>_encoder.onnx where the add-on ships one."""
    found = importlib.util.find_spec("blender_addon")
    for folder in (found.submodule_search_locations or []) if found else []:
        path = Path(folder) / "models" / f"{renderer}_encoder.onnx"
        if path.is_file():
            return path
    return None


def shipped_comparison(renderer: str, spec, res: int) -> tuple[Path | None, str]:
    """(the shipped model to evaluate on the same references, or None; a sentence for the report)."""
    from vto_core.inference import EncoderSession

    path = shipped_model(renderer)
    if path is None:
        return None, f"No {renderer} model ships with the add-on yet (blender_addon/models/{renderer}_encoder.onnx)."
    session = EncoderSession(path)
    if not session.spec.same_as(spec) or tuple(session.input_size) != (res, res):
        return None, (f"The shipped {path.name} estimates [{', '.join(session.spec.modelled)}] from "
                      f"{session.input_size[0]} px images; this demo's encoder estimates [{', '.join(spec.modelled)}] "
                      f"from {res} px ones, so it cannot be evaluated on the same references.")
    return path, f"The shipped {path.name} (same spec and input size) is evaluated on the same references."


def _digest(path: Path | None) -> str | None:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16] if path else None


def run_demo(renderer: str, size_name: str, out: Path) -> Path:
    """Every stage in order (reusing finished ones); returns the report page."""
    from vto_core.products import get_spec

    size: DemoSize = SIZES[size_name]
    params = size.params(renderer)
    spec = get_spec(renderer, params)
    out.mkdir(parents=True, exist_ok=True)
    stages = Stages(out, 7)
    data_i, data_e = out / "data" / "imitator", out / "data" / "encoder"
    run_i, run_e = out / "runs" / "imitator", out / "runs" / "encoder"
    model, eval_dir = out / "encoder.onnx", out / "eval"

    # 1-2. Datasets: the same renderer, size and spp; sensitivity renders only where the imitator needs them.
    def dataset_args(folder: Path, n: int, seed: int, sensitivity: bool) -> list[str]:
        return [renderer, "--out", str(folder), "--n", str(n), "--seed", str(seed), "--res", str(size.res),
                "--samples", str(size.samples), *(["--params", params] if params else []),
                *(["--sensitivity"] if sensitivity else size.source_args(renderer))]

    def dataset(argv: list[str]):
        def work():
            from blender_addon.datasets.commands import cmd_dataset

            cmd_dataset(argv)
        return work

    args_i = dataset_args(data_i, size.n_imitator, IMITATOR_DATA_SEED, True)
    args_e = dataset_args(data_e, size.n_encoder, ENCODER_DATA_SEED, False)
    # Every stamp holds the spec too: a spec changed in the code (an encoding, a range) remakes everything.
    made_for = spec.to_dict()
    stages.run("data_imitator", f"imitator data: {size.n_imitator} looks with sensitivity renders, {size.res} px, "
               f"{size.samples} spp", {"argv": args_i, "spec": made_for}, [data_i], dataset(args_i))
    stages.run("data_encoder", f"encoder data: {size.n_encoder} looks, {size.res} px, {size.samples} spp",
               {"argv": args_e, "spec": made_for}, [data_e], dataset(args_e))

    # 3. Imitator: the paper's loss with the sensitivity term.
    imitator_set = [*COMMON, *size.imitator, "use_sensitivity=true"]

    def train_imitator_stage():
        from training.config import ImitatorConfig, resolve_config
        from training.train_imitator import train_imitator

        train_imitator(str(data_i), str(run_i), resolve_config(ImitatorConfig, None, imitator_set))

    imitator_made = {"data": args_i, "set": imitator_set, "spec": made_for}
    stages.run("imitator", "imitator (imitation + sensitivity + adversarial)", imitator_made, [run_i],
               train_imitator_stage)

    # 4. Encoder: graphics loss + rendering loss through the frozen imitator.
    encoder_set = [*COMMON, *size.encoder, "loss=both"]

    def train_encoder_stage():
        from training.config import EncoderConfig, resolve_config
        from training.train_encoder import train_encoder

        train_encoder(str(data_e), str(run_i), str(run_e), resolve_config(EncoderConfig, None, encoder_set))

    trained = {"data": args_e, "imitator": imitator_made, "set": encoder_set, "spec": made_for}
    stages.run("encoder", "encoder (graphics + rendering loss through the imitator)", trained, [run_e],
               train_encoder_stage)

    # 5. ONNX export (checked against torch).
    def export_stage():
        from training.export import export_encoder

        export_encoder(str(run_e), str(model))

    stages.run("export", "ONNX export", trained, [model], export_stage)

    # 6. Transfer evaluation on fresh looks, with the shipped model where it is comparable.
    shipped, shipped_note = shipped_comparison(renderer, spec, size.res)
    compare = (("shipped encoder", str(shipped)),) if shipped else ()

    def eval_stage():
        from .evaluate import EvalSettings, run_eval

        run_eval(str(model), str(eval_dir), EvalSettings(size.eval_n, size.res, size.samples, EVAL_SEED,
                                                         size.refine, (), str(run_i), compare))

    stages.run("eval", f"evaluation on {size.eval_n} fresh looks", {
        "trained": trained, "n": size.eval_n, "seed": EVAL_SEED, "refine": size.refine,
        "shipped": _digest(shipped)}, [eval_dir / "results.json"], eval_stage)

    # 7. Report.
    from .demo_report import write_report

    banner("[7/7] report")
    context = {"renderer": renderer, "size": size_name, "spec": list(spec.modelled), "settings": size,
               "shipped_note": shipped_note, "timings": stages.timings,
               "commands": commands(renderer, args_i, args_e, imitator_set, encoder_set, size, run_i, run_e, model,
                                    eval_dir)}
    return write_report(out, context)


def commands(renderer, args_i, args_e, imitator_set, encoder_set, size: DemoSize, run_i, run_e, model, eval_dir):
    """The `vto` command lines the stages are equivalent to (shown in the report)."""
    sets = lambda items: " ".join(f"--set {item}" for item in items)  # noqa: E731
    refine = f" --refine {','.join(size.refine)}" if size.refine else ""
    return [f"vto dataset {' '.join(args_i)}", f"vto dataset {' '.join(args_e)}",
            f"vto train imitator --data {args_i[2]} --out {run_i} {sets(imitator_set)}",
            f"vto train encoder --data {args_e[2]} --imitator {run_i} --out {run_e} {sets(encoder_set)}",
            f"vto export --encoder {run_e} --out {model}",
            f"vto eval --model {model} --imitator {run_i} --n {size.eval_n} --res {size.res} --samples {size.samples}"
            f" --seed {EVAL_SEED}{refine} --out {eval_dir}"]


def cmd_demo(argv: list[str]) -> int:
    """vto demo [--renderer PRODUCT] [--size smoke|small|full] --out DIR."""
    parser = ArgumentParser(prog="vto demo", description="the whole pipeline on the default scene: datasets, "
                                                         "imitator, encoder, ONNX export, evaluation, HTML report")
    parser.add_argument("--renderer", choices=product_names(), default=product_names()[0])
    parser.add_argument("--size", choices=list(SIZES), default="full",
                        help="full: about 18 minutes on 2 CPU cores; small: about 4; smoke: under 2 (CI)")
    parser.add_argument("--out", default="out/demo", help="working folder; a rerun reuses its finished stages")
    args = parser.parse_args(argv)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise VtoError(f"--out {out} is a file, not a folder")
    page = run_demo(args.renderer, args.size, out)
    print(page)
    return 0
